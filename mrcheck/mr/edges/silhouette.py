"""Contour samples of the rendered parts: the silhouette term of the edge registration.

Why: a scanned or smooth mesh (the objects of BOP LM-O, a pipe, a tank) has almost no crease
edges, and its facet edges are under the 2 px on screen that
:func:`~mrcheck.mr.edges.model.sample_edges` samples, so the mesh-edge model finds (almost) no
samples on it. Its outline is
still in the photo: region-based trackers (RBOT, Tjaden et al. 2018; SRT3D, Stoiber et al. 2022,
section 4 "correspondence lines") sample the contour of the rendered object mask and search the
photo along each contour point's normal. Here the contour is taken from the depth buffer the
fit renders anyway for visibility: a foreground pixel is on a contour when a 4-neighbour is
background or more than :data:`DEPTH_STEP` farther (one part before another). Each contour
pixel becomes a 3D point on the surface (back-projected at its own depth) with a 3D tangent
whose projection is the contour's direction, so it moves with the pose like an edge sample
and is matched by the same search along the normal; they are found again at every re-render.

Limits: a contour point is a pixel of the render (at most 800 px wide, see
:mod:`mrcheck.mr.edges.fitter`) shifted half a pixel outwards, so its position carries up to
about a quarter of a render pixel of quantisation error (the mesh edges, exact in 3D, do not);
and a contour point is not a fixed point of the surface (the rim slides over a curved surface
as the view turns), which the re-render after every ``rerender_px`` corrects.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy.spatial import cKDTree

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import model

FLAT_DEG = 1.0  # faces meeting at less than this are one plane (a quad's diagonal), not a curved surface
DEPTH_STEP = 0.03  # a neighbour this share farther is another surface behind: an occluding contour
_NORMAL_BLUR = 1.5  # render px: the inverse depth smoothed this much gives the contour's normal
_HALF = 0.5  # render px: a contour pixel's centre lies this far inside the outline (its border)


class ContourModel:
    """Assigns contour points to the scene's instances: the instance of the nearest mesh-edge
    midpoint (the render has no instance buffer); built once per fit."""

    def __init__(self, edges: model.EdgeSet):
        self.edges = edges
        self.tree = cKDTree(edges.mid) if len(edges) else None

    def nearest_edge(self, points: np.ndarray) -> np.ndarray:
        if self.tree is None or len(points) == 0:
            return np.zeros(len(points), np.int64)
        return np.asarray(self.tree.query(points)[1], np.int64)


def curved_parts(edges: model.EdgeSet) -> np.ndarray:
    """(instances,) bool: the parts whose edges between faces meeting at :data:`FLAT_DEG` to
    :data:`~mrcheck.mr.edges.model.CREASE_DEG` (the facets of a curved surface: a scan, a
    pipe, a bottle) are longer in all than their crease edges, so that their outline is mostly
    the contour of a curved surface, which the mesh edges model only as facets under a pixel
    long or as a polygon.

    Why per part and from the mesh: the outline term on parts of boxes and profiles (whose
    outline is crease edges, exact in 3D) cost the generated cell every fit
    (``mrcheck bench --edges --quick``: 3 of 3 failed with the outline of every part, 3 of 3
    within 0.5 px without), while the scanned objects of BOP LM-O have almost no creases."""
    groups = len(edges.group_names)
    if len(edges) == 0:
        return np.zeros(groups, bool)
    length = np.linalg.norm(edges.b - edges.a, axis=1)
    cos = np.abs(np.einsum("ij,ij->i", edges.na, edges.nb))
    curved = ~edges.crease & (cos < math.cos(math.radians(FLAT_DEG)))
    crease_len = np.bincount(edges.group, weights=np.where(edges.crease, length, 0.0), minlength=groups)
    curved_len = np.bincount(edges.group, weights=np.where(curved, length, 0.0), minlength=groups)
    return curved_len > crease_len


def contour_pixels(depth: np.ndarray) -> np.ndarray:
    """(H, W) bool: foreground pixels with a 4-neighbour that is background or more than
    :data:`DEPTH_STEP` farther."""
    far = np.where(depth > 0, depth, np.float32(3e38)).astype(np.float32)
    # the farthest of the 4-neighbourhood (a grey dilation with a cross)
    farthest = cv2.dilate(far, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3)), borderType=cv2.BORDER_REPLICATE)
    return (depth > 0) & (farthest > depth * (1.0 + DEPTH_STEP))


def _outward_normals(depth: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(n, 2) unit image normals pointing away from the pixel's surface: down the gradient of
    the smoothed inverse depth (0 on the background), which drops across every contour."""
    inverse = np.where(depth > 0, 1.0 / np.maximum(depth, 1e-12), 0.0).astype(np.float32)
    inverse /= max(float(inverse.max()), 1e-12)
    smooth = cv2.GaussianBlur(inverse, (0, 0), _NORMAL_BLUR)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)[rows, cols]
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)[rows, cols]
    n = -np.column_stack([gx, gy]).astype(np.float64)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def contour_samples(
    contours: ContourModel, camera: Camera, depth: np.ndarray, spacing_px: float, max_count: int
) -> model.Samples:
    """Samples on the contours of ``depth`` ((H, W) linear depth of ``camera``'s view at the
    render's size, 0 = background), about one every ``spacing_px`` render pixels (one per
    square cell of that side) and at most ``max_count``; ``outside`` is +1 (the normal of the
    sample's tangent points away from its surface)."""
    h, w = depth.shape
    mask = contour_pixels(depth)
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return _empty()
    cell = max(1.0, float(spacing_px), float(np.sqrt(len(rows) / max(max_count, 1))))
    key = (rows // cell).astype(np.int64) * (int(w // cell) + 1) + (cols // cell).astype(np.int64)
    _, first = np.unique(key, return_index=True)
    rows, cols = rows[first], cols[first]
    normal = _outward_normals(depth, rows, cols)
    z = depth[rows, cols].astype(np.float64)
    view = camera.resized(w, h)
    K_inv = np.linalg.inv(view.K)
    # the boundary lies half a pixel beyond the contour pixel's centre, towards the outside
    uv = np.column_stack([cols, rows]).astype(np.float64) + _HALF * normal
    tangent_2d = np.column_stack([normal[:, 1], -normal[:, 0]])  # model.pinhole_samples: n = (-d_y, d_x)
    local = _backproject(K_inv, uv, z)
    ahead = _backproject(K_inv, uv + tangent_2d, z)
    points = (local - view.t) @ view.R  # camera to world: R^T (X - t)
    tangents = (ahead - local) @ view.R
    tangents /= np.maximum(np.linalg.norm(tangents, axis=1, keepdims=True), 1e-12)
    edge = contours.nearest_edge(points)
    group = contours.edges.group[edge] if len(contours.edges) else np.zeros(len(points), np.int64)
    full_spacing = cell * camera.width / w
    return model.Samples(
        points, tangents, group, edge, np.ones(len(points)), spacing_px=full_spacing, contour=np.ones(len(points), bool)
    )


def _backproject(K_inv: np.ndarray, uv: np.ndarray, z: np.ndarray) -> np.ndarray:
    return (np.column_stack([uv, np.ones(len(uv))]) @ K_inv.T) * z[:, None]


def _empty() -> model.Samples:
    empty = np.zeros((0, 3))
    return model.Samples(empty, empty, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))


def joined(a: model.Samples, b: model.Samples) -> model.Samples:
    """The samples of ``a`` then ``b`` (``outside`` 0 where one of them has none)."""
    out_a = a.outside if a.outside is not None else np.zeros(len(a))
    out_b = b.outside if b.outside is not None else np.zeros(len(b))
    return model.Samples(
        np.concatenate([a.points, b.points]),
        np.concatenate([a.tangents, b.tangents]),
        np.concatenate([a.group, b.group]),
        np.concatenate([a.edge, b.edge]),
        np.concatenate([out_a, out_b]),
        a.spacing_px or b.spacing_px,
        np.concatenate([_contour(a), _contour(b)]),
    )


def _contour(samples: model.Samples) -> np.ndarray:
    return samples.contour if samples.contour is not None else np.zeros(len(samples), bool)


__all__ = ["ContourModel", "curved_parts", "contour_pixels", "contour_samples", "joined", "DEPTH_STEP"]
