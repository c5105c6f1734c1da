"""One view's image against its baseline: NVIDIA's FLIP (``flip-evaluator``), its mean, a high
percentile and the count of pixels above a per-pixel error, against :class:`Tolerances`.

The defaults come from the spread measured on the sample cell at 640x480, phong and vector
(docs/regress.md, ``python examples/regress/measure_spread.py``; 2 cores, Mesa llvmpipe,
2026-12-07): renders are byte-identical between runs and between LP_NUM_THREADS 0, 1 and 2, so
the tolerances are sized on what another driver may change, modelled by (a) every channel of
every pixel off by one 8-bit step at random (shader rounding) and (b) the principal point moved
by 1/256 px (llvmpipe snaps vertices to 1/256 px, other rasterisers to other grids). The worst of
the six images under (a) or (b): FLIP mean 0.0163, 99.9th percentile 0.091, 4 pixels of 307200
above 0.2. Each default is about twice or more that.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

DEFAULT_PIXEL_FLIP = 0.2  # a pixel with a FLIP error above this counts as changed (no-change: at most 0.217, 4 px)
DEFAULT_MAX_CHANGED = 1e-4  # fraction of the pixels that may be changed (31 of 640x480; no-change: 4)
DEFAULT_MEAN = 0.03  # mean FLIP error allowed (no-change: 0.0163 under one-step rounding noise)
DEFAULT_PERCENTILE = 99.9  # the high percentile of the FLIP map that is checked
DEFAULT_PERCENTILE_MAX = 0.15  # its allowed value (no-change: 0.091)
FLIP_PPD = 67.0  # FLIP's pixels per degree: its default, a 0.7 m view of a 24" 4K monitor


@dataclass(frozen=True)
class Tolerances:
    """When a view counts as unchanged: every mode within all three limits."""

    mean: float = DEFAULT_MEAN
    percentile: float = DEFAULT_PERCENTILE
    percentile_max: float = DEFAULT_PERCENTILE_MAX
    pixel_flip: float = DEFAULT_PIXEL_FLIP
    max_changed: float = DEFAULT_MAX_CHANGED


@dataclass(frozen=True)
class ModeComparison:
    """One mode of one view: the FLIP figures, the changed pixels and the verdict.

    error : (H, W) float32 FLIP error in [0, 1]; changed : (H, W) bool (error above the pixel limit).
    """

    mode: str
    mean: float
    high: float
    changed_pixels: int
    passed: bool
    error: np.ndarray
    changed: np.ndarray
    reason: str = ""


def flip_error(reference: np.ndarray, test: np.ndarray) -> tuple[np.ndarray, float]:
    """(FLIP map (H, W) float32, its mean) of two (H, W, 3) uint8 sRGB images."""
    import flip_evaluator  # its C++ extension loads only when a check runs

    ref = np.ascontiguousarray(reference, np.float32) / 255.0
    tst = np.ascontiguousarray(test, np.float32) / 255.0
    error, mean, _ = flip_evaluator.evaluate(ref, tst, "LDR", applyMagma=False, parameters={"ppd": FLIP_PPD})
    return np.asarray(error, np.float32).reshape(ref.shape[:2]), float(mean)


def compare_images(mode: str, baseline: np.ndarray, now: np.ndarray, tolerances: Tolerances) -> ModeComparison:
    """``now`` against ``baseline``; images of different sizes are a change of every pixel."""
    if baseline.shape != now.shape:
        h, w = now.shape[:2]
        everything = np.ones((h, w), bool)
        reason = f"size {now.shape[1]}x{now.shape[0]}, baseline {baseline.shape[1]}x{baseline.shape[0]}"
        return ModeComparison(mode, 1.0, 1.0, h * w, False, everything.astype(np.float32), everything, reason)
    if np.array_equal(baseline, now):  # the usual case in CI: no FLIP (0.5-1 s an image here) needed
        nothing = np.zeros(now.shape[:2], np.float32)
        return ModeComparison(mode, 0.0, 0.0, 0, True, nothing, nothing.astype(bool))
    error, mean = flip_error(baseline, now)
    high = float(np.percentile(error, tolerances.percentile))
    changed = error > tolerances.pixel_flip
    count = int(changed.sum())
    reasons = []
    if mean > tolerances.mean:
        reasons.append(f"FLIP mean {mean:.4f} > {tolerances.mean:g}")
    if high > tolerances.percentile_max:
        reasons.append(f"FLIP p{tolerances.percentile:g} {high:.3f} > {tolerances.percentile_max:g}")
    if count > tolerances.max_changed * changed.size:
        reasons.append(f"{count} px above FLIP {tolerances.pixel_flip:g} > {tolerances.max_changed * changed.size:.0f}")
    return ModeComparison(mode, mean, high, count, not reasons, error, changed, "; ".join(reasons))


def difference_image(error: np.ndarray, changed: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB: the FLIP map in magma (black: no difference), the changed regions
    outlined in cyan (dilated, so that a sliver of a few pixels is seen at a glance)."""
    grey = np.clip(np.round(error * 255.0), 0, 255).astype(np.uint8)
    image = cv2.cvtColor(cv2.applyColorMap(grey, cv2.COLORMAP_MAGMA), cv2.COLOR_BGR2RGB)
    if changed.any():
        region = cv2.dilate(changed.astype(np.uint8), np.ones((9, 9), np.uint8))
        contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(image, contours, -1, (0, 255, 255), 1)
    return image


__all__ = ["Tolerances", "ModeComparison", "compare_images", "difference_image", "flip_error"]
