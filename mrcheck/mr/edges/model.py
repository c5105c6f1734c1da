"""The CAD side of the edge registration: the scene's edges, and the visible ones from a pose.

Why the mesh's own edges and not edges found in a rendered image: an edge found in the depth or
normal buffer lies at a pixel centre, up to half a pixel off the true line, and always on the
same (inner) side of a silhouette, a bias that does not average out over many samples and that
alone would use up most of a one-pixel accuracy budget. The mesh edges are exact lines in 3D;
the render decides only which of them are seen (the depth buffer, :meth:`EdgeModel.samples`).

Edges kept per mesh (vertices welded first: GLB meshes split them at every face):

* creases: two faces meeting at more than :data:`CREASE_DEG` (box edges, profiles), and
  boundary or non-manifold edges; seen unless the depth buffer hides them;
* silhouette candidates: the other edges (facets of a tessellated cylinder), seen only where
  one face turns towards the camera and the other away (the contour of a curved surface).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene

CREASE_DEG = 30.0  # a facet edge of a 12-sided cylinder (30 deg) is not yet a crease
_WELD_DIGITS = 6  # vertices within a micrometre (metres) are one vertex
_VISIBLE_DEPTH_TOL = 0.01  # an edge point up to 1 % behind the visible surface is still on it
_MIN_EDGE_PX = 2.0  # edges shorter than this on screen give no sample
_VIEW_MARGIN = 0.05  # sample_edges: edges clipped to the image widened by this share of its width
SALIENT_NEAR_PX = 1.0  # salient(): each side of an edge probed this far (level px) ...
SALIENT_FAR_PX = 2.0  # ... and this far: one surface over that width on both sides
_ON_PLANE = 0.003  # a point lies in a surface's plane: within 0.3 % of the depth (6 cm at 20 m)
_SIDE_NORMAL_COS = math.cos(math.radians(20.0))


@dataclass
class EdgeSet:
    """The scene's edges in world coordinates, float64 (one row per edge of every instance).

    ``a``, ``b``: (n, 3) end points; ``na``, ``nb``: (n, 3) unit normals of the two faces (equal
    for a boundary edge); ``crease``: (n,) bool; ``group``: (n,) int, the instance the edge
    belongs to (an index into ``group_names``, the instance ids).
    """

    a: np.ndarray
    b: np.ndarray
    na: np.ndarray
    nb: np.ndarray
    crease: np.ndarray
    group: np.ndarray
    group_names: list[str]

    def __len__(self) -> int:
        return len(self.a)

    @cached_property
    def mid(self) -> np.ndarray:
        """(n, 3) the edges' midpoints (kept: every sampling and every fit of a video needs them)."""
        return 0.5 * (self.a + self.b)

    @cached_property
    def face_offsets(self) -> tuple:
        """``(na . mid, nb . mid)``: (n,) each, the planes of an edge's two faces through its
        midpoint (kept: the front test of every sampling is then two matrix-vector products,
        ``na . centre - na . mid``, instead of a (n, 3) difference and two row-wise dot products,
        5 ms of a 40 ms sampling of the generated cell)."""
        return np.einsum("ij,ij->i", self.na, self.mid), np.einsum("ij,ij->i", self.nb, self.mid)


@dataclass
class Samples:
    """Points sampled along the visible edges at one pose (world, float64).

    ``points``: (n, 3); ``tangents``: (n, 3) unit edge directions; ``group``: (n,) instance index;
    ``edge``: (n,) index of the edge in the :class:`EdgeSet` (the unit whose samples share one
    error: the clusters of the uncertainty, :mod:`mrcheck.mr.edges.solver`); ``outside``: (n,)
    for a contour the side of the background along the image normal (+1 or -1), 0 for a crease
    or not known (:func:`salient`); ``spacing_px``: the spacing they were made at (pixels of the
    camera they were sampled for; :func:`sample_edges` widens it for a dense scene); ``contour``:
    (n,) bool, the samples of the rendered outline (:mod:`mrcheck.mr.edges.silhouette`), None
    for none.
    """

    points: np.ndarray
    tangents: np.ndarray
    group: np.ndarray
    edge: np.ndarray
    outside: np.ndarray | None = None
    spacing_px: float = 0.0
    contour: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.points)


