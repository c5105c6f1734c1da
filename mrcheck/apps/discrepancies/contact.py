"""Contact lines: photo edges along the foot of a part that stands on the support.

Why: where a part meets the floor (or the table), the photo shows lines the CAD has no edge
for -- the part's contact shadow, its reflection in a glossy floor, a bevel or a skirting -- a
few pixels outside its bottom outline and parallel to it. Counted as unexplained structure they
became the quick start's largest "extra" region (the biscuit box's contact shadow and reflection:
453 edge pixels 5-11 px outside its bottom edge, issue 41).

A CAD outline pixel is a **foot** pixel when the surface beside it belongs to a part resting on
the support (its lowest point within :data:`RESTING_M` of the support level: the planned floor's
level, else the scene's lowest point) and lies within :data:`FOOT_SHARE` of that part's height
(at least :data:`FOOT_M`) above the support. A photo edge pixel is a **contact line** when a foot
pixel of the same orientation bin or a neighbouring one lies within that foot pixel's band width
of it (an added object's edges rarely run along a part's foot). The band width is
:data:`CONTACT_SHARE` of the part's height, at most :data:`CONTACT_MAX_M`, in pixels at the
foot's depth (a contact shadow under ceiling lamps or a high sun is a fraction of the height), at
least ``3 * tolerance``. Why the cap: a quarter of a 6 m wall's or column's height took in the
crates added beside them in the generated cell's evaluation (recall 43/67 -> 40/67, the added
objects 11/16 -> 8/16, ``tests/test_discrepancies.py``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from mrcheck.apps.discrepancies.edges import ORIENTATION_BINS, orientation_bin, outline_normals
from mrcheck.apps.discrepancies.ids import world_points
from mrcheck.apps.discrepancies.planned import PlannedView
from mrcheck.apps.discrepancies.thresholds import MIN_OBJECT_M
from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene

CONTACT_SHARE = 0.25  # the band's width: this share of the part's height ...
CONTACT_MAX_M = 0.1  # ... at most this many metres (a wall's or a rack's band would take in the crates beside it)
FOOT_SHARE = 0.1  # foot pixels: the surface this share of the part's height above the support ...
FOOT_M = 0.02  # ... or this many metres, if more
RESTING_M = 0.02  # a part whose lowest point is this close to the support level rests on it


def instance_heights(scene: Scene, labels: list) -> tuple[np.ndarray, np.ndarray]:
    """``(bottom, height)`` (m) of every instance index of ``labels`` ((part, instance id) pairs):
    its transformed bounding box's lowest z and z extent (the 8 corners of the part's box)."""
    z_range = {}
    for part in scene.parts:
        lo, hi = part.vertices.min(axis=0), part.vertices.max(axis=0)
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for iid, T in zip(part.instance_ids, part.transforms):
            z = corners @ np.asarray(T, np.float64)[2]
            z_range[iid] = (float(z.min()), float(z.max() - z.min()))
    pairs = [z_range.get(iid, (math.inf, 0.0)) for _, iid in labels]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def _world_z(camera: Camera, depth: np.ndarray) -> np.ndarray:
    """(H, W) world z of each pixel's planned surface (nan where there is none)."""
    return np.where(depth > 0, world_points(camera, depth)[..., 2], np.nan)


