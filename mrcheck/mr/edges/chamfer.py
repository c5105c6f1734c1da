"""The coarse stage of the edge registration: oriented chamfer distances of the photo's edges,
a search over the view direction, and robust Gauss-Newton on the chamfer distance.

Why a second matching scheme before the search along the normal (:mod:`mrcheck.mr.edges.photo`):
from 15-40 px off, in a dense scene (fences, trusses, racks), the nearest photo edge along a
CAD edge's normal is mostly another object's edge, and a fit on those matches leaves the basin
(measured on the generated cell: from the *true* pose the old coarse level moved 22 px away).
The chamfer distance to the photo's edges of the same orientation (Liu et al. 2010, "Fast
directional chamfer matching"; as an objective for Levenberg-Marquardt: Imperoli & Pretto 2015,
D2CO) counts every photo edge of the right direction, is smooth in the pose, and truncated it
gives no pull to CAD edges the photo lacks.

Orientation bins are of the edge *direction* (0-180 degrees: the photo's contrast polarity is
not predictable from the CAD); each photo edge pixel goes to its bin and the nearer neighbour,
so a CAD edge matches photo edges within about +-1.5 bin widths of its direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

BINS = 8
TRUNCATE_PX = 4.0  # chamfer distances beyond this (level px) are "no edge here"
HUBER_PX = 1.0  # the chamfer residual's Huber threshold (level px) in a descent on it
_CANNY_HIGH = 3.0  # Canny's high threshold: this many times the median gradient ...
_CANNY_LOW = 1.5  # ... and its low one


@dataclass
class ChamferMap:
    """Per orientation bin (``BINS``, H, W) the distance (level px) to the nearest photo edge
    pixel of that bin, truncated at :data:`TRUNCATE_PX`, and its x and y derivatives."""

    scale: float
    distance: np.ndarray
    dx: np.ndarray
    dy: np.ndarray


def chamfer_map(grey: np.ndarray, scale: float) -> ChamferMap:
    """The chamfer map of the (H, W) float photo (0..1) at the pyramid level of ``scale``
    (``grey`` is already that level's image)."""
    smooth = cv2.GaussianBlur(grey.astype(np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3)
    magnitude = np.hypot(gx, gy)
    median = max(float(np.median(magnitude)), 1e-4)
    scaled = np.clip(smooth * 255.0, 0, 255).astype(np.uint8)
    # Canny on the 8-bit image; its thresholds are on Sobel magnitudes of 0..255 values
    edges = cv2.Canny(scaled, _CANNY_LOW * median * 255.0, _CANNY_HIGH * median * 255.0, L2gradient=True) > 0
    # the edge direction is perpendicular to the gradient
    direction = (np.degrees(np.arctan2(gy, gx)) + 90.0) % 180.0
    position = direction / (180.0 / BINS)
    own = np.floor(position).astype(np.int64) % BINS
    other = np.where(position - np.floor(position) >= 0.5, own + 1, own - 1) % BINS
    h, w = grey.shape
    distance = np.empty((BINS, h, w), np.float32)
    for b in range(BINS):
        mask = edges & ((own == b) | (other == b))
        free = np.where(mask, 0, 255).astype(np.uint8)
        distance[b] = np.minimum(cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE), TRUNCATE_PX)
    gradient = np.gradient(distance, axis=(1, 2))  # along the rows, then the columns
    dy, dx = gradient[0], gradient[1]
    return ChamferMap(scale, distance, dx.astype(np.float32), dy.astype(np.float32))


def bins_of(normals: np.ndarray) -> np.ndarray:
    """(n,) orientation bin of CAD edges with image normals ``normals`` (n, 2)."""
    direction = (np.degrees(np.arctan2(normals[:, 1], normals[:, 0])) + 90.0) % 180.0
    return np.floor(direction / (180.0 / BINS)).astype(np.int64) % BINS


def lookup(cmap: ChamferMap, uv: np.ndarray, bins: np.ndarray) -> tuple:
    """``(distance, gradient (n, 2))`` at level positions ``uv`` (bilinear; outside: truncated,
    no gradient)."""
    _, h, w = cmap.distance.shape
    u, v = uv[:, 0], uv[:, 1]
    inside = (u >= 0) & (v >= 0) & (u < w - 1) & (v < h - 1)
    u0 = np.clip(np.floor(u), 0, w - 2).astype(np.int64)
    v0 = np.clip(np.floor(v), 0, h - 2).astype(np.int64)
    fu, fv = np.clip(u - u0, 0, 1), np.clip(v - v0, 0, 1)

    def sample(image):
        return (
            (1 - fu) * (1 - fv) * image[bins, v0, u0]
            + fu * (1 - fv) * image[bins, v0, u0 + 1]
            + (1 - fu) * fv * image[bins, v0 + 1, u0]
            + fu * fv * image[bins, v0 + 1, u0 + 1]
        )

    d = np.where(inside, sample(cmap.distance), TRUNCATE_PX)
    g = np.column_stack([np.where(inside, sample(cmap.dx), 0.0), np.where(inside, sample(cmap.dy), 0.0)])
    return d, g


def huber_weights(distance: np.ndarray) -> np.ndarray:
    """(n,) weights of a descent on the chamfer distance: Huber's within the truncation, 0 beyond
    (a CAD edge with no photo edge of its direction nearby does not pull)."""
    return np.where(distance < TRUNCATE_PX, np.minimum(1.0, HUBER_PX / np.maximum(distance, 1e-9)), 0.0)


def cost(distance: np.ndarray) -> float:
    """The truncated chamfer cost: the mean squared distance, each capped at the truncation."""
    return float(np.mean(np.minimum(distance, TRUNCATE_PX) ** 2)) if distance.size else math.inf


__all__ = ["ChamferMap", "chamfer_map", "bins_of", "lookup", "cost", "huber_weights", "BINS", "TRUNCATE_PX", "HUBER_PX"]
