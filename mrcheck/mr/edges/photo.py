"""The photo side of the edge registration: an image pyramid of gradients, and the search for the
photo's edge along a CAD edge's normal (the "moving edges" of RAPID and its successors: Harris &
Stennett 1990, Drummond & Cipolla 2002), with sub-pixel positions.

Pixel coordinates of level ``l`` (``cv2.pyrDown`` halves the image ``l`` times): its pixel ``i``
is centred on pixel ``2i`` of the level below (a symmetric 5-tap kernel), so ``u_l = u / 2**l``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

_ORIENTATION_COS = math.cos(math.radians(35.0))  # the photo's gradient within 35 deg of the CAD normal
_OUTLINE_SHARE = 0.25  # a contour's edge: the outermost peak of at least this share of the strongest
_NOISE_FACTOR = 4.0  # an edge is a gradient above this many times the image's median gradient


@dataclass
class Level:
    """One pyramid level: its scale (``2**-l``), the gradient images and the edge threshold."""

    scale: float
    gx: np.ndarray
    gy: np.ndarray
    threshold: float

    @property
    def shape(self) -> tuple:
        return self.gx.shape


def to_level(uv: np.ndarray, scale: float) -> np.ndarray:
    return uv * scale  # cv2.pyrDown: level pixel i is centred on pixel 2i below


def pyramid(grey: np.ndarray, levels: int) -> list[Level]:
    """``levels`` levels of the (H, W) grey photo, level 0 at full resolution."""
    image: np.ndarray = grey.astype(np.float32) / (255.0 if grey.dtype == np.uint8 else 1.0)
    out = []
    for level in range(levels):
        if level:
            image = cv2.pyrDown(image)
        # a light blur first: the Scharr kernel alone is 3 px wide, and sensor noise or JPEG blocks
        # would make every pixel a local maximum of the gradient
        smooth = cv2.GaussianBlur(image, (0, 0), 0.8)
        gx = cv2.Scharr(smooth, cv2.CV_32F, 1, 0) / 32.0
        gy = cv2.Scharr(smooth, cv2.CV_32F, 0, 1) / 32.0
        magnitude = np.hypot(gx, gy)
        threshold = max(_NOISE_FACTOR * float(np.median(magnitude)), 2.0 / 255.0)
        out.append(Level(0.5**level, gx, gy, threshold))
    return out


def _bilinear(images: tuple, u: np.ndarray, v: np.ndarray) -> list:
    """Each of the (H, W) ``images`` (one shape) at float pixel positions (0 outside); the
    positions' indices and weights are computed once for all of them (the search reads the two
    gradient images at the same points: half the index work of one call per image), and the
    corners read by flat index with ``take`` (the search's innermost loop: 2D fancy indexing
    took 60 % longer)."""
    h, w = images[0].shape
    u0, v0 = np.floor(u), np.floor(v)
    fu, fv = u - u0, v - v0
    u0, v0 = u0.astype(np.int32), v0.astype(np.int32)
    inside = (u0 >= 0) & (v0 >= 0) & (u0 < w - 1) & (v0 < h - 1)
    at = np.clip(v0, 0, h - 2) * w + np.clip(u0, 0, w - 2)
    corners = (at, at + 1, at + w, at + w + 1)
    weights = ((1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv)
    out = []
    for image in images:
        flat = image.ravel()
        value = sum(wk * flat.take(k) for wk, k in zip(weights, corners))
        value[~inside] = 0.0
        out.append(value)
    return out


@dataclass
class Matches:
    """Per sample: ``offset`` along the normal to the photo's edge (level pixels; nan: none
    found), ``strength`` of that edge (the gradient along the normal), ``polarity`` (its sign)."""

    offset: np.ndarray
    strength: np.ndarray
    polarity: np.ndarray


def _peaks(level: Level, uv: np.ndarray, normals: np.ndarray, radius: int, polarity=None):
    """The gradient profile along each normal and its edge peaks: ``(steps, a, along, peak)``."""
    n = len(uv)
    steps = np.arange(-radius - 1, radius + 2, dtype=np.float64)  # one extra each side
    pu = uv[:, 0:1] + steps[None, :] * normals[:, 0:1]
    pv = uv[:, 1:2] + steps[None, :] * normals[:, 1:2]
    gx, gy = (g.reshape(n, -1) for g in _bilinear((level.gx, level.gy), pu.ravel(), pv.ravel()))
    along = gx * normals[:, 0:1] + gy * normals[:, 1:2]
    a = np.abs(along)
    centre = a[:, 1:-1]
    peak = (centre >= a[:, :-2]) & (centre > a[:, 2:]) & (centre > level.threshold)
    peak &= centre >= _ORIENTATION_COS * np.hypot(gx, gy)[:, 1:-1]
    if polarity is not None:
        sign = np.sign(along[:, 1:-1])
        peak &= (polarity[:, None] == 0) | (sign == polarity[:, None])
    return steps, a, along, peak


def search(level: Level, uv: np.ndarray, normals: np.ndarray, radius: int, polarity=None, outside=None) -> Matches:
    """For every point ``uv`` (level pixels) with unit image normal ``normals``: the photo's edge
    nearest to it along the normal within ``radius`` level pixels.

    An edge is a local maximum of the gradient component along the normal, above the level's
    threshold, with the gradient within 35 degrees of the normal (a crossing edge of another
    direction is not this one); the position is refined to sub-pixel by a parabola through the
    maximum and its two neighbours. ``polarity`` (the sign of the gradient along the normal
    found before, or 0 for any) keeps a point on the same side's edge from one iteration to
    the next, so it does not hop to a parallel edge of the opposite contrast.

    ``outside`` (n,): for a contour, the background's side along the normal (+1, -1; 0 for a
    crease): such a point takes the *outermost* of the strong edges in its window (at least a quarter
    of the strongest) instead of the nearest. The
    CAD has no texture, so the print or trim just inside a real object's outline (the box of
    tests/data/pose/box: a printed border 4-8 px inside) must not take the outline's samples;
    beyond the outline lies what the object stands before, where the CAD has no edge.
    """
    n = len(uv)
    steps, a, along, peak = _peaks(level, uv, normals, radius, polarity)
    distance = np.where(peak, np.abs(steps[None, 1:-1]), np.inf)
    if outside is not None:
        # the outermost of the strong edges (a quarter of the window's strongest: a soft shadow
        # edge or the table's grain beyond the outline does not count); creases keep the nearest
        magnitude = np.where(peak, a[:, 1:-1], 0.0)
        strong = peak & (magnitude >= _OUTLINE_SHARE * magnitude.max(axis=1, keepdims=True))
        rank = -outside[:, None] * steps[None, 1:-1] * (2 * radius + 3) + np.abs(steps[None, 1:-1])
        distance = np.where((outside[:, None] != 0), np.where(strong, rank, np.inf), distance)
    best = np.argmin(distance, axis=1)
    found = np.isfinite(distance[np.arange(n), best])
    i = best + 1  # index into a
    rows = np.arange(n)
    left, mid, right = a[rows, i - 1], a[rows, i], a[rows, i + 1]
    denom = left - 2 * mid + right
    delta = np.where(denom < 0, 0.5 * (left - right) / np.where(denom < 0, denom, -1.0), 0.0)
    offset = np.where(found, steps[i] + np.clip(delta, -0.5, 0.5), np.nan)
    return Matches(offset, np.where(found, mid, 0.0), np.where(found, np.sign(along[rows, i]), 0.0))


CHANCE_OFFSETS = (-6, -5, -4, -3, 3, 4, 5, 6)  # level px along the normal: "a pose a few px off"


def support_above_chance(level: Level, uv: np.ndarray, normals: np.ndarray) -> tuple:
    """``(support, chance, above)`` of points ``uv`` (level px) with image normals ``normals``.

    ``support``: the share with a photo edge within about 1.5 px along the normal (a search of
    radius 1, :func:`search`); ``chance``: the mean share at :data:`CHANCE_OFFSETS` along each
    normal, the support that the photo's clutter gives a pose 3-6 px off; ``above``: the support
    beyond chance, ``(support - chance) / (1 - chance)`` (0: no better than an unrelated pose,
    1: every point on an edge and none by chance). A photo dense with edges (a hall's fences,
    racks, a printed box) gives support to any pose; this tells a pose that fits from one that
    merely lies among edges."""
    if len(uv) == 0:
        return 0.0, 0.0, 0.0
    return above_from_hits(edge_hits(level, uv, normals))


def edge_hits(level: Level, uv: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(1 + len(:data:`CHANCE_OFFSETS`), n) bool: whether each point finds a photo edge within
    about 1.5 px at its place (row 0) and at each chance offset along its normal (the rest): what
    :func:`support_above_chance` and per-part figures (:func:`above_per_group`) count."""
    offsets = np.array((0.0, *CHANCE_OFFSETS))
    # one search over every offset at once (the profiles are 5 px long: numpy's overhead would rule)
    shifted = (uv[None, :, :] + offsets[:, None, None] * normals[None, :, :]).reshape(-1, 2)
    found = np.isfinite(search(level, shifted, np.tile(normals, (len(offsets), 1)), 1).offset)
    return found.reshape(len(offsets), -1)


def above_per_group(hits: np.ndarray, group: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """The support beyond chance of the :func:`edge_hits` points of each of ``groups``
    (``group``: each point's), counted from ``hits`` without another search."""
    size = int(group.max()) + 1
    counts = np.maximum(np.bincount(group, minlength=size)[groups], 1)
    share = np.stack([np.bincount(group, weights=row, minlength=size)[groups] for row in hits.astype(float)]) / counts
    return _beyond(share[0], share[1:].mean(axis=0))


def above_from_hits(hits: np.ndarray) -> tuple[float, float, float]:
    """``(support, chance, above)`` of :func:`support_above_chance` from :func:`edge_hits`."""
    shares = hits.mean(axis=1)
    support, chance = float(shares[0]), float(np.mean(shares[1:]))
    return support, chance, float(_beyond(support, chance))


def _beyond(support, chance):
    """The support beyond chance (:func:`support_above_chance`), of floats or arrays alike."""
    return (support - chance) / np.maximum(1.0 - chance, 1e-9)


__all__ = [
    "Level",
    "Matches",
    "pyramid",
    "search",
    "to_level",
    "support_above_chance",
    "edge_hits",
    "above_from_hits",
    "above_per_group",
    "CHANCE_OFFSETS",
]
