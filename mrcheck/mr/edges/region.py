"""The region criterion of the silhouette term: where along a contour sample's normal the photo
changes from the parts' colours to the background's.

As RBOT (Tjaden et al., TPAMI 2018, section 3: per-pixel foreground posteriors from colour
histograms of the current pose's mask) and SRT3D (Stoiber et al., IJCV 2022, section 4.2:
the contour position along a correspondence line as a two-class segmentation of that line):
the foreground histogram is taken over the rendered mask, the background's over a band
:data:`BAND_PX` wide around it, each photo pixel gets ``P(foreground | colour)``, and along
each contour sample's normal the boundary is placed where a step from foreground (inside) to
background (outside) explains the line best (the log-likelihood of the two-class split,
maximised over the split point). The gradient peak near that point then refines it
(:meth:`mrcheck.mr.edges.fitter.Fitter.match`): the region decides *which* photo edge is the
outline (clutter edges beyond it and print inside it separate nothing), the gradient *where*.

Limits: one foreground model for all parts in view (the render has no instance buffer), so
parts of very different colours share it; a part whose colours match what it stands before
(a grey part before a grey wall) gives no split, and its samples find no match (as with the
gradient search).
"""

from __future__ import annotations

import cv2
import numpy as np

BAND_PX = 12  # level px: the background histogram's band around the rendered mask
_BITS = 4  # colour quantisation: 16 levels a channel (16^3 bins), as RBOT's 32^3 for smaller masks
_CLIP = 0.02  # posteriors kept in [_CLIP, 1 - _CLIP] (one odd pixel cannot veto a split)
MIN_GAIN = 2.0  # nats: a split must explain the line this much better than all one class


def colour_levels(photo: np.ndarray, levels: int) -> list[np.ndarray]:
    """(H, W) int32 colour-bin indices of the photo at each pyramid level (``cv2.pyrDown``, as
    :func:`mrcheck.mr.edges.photo.pyramid`); a grey photo gets 2^(3 * bits) grey bins."""
    image = np.asarray(photo)
    if image.dtype != np.uint8:
        image = np.clip(image * (255.0 if image.max() <= 1.5 else 1.0), 0, 255).astype(np.uint8)
    out = []
    for level in range(levels):
        if level:
            image = cv2.pyrDown(image)
        q = (image >> _BITS).astype(np.int32)
        if q.ndim == 3:
            side = 1 << (8 - _BITS)
            out.append((q[..., 0] * side + q[..., 1]) * side + q[..., 2])
        else:
            out.append(np.asarray(image, np.int32))
    return out


def posteriors(
    bins: np.ndarray, mask: np.ndarray, seeds: np.ndarray, seed_group: np.ndarray, groups: int
) -> np.ndarray:
    """(groups, bins) float32 ``P(foreground | colour)`` per instance, from ``bins`` (a level's
    colour bins) and ``mask`` (the rendered parts at the level's size): each pixel within
    :data:`BAND_PX` of a contour sample (``seeds``: (n, 2) level px, ``seed_group`` their
    instances) counts for that sample's instance, inside the mask as foreground, outside as
    background (a local split as SRT3D's lines: a desk of red, yellow and white objects has no
    one foreground colour); each histogram normalised (equal priors)."""
    size = 1 << (3 * (8 - _BITS)) if bins.max() >= 256 else 256
    h, w = bins.shape
    if len(seeds) == 0:
        return np.full((groups, size), 0.5, np.float32)
    col = np.clip(np.rint(seeds[:, 0]), 0, w - 1).astype(np.int64)
    row = np.clip(np.rint(seeds[:, 1]), 0, h - 1).astype(np.int64)
    src = np.ones((h, w), np.uint8)
    src[row, col] = 0
    # the nearest seed pixel of every pixel (labels number the zero pixels in scan order)
    dist, label = cv2.distanceTransformWithLabels(src, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    flat = np.flatnonzero(src.ravel() == 0)
    owner = np.full(h * w, -1, np.int64)
    owner[row * w + col] = seed_group
    pixel_group = owner[flat][np.clip(label.ravel() - 1, 0, len(flat) - 1)]
    near = (dist.ravel() <= BAND_PX) & (pixel_group >= 0)
    index = pixel_group * size + bins.ravel()
    inside = mask.ravel()
    fg = np.bincount(index[near & inside], minlength=groups * size).reshape(groups, size).astype(np.float64)
    bg = np.bincount(index[near & ~inside], minlength=groups * size).reshape(groups, size).astype(np.float64)
    fg /= np.maximum(fg.sum(axis=1, keepdims=True), 1.0)
    bg /= np.maximum(bg.sum(axis=1, keepdims=True), 1.0)
    p = (fg + 1e-6) / (fg + bg + 2e-6)
    return np.clip(p, _CLIP, 1.0 - _CLIP).astype(np.float32)


def step_search(
    bins: np.ndarray, tables: np.ndarray, uv: np.ndarray, normals: np.ndarray, group: np.ndarray, radius: int
) -> np.ndarray:
    """(n,) offsets (level px along ``normals``, which point outwards) of the best foreground-to-
    background split along each line of ``radius`` px each side of ``uv``, the pixels' colours
    (``bins``) judged by their instance's posterior (``tables``, :func:`posteriors`); nan where
    no split gains :data:`MIN_GAIN` over the line being all one class."""
    n = len(uv)
    if n == 0:
        return np.zeros(0)
    steps = np.arange(-radius, radius + 1, dtype=np.float32)
    mx = (uv[:, 0:1] + steps[None, :] * normals[:, 0:1]).astype(np.float32)
    my = (uv[:, 1:2] + steps[None, :] * normals[:, 1:2]).astype(np.float32)
    b = cv2.remap(bins.astype(np.float32), mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
    p = tables[group[:, None], b.astype(np.int64)].astype(np.float64)
    inside, outside = np.log(p), np.log(1.0 - p)
    # split after step k: steps <= k inside, > k outside (k = -1 .. len - 1 as cumulative sums)
    zero = np.zeros((n, 1))
    lead = np.hstack([zero, np.cumsum(inside, axis=1)])
    tail = np.hstack([np.cumsum(outside[:, ::-1], axis=1)[:, ::-1], zero])
    score = lead + tail  # (n, len + 1): index j splits between step j - 1 and step j
    best = np.argmax(score[:, 1:-1], axis=1) + 1
    rows = np.arange(n)
    gain = score[rows, best] - np.maximum(score[:, 0], score[:, -1])
    left, mid, right = score[rows, best - 1], score[rows, best], score[rows, best + 1]
    denom = left - 2 * mid + right
    delta = np.where(denom < 0, 0.5 * (left - right) / np.where(denom < 0, denom, -1.0), 0.0)
    offset = steps[0] + best - 0.5 + np.clip(delta, -0.5, 0.5)
    return np.where(gain >= MIN_GAIN, offset, np.nan)


__all__ = ["colour_levels", "posteriors", "step_search", "BAND_PX", "MIN_GAIN"]
