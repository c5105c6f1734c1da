"""The coarse stage of :func:`mrcheck.mr.edges.refine_pose`: from a rough pose 15-40 px off to
within a pixel or two, on the oriented chamfer distance (:mod:`mrcheck.mr.edges.chamfer`).

1. On the level about 320 px wide, a search over whole poses (:mod:`mrcheck.mr.edges.search`:
   thousands of candidate poses scored on the truncated chamfer cost of the linearised
   projection, a beam search).
2. Per level from there down to the second finest, Levenberg-Marquardt on the chamfer
   distance (Huber weights, truncated: a CAD edge with no photo edge of its direction within
   :data:`~mrcheck.mr.edges.chamfer.TRUNCATE_PX` does not pull), the visible edges found again
   when the pose moved.

The fine levels then match along the normal (:mod:`mrcheck.mr.edges.photo`): sub-pixel, and
the residuals the uncertainty is computed from.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.mr.edges import chamfer, search, solver

HUBER_PX = 1.0  # the chamfer residual's Huber threshold (level px)
_CONVERGED_PX = 0.05  # a step moving no sample more than this (level px) ends the level
_RIDGE = 1e-4  # times the trace of the normal equations (see chamfer_level)


@dataclass
class CoarseReport:
    """What the coarse stage did: the pose search (:class:`~mrcheck.mr.edges.search.SearchReport`),
    and per level ``(scale, iterations, samples, share of samples within the truncation)``."""

    search: search.SearchReport
    levels: list


def grey_levels(grey: np.ndarray, count: int) -> list:
    """The photo (float 0..1) at ``count`` pyramid levels (``cv2.pyrDown``), level 0 first."""
    image = grey.astype(np.float32) / (255.0 if grey.dtype == np.uint8 else 1.0)
    out = [image]
    for _ in range(count - 1):
        out.append(cv2.pyrDown(out[-1]))
    return out


def _chamfer(fitter, cmap, samples):
    proj = solver.project(fitter.state, fitter.camera, samples.points, samples.tangents)
    d, g = chamfer.lookup(cmap, proj.uv * cmap.scale, chamfer.bins_of(proj.normal))
    rows = np.einsum("ni,nij->nj", g, proj.J) * cmap.scale
    return d, rows


def chamfer_level(fitter, cmap, iterations: int, rerender_px: float) -> tuple:
    """Step 2 on one level: ``(iterations, samples, share within the truncation)``."""
    samples = fitter.samples_for(cmap.scale)
    d, rows = _chamfer(fitter, cmap, samples)
    now, damping, moved, done = chamfer.cost(d), 1e-3, 0.0, 0
    while done < iterations and damping < 1e4:
        done += 1
        near = d < chamfer.TRUNCATE_PX
        if np.count_nonzero(near) < 6:
            break
        weights = np.where(near, np.minimum(1.0, HUBER_PX / np.maximum(d, 1e-9)), 0.0)
        # a ridge: on a coarse level a direction the edges leave open (parallel lines) would
        # otherwise take any step the noise asks for (measured: a bar turned 6 degrees)
        step = solver.gauss_newton_step(rows[near], d[near], weights[near], damping, ridge=_RIDGE)
        if step is None:
            break
        shift = float(np.max(np.abs(rows @ step)))
        if shift > chamfer.TRUNCATE_PX:  # a trust region: the truncation's width
            step, shift = step * (chamfer.TRUNCATE_PX / shift), chamfer.TRUNCATE_PX
        before = fitter.state
        fitter.state = before.moved(step)
        d_new, rows_new = _chamfer(fitter, cmap, samples)
        if chamfer.cost(d_new) >= now:
            fitter.state, damping = before, damping * 10.0
            continue
        damping, moved = max(damping / 10.0, 1e-6), moved + shift
        if shift < _CONVERGED_PX:
            d = d_new
            break
        if moved > rerender_px:
            samples, moved = fitter.samples_for(cmap.scale), 0.0
            d_new, rows_new = _chamfer(fitter, cmap, samples)
        d, rows, now = d_new, rows_new, chamfer.cost(d_new)
    return done, len(samples), float(np.mean(d < chamfer.TRUNCATE_PX))


def coarse_align(fitter, grey, levels: int, search_px: float, iterations: int, rerender_px: float) -> CoarseReport:
    """Step 1 on the level :func:`~mrcheck.mr.edges.search.search_level` picks, step 2 on that
    level and the finer ones down to level 1 (only step 1 when ``levels`` is 1). Levels coarser
    than the searched one are not used: at 160 px wide the generated cell's true pose no longer
    has the lowest chamfer cost (measured, seeds 0-9: a wrong pose's 9.5 against the truth's 10.2)."""
    images = grey_levels(grey, levels)
    first = search.search_level([image.shape[1] for image in images])
    cmap = chamfer.chamfer_map(images[first], 0.5**first)
    found = search.search_pose(fitter, cmap, search_px)
    reports = []
    for index in range(first, 0, -1):
        if index != first:
            cmap = chamfer.chamfer_map(images[index], 0.5**index)
        reports.append((cmap.scale, *chamfer_level(fitter, cmap, iterations, rerender_px)))
    return CoarseReport(found, reports)


__all__ = ["CoarseReport", "grey_levels", "chamfer_level", "coarse_align", "HUBER_PX"]