def mesh_edges(vertices: np.ndarray, faces: np.ndarray, crease_deg: float = CREASE_DEG):
    """``(a, b, na, nb, crease)`` of one mesh in its own coordinates (see :class:`EdgeSet`)."""
    v = np.asarray(vertices, np.float64)
    key = np.round(v, _WELD_DIGITS)
    _, weld = np.unique(key, axis=0, return_inverse=True)
    f = weld.reshape(-1)[np.asarray(faces, np.int64)]
    normal = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    area = np.linalg.norm(normal, axis=1)
    keep = (area > 1e-12) & (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f, faces, normal = f[keep], np.asarray(faces)[keep], normal[keep] / area[keep, None]
    # each face's three edges, as (welded low, welded high) keys; the positions from the original
    # vertex indices (a welded vertex's copies sit within a micrometre)
    lo = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    pos = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(f)), 3)
    pair = np.sort(lo, axis=1)
    order = np.lexsort((pair[:, 1], pair[:, 0]))
    pair, pos, owner = pair[order], pos[order], owner[order]
    start = np.flatnonzero(np.r_[True, np.any(pair[1:] != pair[:-1], axis=1)])
    count = np.diff(np.r_[start, len(pair)])
    first = owner[start]
    second = np.where(count >= 2, owner[np.minimum(start + 1, len(pair) - 1)], first)
    na, nb = normal[first], normal[second]
    # the angle between the two faces' planes, whatever their winding (a mesh whose triangles of
    # one flat face wind both ways has no crease along the face's diagonal); nb then turned to
    # na's side, so that a contour is where the two faces' signs really change
    dot = np.einsum("ij,ij->i", na, nb)
    nb = np.where((dot < 0)[:, None], -nb, nb)
    crease = (count != 2) | (np.abs(dot) < math.cos(math.radians(crease_deg)))
    a, b = v[pos[start, 0]], v[pos[start, 1]]
    return a, b, na, nb, crease


def scene_edges(scene: Scene, crease_deg: float = CREASE_DEG) -> EdgeSet:
    """Every instance's edges in world coordinates (a mesh's edges found once, then placed)."""
    parts = []
    names: list[str] = []
    for part in scene.parts:
        a, b, na, nb, crease = mesh_edges(part.vertices, part.faces, crease_deg)
        for transform, name in zip(part.transforms, part.instance_ids):
            M, offset = transform[:3, :3], transform[:3, 3]
            # normals with the inverse transpose (a non-uniform scale would tilt them otherwise)
            N = np.linalg.inv(M).T
            n_a, n_b = na @ N.T, nb @ N.T
            n_a /= np.linalg.norm(n_a, axis=1, keepdims=True)
            n_b /= np.linalg.norm(n_b, axis=1, keepdims=True)
            parts.append((a @ M.T + offset, b @ M.T + offset, n_a, n_b, crease, np.full(len(a), len(names))))
            names.append(name)
    if not parts:
        empty = np.zeros((0, 3))
        return EdgeSet(empty, empty, empty, empty, np.zeros(0, bool), np.zeros(0, int), [])
    a, b, na, nb, crease, group = (np.concatenate(c) for c in zip(*parts))
    return EdgeSet(a, b, na, nb, crease, group, names)


def front_edges(edges: EdgeSet, centre: np.ndarray) -> np.ndarray:
    """(n,) bool: the edges that can be seen from ``centre`` (world): every crease, and the
    contour edges (one face towards it, the other away)."""
    return _facing(edges, slice(None), centre)


def _facing(edges: EdgeSet, which, centre: np.ndarray) -> np.ndarray:
    """:func:`front_edges` of the edges ``which`` (an index array or a slice)."""
    oa, ob = edges.face_offsets
    fa = edges.na[which] @ centre > oa[which]  # the face's normal . (centre - mid) > 0
    fb = edges.nb[which] @ centre > ob[which]
    # creases whatever their faces' winding (meshes from CAD exports often mix it; the depth
    # buffer hides the ones behind); a contour needs its faces' sign to change
    return edges.crease[which] | (fa != fb)


def project_pinhole(camera: Camera, points: np.ndarray) -> np.ndarray:
    """(n, 2) pinhole pixels of world points (as ``camera.project``), about the camera centre so
    that coordinates far from the world origin keep their precision. Plain numpy: a dense
    scene's edges are hundreds of thousands of points per pose, and ``cv2.projectPoints``
    (which also makes a Jacobian) took about 2 us per point."""
    if len(points) == 0:
        return np.zeros((0, 2))
    x = (np.asarray(points, np.float64) - camera.center) @ (camera.K @ camera.R).T
    with np.errstate(divide="ignore", invalid="ignore"):
        return x[:, :2] / x[:, 2:3]


