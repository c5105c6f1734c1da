"""Error metrics of a screen-space AO buffer against its ray-traced reference (numpy/OpenCV, no GL).

Every metric compares ``ao`` (a mode's unblurred AO, ``a``) with ``ref`` (the reference, ``r``),
both float32 (H, W) in [0, 1] where 1 is unoccluded, over the *covered* pixels
``M = {p : depth(p) > 0}``: background pixels (``depth == 0``) have no surface and no AO, so
they are excluded everywhere. ``1 - a`` is the darkening a mode applies to a pixel.

* :func:`mae` -- mean absolute error, ``mean_M |a - r|``
* :func:`rmse` -- root mean square error, ``sqrt(mean_M (a - r)^2)``
* :func:`ssim` -- structural similarity (Wang et al. 2004), Gaussian window, data range 1
* :func:`false_occlusion` -- darkening where the reference sees none, ``mean_{M, r >= 0.99} (1 - a)``
* :func:`distance_retention` -- far-quartile darkening over near-quartile darkening

A metric that is undefined for the input (no covered pixel, no unoccluded pixel, no near
darkening to divide by) raises :class:`MetricUndefined` with the reason; :func:`all_metrics`
turns that into ``None`` and keeps the reason.
"""

from __future__ import annotations

import cv2
import numpy as np

UNOCCLUDED = 0.99  # reference AO at or above this counts as "unoccluded" (flat walls, floors)
SSIM_SIGMA = 1.5  # Wang et al. 2004: 11x11 circular-symmetric Gaussian, sigma 1.5
SSIM_WINDOW = 11
SSIM_K1, SSIM_K2 = 0.01, 0.03
SSIM_RANGE = 1.0  # AO lives in [0, 1]
DIVISION_EPS = 1e-4  # near-quartile darkening below this is "no darkening": the ratio is meaningless

METRIC_NAMES = ("mae", "rmse", "ssim", "false_occlusion", "distance_retention")


class MetricUndefined(ValueError):
    """A metric has no value for this input; the message says why (one line)."""


def covered(depth: np.ndarray) -> np.ndarray:
    """(H, W) bool mask of the pixels with a surface: ``depth > 0`` (and finite)."""
    depth = np.asarray(depth)
    return np.isfinite(depth) & (depth > 0)


def _prepared(ao, ref, depth):
    """float64 copies of ``ao`` and ``ref`` and the covered mask, shapes checked."""
    ao, ref, depth = (np.asarray(x, np.float64) for x in (ao, ref, depth))
    if not (ao.shape == ref.shape == depth.shape and ao.ndim == 2):
        raise ValueError(
            f"ao, ref and depth must be (H, W) arrays of one shape, got {ao.shape}, {ref.shape}, {depth.shape}"
        )
    mask = covered(depth)
    if not mask.any():
        raise MetricUndefined("no covered pixel (depth > 0)")
    return ao, ref, mask


def mae(ao, ref, depth) -> float:
    """Mean absolute error over the covered pixels ``M``: ``MAE = mean_M |a - r|``."""
    ao, ref, mask = _prepared(ao, ref, depth)
    return float(np.mean(np.abs(ao - ref)[mask]))


def rmse(ao, ref, depth) -> float:
    """Root mean square error over the covered pixels ``M``: ``RMSE = sqrt(mean_M (a - r)^2)``."""
    ao, ref, mask = _prepared(ao, ref, depth)
    return float(np.sqrt(np.mean(np.square(ao - ref)[mask])))


