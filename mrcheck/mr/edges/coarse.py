"""The coarse stage of :func:`mrcheck.mr.edges.refine_pose`: from a rough pose 15-40 px off to
within a pixel or two, on the oriented chamfer distance (:mod:`mrcheck.mr.edges.chamfer`).

1. On the coarsest level, a search over the view direction: the CAD's salient edge samples
   shifted over a grid of image offsets (the rough pose's error is mostly a pan or tilt), the
   offset with the lowest truncated chamfer cost taken as a camera rotation.
2. Per level, coarse to fine down to the second finest, Levenberg-Marquardt on the chamfer
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

from mrcheck.mr.edges import chamfer, solver

HUBER_PX = 1.0          # the chamfer residual's Huber threshold (level px)
_CONVERGED_PX = 0.05    # a step moving no sample more than this (level px) ends the level
_RIDGE = 1e-4           # times the trace of the normal equations (see chamfer_level)


@dataclass
class CoarseReport:
    """What the coarse stage did: the shift found (full px), and per level ``(scale,
    iterations, samples, share of samples within the truncation)``."""

    shift_px: tuple
    levels: list


def grey_levels(grey: np.ndarray, count: int) -> list:
    """The photo (float 0..1) at ``count`` pyramid levels (``cv2.pyrDown``), level 0 first."""
    image = grey.astype(np.float32) / (255.0 if grey.dtype == np.uint8 else 1.0)
    out = [image]
    for _ in range(count - 1):
        out.append(cv2.pyrDown(out[-1]))
    return out


def rotated(state: solver.PoseState, camera, du: float, dv: float) -> solver.PoseState:
    """``state`` turned so that points ahead move by about ``(du, dv)`` full-resolution px
    (a pan about the camera's y axis, a tilt about its x axis)."""
    dR = cv2.Rodrigues(np.array([-dv / camera.K[1, 1], du / camera.K[0, 0], 0.0]))[0]
    return solver.PoseState(cv2.Rodrigues(dR @ state.R)[0].ravel(), dR @ state.t, state.centre)


def _chamfer(fitter, cmap, samples):
    proj = solver.project(fitter.state, fitter.camera, samples.points, samples.tangents)
    d, g = chamfer.lookup(cmap, proj.uv * cmap.scale, chamfer.bins_of(proj.normal))
    rows = np.einsum("ni,nij->nj", g, proj.J) * cmap.scale
    return d, rows


def search_shift(fitter, cmap, radius_px: float) -> tuple:
    """Step 1: the best image shift (full px) of the salient samples at the current pose, applied."""
    samples = fitter.samples_for(cmap.scale)
    proj = solver.project(fitter.state, fitter.camera, samples.points, samples.tangents)
    du, dv, _ = chamfer.best_shift(cmap, proj.uv * cmap.scale, chamfer.bins_of(proj.normal), radius_px * cmap.scale)
    du, dv = du / cmap.scale, dv / cmap.scale
    fitter.state = rotated(fitter.state, fitter.camera, du, dv)
    return du, dv


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
        if shift > chamfer.TRUNCATE_PX:           # a trust region: the truncation's width
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
    """Steps 1 and 2 on the levels ``levels - 1`` down to 1 (only step 1 when ``levels`` is 1)."""
    images = grey_levels(grey, levels)
    coarsest = len(images) - 1
    cmap = chamfer.chamfer_map(images[coarsest], 0.5 ** coarsest)
    shift = search_shift(fitter, cmap, search_px)
    reports = []
    for index in range(coarsest, 0, -1):
        if index != coarsest:
            cmap = chamfer.chamfer_map(images[index], 0.5 ** index)
        reports.append((cmap.scale, *chamfer_level(fitter, cmap, iterations, rerender_px)))
    return CoarseReport(shift, reports)


__all__ = ["CoarseReport", "grey_levels", "rotated", "search_shift", "chamfer_level", "coarse_align", "HUBER_PX"]