def clip_to_view(camera: Camera, a: np.ndarray, b: np.ndarray, near: float, margin_px: float) -> tuple:
    """``(a, b, keep)``: the segments ``a``-``b`` (world, (n, 3)) cut to the part in front of the
    camera's near plane ``near`` (m) and inside the pinhole image widened by ``margin_px`` on
    every side (Liang-Barsky on the five planes of that frustum, in camera coordinates, where
    each is linear); ``keep`` (n,) the segments with a part inside (``a``, ``b`` are those).

    Why: samples are spaced along the part that is seen. Spread along a whole edge, an edge
    running from beside the camera to the far wall (a pipe overhead) put most of its up to 4096
    samples on its few hundred visible pixels: on the generated cell's overview three pipes
    held 58 % of the 3000 samples a fit used."""
    if len(a) == 0:
        return a, b, np.zeros(0, bool)
    K, w, h = camera.K, camera.width, camera.height
    # each plane as n . X + d >= 0 (camera coordinates X = R (x - centre)): near, left, right, top, bottom
    planes = np.array(
        [
            [0.0, 0.0, 1.0],
            [K[0, 0], K[0, 1], K[0, 2] + margin_px],
            [-K[0, 0], -K[0, 1], w - 1 + margin_px - K[0, 2]],
            [0.0, K[1, 1], K[1, 2] + margin_px],
            [0.0, -K[1, 1], h - 1 + margin_px - K[1, 2]],
        ]
    )
    offset = np.array([[-near], [0.0], [0.0], [0.0], [0.0]])
    # (5, n): one row per plane, so that the tests run along contiguous rows (numpy's reductions
    # over a trailing axis of 5 took most of this function's 20 ms on the generated cell); made
    # as (5, 3) @ (3, n) straight into that layout (the transposing copy of a (n, 5) product
    # took 14 of those 20 ms)
    world = planes @ camera.R
    da, db = world @ (a - camera.center).T + offset, world @ (b - camera.center).T + offset
    out_a, out_b = da < 0, db < 0
    beyond, partly = out_a[0] & out_b[0], out_a[0] | out_b[0]
    for k in range(1, len(planes)):
        beyond |= out_a[k] & out_b[k]
        partly |= out_a[k] | out_b[k]
    keep = ~beyond  # both ends beyond one plane: nothing in view
    cut = np.flatnonzero(keep & partly)  # one end beyond some plane: clipped
    da, db = da[:, cut], db[:, cut]
    slope = db - da
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = -da / slope
    lo, hi = np.zeros(len(cut)), np.ones(len(cut))
    for k in range(len(planes)):
        lo = np.maximum(lo, np.where(slope[k] > 0, cross[k], 0.0))
        hi = np.minimum(hi, np.where(slope[k] < 0, cross[k], 1.0))
    inside = lo < hi
    keep[cut[~inside]] = False
    ca, cb = a[cut[inside]], b[cut[inside]]
    lo, hi = lo[inside, None], hi[inside, None]
    at = np.cumsum(keep)[cut[inside]] - 1  # where the clipped ones lie among the kept
    a, b = a[keep], b[keep]
    a[at], b[at] = ca + lo * (cb - ca), ca + hi * (cb - ca)
    return a, b, keep