def ssim(ao, ref, depth) -> float:
    """Mean structural similarity of ``a`` and ``r`` over the covered pixels (Wang et al. 2004).

    Per pixel, with local Gaussian-weighted statistics (window 11x11, sigma 1.5, computed with
    ``cv2.GaussianBlur``), ``C1 = (0.01 L)^2``, ``C2 = (0.03 L)^2`` and data range ``L = 1``::

        SSIM = (2 mu_a mu_r + C1) (2 s_ar + C2) / ((mu_a^2 + mu_r^2 + C1) (s_a^2 + s_r^2 + C2))

    and the result is ``mean_M SSIM``. The local statistics are *normalised* Gaussian averages
    over covered pixels only, ``E[x] = G(m x) / G(m)`` with ``m`` the covered mask, so a
    silhouette does not mix the background's AO of 1 into its neighbours' means and variances
    (without background this is exactly the standard Gaussian SSIM). 1 for identical buffers.
    """
    ao, ref, mask = _prepared(ao, ref, depth)
    m = mask.astype(np.float64)

    def blur(x):
        return cv2.GaussianBlur(x, (SSIM_WINDOW, SSIM_WINDOW), SSIM_SIGMA, borderType=cv2.BORDER_REFLECT)

    weight = np.maximum(blur(m), 1e-12)  # > 0 on every covered pixel (its own weight is in it)

    def local_mean(x):
        return blur(m * x) / weight

    mu_a, mu_r = local_mean(ao), local_mean(ref)
    var_a = local_mean(ao * ao) - mu_a * mu_a
    var_r = local_mean(ref * ref) - mu_r * mu_r
    cov = local_mean(ao * ref) - mu_a * mu_r
    c1, c2 = (SSIM_K1 * SSIM_RANGE) ** 2, (SSIM_K2 * SSIM_RANGE) ** 2
    ssim_map = ((2 * mu_a * mu_r + c1) * (2 * cov + c2)) / ((mu_a**2 + mu_r**2 + c1) * (var_a + var_r + c2))
    return float(np.mean(ssim_map[mask]))


def false_occlusion(ao, ref, depth) -> float:
    """Mean darkening where the reference sees no occlusion (flat walls and floors, open space):
    ``FO = mean_{p in M, r(p) >= 0.99} (1 - a(p))``. 0 is ideal; the darkening a mode invents."""
    ao, ref, mask = _prepared(ao, ref, depth)
    open_pixels = mask & (ref >= UNOCCLUDED)
    if not open_pixels.any():
        raise MetricUndefined(f"no covered pixel has reference AO >= {UNOCCLUDED}")
    return float(np.mean(1.0 - ao[open_pixels]))


def depth_quartiles(depth) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the nearest and the farthest depth quartile of the covered pixels.

    ``near = {p in M : depth(p) <= Q1}``, ``far = {p in M : depth(p) >= Q3}``, with ``Q1`` and
    ``Q3`` the 25th and 75th percentiles (``numpy.quantile``, linear interpolation) of the
    covered depths. Quartiles by depth value, not by pixel count: pixels at a tie all go in.
    """
    depth = np.asarray(depth, np.float64)
    mask = covered(depth)
    if not mask.any():
        raise MetricUndefined("no covered pixel (depth > 0)")
    q1, q3 = np.quantile(depth[mask], [0.25, 0.75])
    return mask & (depth <= q1), mask & (depth >= q3)


def distance_retention(ao, ref, depth) -> float:
    """How much of its near-range darkening a mode keeps at distance:
    ``DR = mean_far (1 - a) / mean_near (1 - a)`` over the farthest and nearest depth quartiles
    of the covered pixels (:func:`depth_quartiles`). A constant world radius shrinks to a few
    pixels far away and its AO fades there (DR near 0); a screen-constant radius keeps it.
    ``ref`` is not used (the signature matches the other metrics); ``DR`` of the reference
    itself is the value to compare against. Undefined when the near darkening is below 1e-4.
    """
    ao, _, _ = _prepared(ao, ref, depth)
    near, far = depth_quartiles(depth)
    near_dark = float(np.mean(1.0 - ao[near]))
    if near_dark < DIVISION_EPS:
        raise MetricUndefined(f"no darkening in the nearest depth quartile ({near_dark:.2g}) to divide by")
    return float(np.mean(1.0 - ao[far])) / near_dark


METRICS = {
    "mae": mae,
    "rmse": rmse,
    "ssim": ssim,
    "false_occlusion": false_occlusion,
    "distance_retention": distance_retention,
}


def all_metrics(ao, ref, depth) -> dict:
    """Every metric of :data:`METRIC_NAMES` as ``{name: float or None}``, plus ``"notes"``:
    ``{name: reason}`` for each metric that is undefined here (None), empty otherwise."""
    values, notes = {}, {}
    for name in METRIC_NAMES:
        try:
            values[name] = METRICS[name](ao, ref, depth)
        except MetricUndefined as exc:
            values[name], notes[name] = None, str(exc)
    values["notes"] = notes
    return values


__all__ = [
    "mae",
    "rmse",
    "ssim",
    "false_occlusion",
    "distance_retention",
    "depth_quartiles",
    "covered",
    "all_metrics",
    "MetricUndefined",
    "METRIC_NAMES",
    "UNOCCLUDED",
]