def contact_lines(
    scene: Scene, camera: Camera, planned: PlannedView, edges: np.ndarray, angle: np.ndarray, tol: float
) -> tuple[np.ndarray, float]:
    """``(lines, support)``: (H, W) bool, the photo ``edges`` (with their normal ``angle``,
    radians mod pi) that are contact lines of a resting part's foot (module docstring): per
    orientation bin, the nearest foot pixel of that bin or a neighbouring one, within its band
    width; and the support's level (:func:`support_level`, found on the way)."""
    foot, width, support = _foot(scene, camera, planned, tol)
    out = np.zeros_like(edges)
    if not foot.any():
        return out, support
    foot_bin = orientation_bin(outline_normals(planned.cad))
    edge_bin = orientation_bin(angle)
    candidates = edges & (cv2.distanceTransform((~foot).astype(np.uint8), cv2.DIST_L2, 5) <= width.max())
    for b in range(ORIENTATION_BINS):
        near_bins = [(b - 1) % ORIENTATION_BINS, b, (b + 1) % ORIENTATION_BINS]
        mine = foot & np.isin(foot_bin, near_bins)
        ys, xs = np.nonzero(candidates & (edge_bin == b))
        if not mine.any() or not len(ys):
            continue
        dist, labels = cv2.distanceTransformWithLabels(
            (~mine).astype(np.uint8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL
        )
        fy, fx = np.nonzero(mine)  # the labels number the zero pixels in this (row-major) order
        k = labels[ys, xs] - 1
        near = dist[ys, xs] <= width[fy[k], fx[k]]
        out[ys[near], xs[near]] = True
    return out, support


def support_level(scene: Scene, camera: Camera, planned: PlannedView, z: np.ndarray | None = None) -> float:
    """The support's height (world z, m): the planned floor's median level where the view shows
    one (``planned.ground``), else the scene's lowest point (a box alone stands on a table the CAD
    lacks); ``z``: :func:`_world_z` of the view, when computed."""
    if planned.ground is None or not planned.ground.any():
        return float(scene.bounds()[0, 2])
    z = _world_z(camera, planned.depth) if z is None else z
    return float(np.nanmedian(z[planned.ground]))


def metres_per_pixel(camera: Camera, support: float, u: float, v: float) -> float | None:
    """The size (m) of one pixel at photo pixel (``u``, ``v``) on the support plane (world z =
    ``support``), None where the pixel's ray does not meet it in front of the camera."""
    x, y = cv2.undistortPoints(np.array([[[u, v]]], np.float64), camera.K, camera.dist).reshape(2)
    ray = camera.R.T @ np.array([x, y, 1.0])  # world direction of a point at camera depth 1
    if abs(ray[2]) < 1e-12:
        return None
    depth = (support - camera.center[2]) / ray[2]
    return float(depth / camera.fx) if depth > 0 else None


def object_sized(bbox, camera: Camera, support: float) -> bool:
    """Whether a region's box ([x0, y0, x1, y1]) spans at least :data:`MIN_OBJECT_M` (diagonal)
    on the support plane (world z = ``support``) at its bottom centre; a box whose bottom ray
    misses the plane (above the horizon: a wall, a ceiling) counts: its size cannot be told."""
    x0, y0, x1, y1 = bbox
    size = metres_per_pixel(camera, support, (x0 + x1) / 2.0, float(y1))
    return size is None or size * float(np.hypot(x1 - x0 + 1, y1 - y0 + 1)) >= MIN_OBJECT_M


def _foot(scene: Scene, camera: Camera, planned: PlannedView, tol: float) -> tuple[np.ndarray, np.ndarray, float]:
    """``(foot (H, W) bool, width (H, W) float32 px, support level)``: the foot pixels and each
    one's band width."""
    ids, depth = planned.ids, planned.depth
    z = _world_z(camera, depth)
    ground = planned.ground if planned.ground is not None and planned.ground.any() else None
    support = support_level(scene, camera, planned, z)
    bottom, height = instance_heights(scene, planned.labels)
    inst = np.where(ids >= 0, ids, 0)
    resting = (ids >= 0) & (bottom[inst] <= support + RESTING_M) & (height[inst] > 0)
    if ground is not None:
        resting &= ~ground  # the floor itself is no part standing on it
    low = np.maximum(FOOT_M, FOOT_SHARE * height[inst])
    surface = resting & (np.nan_to_num(z, nan=np.inf) - support <= low)
    foot = planned.cad & (cv2.dilate(surface.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0)
    # the band width of a foot pixel: from its own or its neighbour's surface (a silhouette pixel
    # may lie on the background)
    metres = np.minimum(CONTACT_SHARE * height[inst], CONTACT_MAX_M)
    band = np.where(surface, metres * camera.fx / np.maximum(depth, 1e-6), 0.0)
    band = cv2.dilate(band.astype(np.float32), np.ones((3, 3), np.uint8))
    return foot, np.maximum(band, 3.0 * tol).astype(np.float32), support


__all__ = [
    "contact_lines",
    "instance_heights",
    "support_level",
    "object_sized",
    "metres_per_pixel",
    "CONTACT_SHARE",
    "CONTACT_MAX_M",
    "FOOT_SHARE",
    "FOOT_M",
    "RESTING_M",
]