def sample_edges(
    edges: EdgeSet,
    camera: Camera,
    spacing_px: float,
    near: float = 1e-3,
    max_count: int | None = None,
    among: np.ndarray | None = None,
) -> Samples:
    """Points every ``spacing_px`` pixels (pinhole projection, evenly on screen) along the edges
    that face the camera, clipped to the part of each edge in front of the camera and inside the
    image (:func:`clip_to_view`; samples beyond a margin of one spacing dropped); the spacing
    is widened so that at most about ``max_count`` points
    are made (a dense scene at full resolution has millions of edge pixels). ``among``: edge
    indices to consider (default: all). Visibility (occlusion) is :func:`visible`'s."""
    if among is None:
        idx = np.flatnonzero(front_edges(edges, camera.center))
    else:
        idx = among[_facing(edges, among, camera.center)]
    room = spacing_px + _VIEW_MARGIN * camera.width  # the lens distortion's room at the border
    a, b, keep = clip_to_view(camera, edges.a[idx], edges.b[idx], near, margin_px=room)
    idx = idx[keep]
    d = project_pinhole(camera, b) - project_pinhole(camera, a)
    length = np.hypot(d[:, 0], d[:, 1])
    keep = np.isfinite(length) & (length >= _MIN_EDGE_PX)
    idx, a, b, length = idx[keep], a[keep], b[keep], length[keep]
    if max_count:
        spacing_px = max(spacing_px, float(np.sum(np.minimum(length, 4 * (camera.width + camera.height)))) / max_count)
    count = np.maximum(1, np.floor(length / spacing_px)).astype(np.int64)
    count = np.minimum(count, 4096)  # a wall edge crossing the whole view: enough samples
    edge = np.repeat(np.arange(len(idx)), count)
    k = np.arange(len(edge)) - np.repeat(np.cumsum(count) - count, count)
    # evenly spaced on screen: 1/z is linear in the image, so the screen fraction f lies at
    # s = f za / ((1 - f) zb + f za) along the 3D segment (evenly in 3D, an edge from 2 m to
    # 30 m would crowd its samples at the far end)
    f = (k + 0.5) / count[edge]
    za, zb = (a - camera.center) @ camera.R[2], (b - camera.center) @ camera.R[2]
    za, zb = za[edge], zb[edge]
    s = f * za / ((1.0 - f) * zb + f * za)
    points = a[edge] + s[:, None] * (b[edge] - a[edge])
    tangents = (b - a)[edge]
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    samples = Samples(points, tangents, edges.group[idx][edge], idx[edge], spacing_px=float(spacing_px))
    uv = project_pinhole(camera, samples.points)
    margin = spacing_px
    inside = (
        (uv[:, 0] > -margin)
        & (uv[:, 0] < camera.width - 1 + margin)
        & (uv[:, 1] > -margin)
        & (uv[:, 1] < camera.height - 1 + margin)
    )
    return subset(samples, inside)


def subset(samples: Samples, mask) -> Samples:
    outside = None if samples.outside is None else samples.outside[mask]
    return Samples(
        samples.points[mask],
        samples.tangents[mask],
        samples.group[mask],
        samples.edge[mask],
        outside,
        samples.spacing_px,
        None if samples.contour is None else samples.contour[mask],
    )


