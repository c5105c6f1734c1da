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

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import chamfer, model, search, solver

HUBER_PX = chamfer.HUBER_PX  # the chamfer residual's Huber threshold (level px)
_CONVERGED_PX = 0.05  # a step moving no sample more than this (level px) ends the level
_RIDGE = 1e-4  # times the trace of the normal equations (see chamfer_level)

Sampler = Callable[[solver.PoseState, float], model.Samples]
"""The visible, salient edge samples at a pose and a level scale
(:meth:`mrcheck.mr.edges.fitter.Fitter.samples_for`)."""


@dataclass
class ChamferLevelReport:
    """What step 2 did on one level: ``pose`` the pose it ended at, ``scale`` the level's,
    ``iterations``, ``samples`` and ``near`` the share of samples within the truncation."""

    pose: solver.PoseState
    scale: float
    iterations: int
    samples: int
    near: float


@dataclass
class CoarseReport:
    """What the coarse stage did: ``pose`` the pose it ended at, ``search`` the pose search
    (:class:`~mrcheck.mr.edges.search.SearchReport`) and ``levels`` step 2 per level."""

    pose: solver.PoseState
    search: search.SearchReport
    levels: list[ChamferLevelReport]


def grey_levels(grey: np.ndarray, count: int) -> list[np.ndarray]:
    """The photo (float 0..1) at ``count`` pyramid levels (``cv2.pyrDown``), level 0 first."""
    image = grey.astype(np.float32) / (255.0 if grey.dtype == np.uint8 else 1.0)
    out: list[np.ndarray] = [image]
    for _ in range(count - 1):
        out.append(cv2.pyrDown(out[-1]))
    return out


def _chamfer(
    pose: solver.PoseState, camera: Camera, cmap: chamfer.ChamferMap, samples: model.Samples
) -> tuple[np.ndarray, np.ndarray]:
    """The samples' chamfer distances at ``pose`` and their rows (d distance / d pose)."""
    proj = solver.project(pose, camera, samples.points, samples.tangents)
    d, g = chamfer.lookup(cmap, proj.uv * cmap.scale, chamfer.bins_of(proj.normal))
    rows = np.einsum("ni,nij->nj", g, proj.J) * cmap.scale
    return d, rows


def chamfer_level(
    pose: solver.PoseState,
    camera: Camera,
    sampler: Sampler,
    cmap: chamfer.ChamferMap,
    iterations: int,
    rerender_px: float,
) -> ChamferLevelReport:
    """Step 2 on one level from ``pose`` (``camera``: the photo's intrinsics; ``sampler``: the
    visible edges at a pose, found again after ``rerender_px`` level px of steps)."""
    samples = sampler(pose, cmap.scale)
    d, rows = _chamfer(pose, camera, cmap, samples)
    now, damping, moved, done = chamfer.cost(d), 1e-3, 0.0, 0
    while done < iterations and damping < 1e4:
        done += 1
        near = d < chamfer.TRUNCATE_PX
        if np.count_nonzero(near) < 6:
            break
        weights = chamfer.huber_weights(d)
        # a ridge: on a coarse level a direction the edges leave open (parallel lines) would
        # otherwise take any step the noise asks for (measured: a bar turned 6 degrees)
        step = solver.gauss_newton_step(rows[near], d[near], weights[near], damping, ridge=_RIDGE)
        if step is None:
            break
        shift = float(np.max(np.abs(rows @ step)))
        if shift > chamfer.TRUNCATE_PX:  # a trust region: the truncation's width
            step, shift = step * (chamfer.TRUNCATE_PX / shift), chamfer.TRUNCATE_PX
        trial = pose.moved(step)
        d_new, rows_new = _chamfer(trial, camera, cmap, samples)
        if chamfer.cost(d_new) >= now:
            damping = damping * 10.0
            continue
        pose = trial
        damping, moved = max(damping / 10.0, 1e-6), moved + shift
        if shift < _CONVERGED_PX:
            d = d_new
            break
        if moved > rerender_px:
            samples, moved = sampler(pose, cmap.scale), 0.0
            d_new, rows_new = _chamfer(pose, camera, cmap, samples)
        d, rows, now = d_new, rows_new, chamfer.cost(d_new)
    return ChamferLevelReport(pose, cmap.scale, done, len(samples), float(np.mean(d < chamfer.TRUNCATE_PX)))


@dataclass
class Searched:
    """Step 1's outcome: ``report`` the search (its pose and alternates), ``images`` the photo's
    levels and ``first`` the index of the level searched (step 2 starts there)."""

    report: search.SearchReport
    images: list
    first: int


def search_start(
    pose: solver.PoseState, camera: Camera, sampler: Sampler, grey: np.ndarray, levels: int, search_px: float
) -> Searched:
    """Step 1 on the level :func:`~mrcheck.mr.edges.search.search_level` picks, from the rough
    ``pose``. Levels coarser than the searched one are not used: at 160 px wide the generated
    cell's true pose does not have the lowest chamfer cost (measured, seeds 0-9: a wrong pose's
    9.5 against the truth's 10.2)."""
    images = grey_levels(grey, levels)
    first = search.search_level([image.shape[1] for image in images])
    cmap = chamfer.chamfer_map(images[first], 0.5**first)
    return Searched(search.search_pose(pose, camera, sampler(pose, cmap.scale), cmap, search_px), images, first)


def descend(
    searched: Searched, pose: solver.PoseState, camera: Camera, sampler: Sampler, iterations: int, rerender_px: float
) -> CoarseReport:
    """Step 2 from ``pose`` (the search's or one of its alternates) on the level searched and the
    finer ones down to level 1 (none when the photo has one level)."""
    reports = []
    for index in range(searched.first, 0, -1):
        cmap = chamfer.chamfer_map(searched.images[index], 0.5**index)
        reports.append(chamfer_level(pose, camera, sampler, cmap, iterations, rerender_px))
        pose = reports[-1].pose
    return CoarseReport(pose, searched.report, reports)


def coarse_align(
    pose: solver.PoseState,
    camera: Camera,
    sampler: Sampler,
    grey: np.ndarray,
    levels: int,
    search_px: float,
    iterations: int,
    rerender_px: float,
) -> CoarseReport:
    """Step 1 (:func:`search_start`) then step 2 (:func:`descend`) from the pose the search chose
    (``camera``, ``sampler``: see :func:`chamfer_level`)."""
    searched = search_start(pose, camera, sampler, grey, levels, search_px)
    return descend(searched, searched.report.pose, camera, sampler, iterations, rerender_px)


__all__ = [
    "CoarseReport",
    "ChamferLevelReport",
    "Sampler",
    "grey_levels",
    "chamfer_level",
    "coarse_align",
    "search_start",
    "descend",
    "Searched",
    "HUBER_PX",
]