def visible(samples: Samples, camera: Camera, depth: np.ndarray) -> np.ndarray:
    """(n,) bool: the samples that no nearer surface hides, by the depth buffer ``depth`` (H, W)
    linear depth of ``camera`` (0 = background), which may be smaller than the camera's image
    (a coarse level): it is looked up at the scaled pixel.

    A point on an edge is seen when some pixel of its 3x3 neighbourhood shows a surface at its
    depth or farther (the background counts as infinitely far): a silhouette pixel shows either
    the part itself or what lies behind it, a hidden edge only the nearer occluder.
    """
    h, w = depth.shape
    far = np.where(depth > 0, depth, np.float32(3e38)).astype(np.float32)
    # the farthest depth of each 3x3 neighbourhood (a grey dilation)
    farthest = cv2.dilate(far, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    uv = project_pinhole(camera, samples.points)
    sx, sy = w / camera.width, h / camera.height
    col = np.clip(np.rint((uv[:, 0] + 0.5) * sx - 0.5), 0, w - 1).astype(np.int64)
    row = np.clip(np.rint((uv[:, 1] + 0.5) * sy - 0.5), 0, h - 1).astype(np.int64)
    z = samples.points @ camera.R[2] + camera.t[2]
    return farthest[row, col] >= z * (1.0 - _VISIBLE_DEPTH_TOL)


def pinhole_samples(camera: Camera, samples: Samples, shape) -> tuple:
    """``(uv, normals, local)`` of the samples in a pinhole image of ``shape`` (H, W) of
    ``camera`` (a level's render): pixel positions, unit image normals of the edges, (n, 3)
    camera coordinates."""
    h, w = shape
    sx, sy = w / camera.width, h / camera.height
    local = samples.points @ camera.R.T + camera.t
    z = local[:, 2]
    uv = project_pinhole(camera, samples.points)
    ahead = project_pinhole(camera, samples.points + (1e-3 * z)[:, None] * samples.tangents)
    d = (ahead - uv) * (sx, sy)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    level_uv = np.column_stack([(uv[:, 0] + 0.5) * sx - 0.5, (uv[:, 1] + 0.5) * sy - 0.5])
    return level_uv, np.column_stack([-d[:, 1], d[:, 0]]), local


def _lookup(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``image`` (H, W[, C]) at the nearest pixel of level positions ``uv`` (clamped)."""
    h, w = image.shape[:2]
    col = np.clip(np.rint(uv[:, 0]), 0, w - 1).astype(np.int32)
    row = np.clip(np.rint(uv[:, 1]), 0, h - 1).astype(np.int32)
    # by flat index (a third of the time of image[row, col] for a normal buffer)
    at = row * w + col
    return image.reshape(h * w, -1).take(at, axis=0).reshape((len(at),) + image.shape[2:])


def salient(
    uv: np.ndarray,
    normals: np.ndarray,
    points: np.ndarray,
    depth: np.ndarray,
    surface_normals: np.ndarray,
    K: np.ndarray,
    near_px: float = SALIENT_NEAR_PX,
    far_px: float = SALIENT_FAR_PX,
) -> tuple:
    """``(keep, outside)``: (n,) bool, the samples whose edge a photo can show as one clean step, judged on a render
    at the level's size: ``uv`` level pixels, ``normals`` unit image normals, ``points`` (n, 3)
    camera coordinates of the samples; ``depth`` (H, W, 0 = background) and ``surface_normals``
    (H, W, 3) the render's G-buffer (camera space), ``K`` the level camera's matrix.

    Across the edge, at ``near_px`` and ``far_px`` on each side along the normal, the render's
    surface point and normal are looked up. A side is *on* the edge when the edge point lies in
    that side's surface plane (within :data:`_ON_PLANE` of its depth: slope-independent, so a
    face seen obliquely counts and a column 20 cm before a wall 19 m away does not); it is
    *clean* when the far probe lies in the near probe's plane (one surface over ``far_px``: no
    other edge that close). Kept: a contour (exactly one side on, the other farther or
    background and clean: a thin column before a wall counts) or a crease (both on and clean,
    normals more than :data:`CREASE_DEG` apart). Removed: wires and bars thinner than
    ``2 near_px`` (no side is on: in a photo they blur away), corrugated sheet, grids and racks
    (not clean), mesh edges inside a flat face. ``outside`` (n,): the contour's background side
    along the normal (+1, -1; 0 for a crease), see :class:`Samples`.
    """
    z = points[:, 2]
    K_inv = np.linalg.inv(K)
    sides = []
    for sign in (-1.0, 1.0):
        probes = []
        for d in (near_px, far_px):
            p = uv + (sign * d) * normals
            dz = _lookup(depth, p).astype(np.float64)
            ray = np.column_stack([p, np.ones(len(p))]) @ K_inv.T
            probes.append((dz, ray * dz[:, None], _lookup(surface_normals, p).astype(np.float64)))
        (d1, p1, n1), (d2, p2, n2) = probes
        bg1, bg2 = d1 <= 0, d2 <= 0
        in_plane = lambda q: np.abs(np.einsum("ij,ij->i", n1, q - p1)) <= _ON_PLANE * d1  # noqa: E731
        clean = (bg1 & bg2) | (~bg1 & ~bg2 & in_plane(p2) & (np.einsum("ij,ij->i", n1, n2) > _SIDE_NORMAL_COS))
        on = ~bg1 & in_plane(points)
        behind = bg1 | (d1 > z * (1.0 - _ON_PLANE))
        sides.append((clean, on, behind, n1))
    (clean_a, on_a, behind_a, n_a), (clean_b, on_b, behind_b, n_b) = sides
    out_b, out_a = clean_a & clean_b & on_a & ~on_b & behind_b, clean_a & clean_b & on_b & ~on_a & behind_a
    crease = on_a & on_b & clean_a & clean_b & (np.einsum("ij,ij->i", n_a, n_b) < math.cos(math.radians(CREASE_DEG)))
    return out_a | out_b | crease, np.where(out_b, 1.0, 0.0) - np.where(out_a, 1.0, 0.0)


__all__ = [
    "EdgeSet",
    "Samples",
    "mesh_edges",
    "scene_edges",
    "front_edges",
    "sample_edges",
    "visible",
    "subset",
    "project_pinhole",
    "pinhole_samples",
    "salient",
    "CREASE_DEG",
]
