"""Edge registration: snap a rough camera pose onto the photo's edges (:func:`refine_pose`).

Coarse to fine over an image pyramid (the coarsest level about 160 px wide): the coarse stage
(:mod:`mrcheck.mr.edges.coarse`: a search over whole poses, then the oriented chamfer distance)
down to the second finest level, then on the two finest levels the search along the normal and
robust Gauss-Newton (:class:`~mrcheck.mr.edges.fitter.Fitter`), then the verdict
(:mod:`mrcheck.mr.edges.verdict`). The search radius of the coarsest level is how far off the
rough pose may be (``EdgeOptions.search_px``, full-resolution pixels).

Modules: ``options`` (the settings and results), ``fitter`` (one level's fit), ``coarse`` and
``search`` (the coarse stage), ``verdict`` (the statistics, the uncertainty, the failure tests),
``restarts`` (an accepted fit made again when one part fits far worse than the others).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.mr.edges import coarse, model, photo, restarts, solver, verdict
from mrcheck.mr.edges.candidates import CandidateEdges
from mrcheck.mr.edges.fitter import NEXT_LEVEL_SIGMA, Clock, Fitter
from mrcheck.mr.edges.options import EdgeFit, EdgeFitError, EdgeOptions, LevelReport, VisibilityRender, level_count

if TYPE_CHECKING:
    from mrcheck.render.renderer import Renderer
    from mrcheck.scene.model import Scene


def photo_pyramid(grey: np.ndarray, options: EdgeOptions) -> list[photo.Level]:
    """The gradient pyramid (:func:`photo.pyramid`) of the photo ``grey`` that :func:`refine_pose`
    fits the CAD's edges to with ``options``; made beforehand and given to it as ``pyramid=``
    where the photo is known early (a video's next frame, on a thread beside this one's fit)."""
    grey = _grey(grey)
    return photo.pyramid(grey, level_count(grey.shape[1], options))


def refine_pose(
    scene: Scene,
    camera: Camera,
    grey: np.ndarray,
    initial: Camera | None = None,
    options: EdgeOptions | None = None,
    *,
    renderer: Renderer | None = None,
    edges: model.EdgeSet | None = None,
    candidates: CandidateEdges | None = None,
    seed: VisibilityRender | None = None,
    pyramid: list[photo.Level] | None = None,
) -> EdgeFit:
    """Snap the pose of ``camera`` (or of ``initial``) onto the edges of the photo ``grey``.

    ``scene``: the :class:`~mrcheck.scene.model.Scene`; ``camera``: the photo's intrinsics (at the
    photo's size, lens distortion as calibrated) and, without ``initial``, the rough pose;
    ``grey``: (H, W) photo, uint8 or float in 0..1 (colour is converted). ``renderer``: a
    :class:`~mrcheck.render.renderer.Renderer` of ``scene`` to reuse (a video), else one is made
    and released; ``edges``: :func:`~mrcheck.mr.edges.model.scene_edges` of the scene, to reuse;
    ``candidates``: a :class:`~mrcheck.mr.edges.candidates.CandidateEdges` of those edges kept
    from the fit of the previous video frame (its edges seen are reused while the view moved
    less than :data:`~mrcheck.mr.edges.candidates.REUSE_PX` level px); ``seed``: a
    :class:`VisibilityRender` near the start that finds the visible edges of the first
    full-resolution sampling instead of a render (the edges' visibility judged from its pose);
    ``pyramid``: :func:`photo_pyramid` of ``grey`` with these options, made beforehand.
    Raises :class:`EdgeFitError` when the fit diverges or ends with too little support: below
    ``options.min_support`` of the samples kept, its support beyond chance too low, or the parts
    left out (no support) holding more than ``options.max_left_out`` of the visible samples (a
    wrong pose fitting a few parts).
    """
    options = (options or EdgeOptions()).validated()
    colour = np.asarray(grey) if options.reads_colour else None
    grey = _grey(grey)
    if grey.shape != (camera.height, camera.width):
        raise MrcheckError(f"photo is {grey.shape[1]}x{grey.shape[0]} but the camera is {camera.width}x{camera.height}")
    levels = level_count(camera.width, options)
    if pyramid is not None and (len(pyramid) != levels or pyramid[0].gx.shape != grey.shape):
        raise MrcheckError(
            f"the photo's pyramid ({len(pyramid)} levels of {pyramid[0].gx.shape[::-1]}) is not "
            f"this photo's with these options ({levels} levels)"
        )
    start_total = time.perf_counter()
    clock = Clock()
    start = time.perf_counter()
    edges = edges if edges is not None else model.scene_edges(scene)
    clock.add("edges", start)
    own = renderer is None
    if renderer is None:
        from mrcheck.render.renderer import Renderer

        renderer = Renderer(scene)
    try:
        start_pose = camera if initial is None else camera.with_pose(initial.R, initial.t)
        start = time.perf_counter()
        pyramid = pyramid if pyramid is not None else photo_pyramid(grey, options)
        clock.add("photo", start)
        fitter = Fitter(edges, renderer, camera, pyramid, options, clock, candidates, seed, colour)
        fit = _fit(fitter, start_pose, grey)
    finally:
        if own:
            renderer.release()
    fit.times_s = {**clock.times, "total": time.perf_counter() - start_total}
    return fit


def _grey(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 3:
        image = image[..., :3].astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)
        return image / 255.0 if image.max() > 1.5 else image
    return image


def _fit(fitter: Fitter, rough: Camera, grey: np.ndarray) -> EdgeFit:
    """The chamfer schedule (:func:`chamfer_schedule`) from the pose search's choice, or with
    ``coarse="normal"`` the search along the normal on every level (:func:`normal_schedule`).

    A start the verdict refuses is not the end: the chamfer schedule is made again from each of
    the search's alternates (:meth:`~mrcheck.mr.edges.search.SearchReport.alternates`: other
    basins, scored at their exact projection), then, when parts' outlines are sampled
    (:attr:`EdgeOptions.silhouette`), by the normal schedule, whose outline samples are matched
    by their colour regions from the coarsest level on; the first fit accepted is returned, else
    the first refusal. Why: the chamfer distance of grey edges finds the clutter around a
    scanned object as readily as its outline (DLR M3T frame 200: from the published pose the
    chamfer schedule was refused, the normal schedule stayed within 1.6 px; BOP LM-O photos 3
    and 402 from 40 px off: the search's choice refused in 5 of 16 cases that an alternate fits)."""
    if fitter.options.coarse == "normal":
        return _restarted(fitter, rough, normal_schedule(fitter, rough))
    pose = solver.PoseState.of(rough, _edges_centre(fitter.edges, rough))
    start, before = time.perf_counter(), dict(fitter.clock.times)
    searched = coarse.search_start(
        pose, fitter.camera, fitter.samples_for, grey, len(fitter.pyramid), fitter.options.search_px
    )
    _count_coarse(fitter, start, before)
    failures = []
    for attempt, found in enumerate(_starts(searched.report)):
        if attempt:
            fitter.restart()
        try:
            fit = chamfer_schedule(fitter, rough, searched, found)
        except EdgeFitError as exc:
            failures.append(exc)
            continue
        return _restarted(fitter, rough, fit, other=fitter.contours is not None)
    if fitter.contours is not None:
        fitter.restart()
        try:
            return _restarted(fitter, rough, normal_schedule(fitter, rough))
        except EdgeFitError:
            pass
    raise failures[0]


def _restarted(fitter: Fitter, rough: Camera, fit: EdgeFit, other: bool = False) -> EdgeFit:
    """``fit``, or with ``options.restarts`` and a part lagging a restart that beats it
    (:mod:`.restarts`); with ``other`` (a chamfer fit, outlines sampled) the normal schedule's
    fit and its restarts are candidates too. Why: on DLR M3T frame 200 from 20 px off the
    chamfer schedule accepted three poses 52-118 px off (0.12-0.14 beyond chance, the bottle
    lagging) where the normal schedule fits (0.55 and above)."""
    if not fitter.options.restarts or restarts.lagging_part(fit) is None:
        return fit
    best = _best_restart(fitter, rough, fit)
    if other:
        fitter.restart()
        try:
            candidate = _best_restart(fitter, rough, normal_schedule(fitter, rough))
        except EdgeFitError:
            return best
        if candidate.above_chance > best.above_chance + restarts.MIN_GAIN:
            chamfer = f"the chamfer schedule's fit had {fit.above_chance:.2f} beyond chance, the normal schedule's"
            best, candidate.restart = candidate, "; ".join(filter(None, [chamfer + " is kept", candidate.restart]))
    return best


def _best_restart(fitter: Fitter, rough: Camera, fit: EdgeFit) -> EdgeFit:
    centre = _edges_centre(fitter.edges, fit.camera)
    return restarts.best_of(fitter, fit, centre, lambda pose: _fine_levels(fitter, rough, pose))


def _starts(report):
    """The search's choice, then (only when asked for: after a refusal) its alternates."""
    yield report.pose
    yield from report.alternates()


def _count_coarse(fitter: Fitter, start: float, before: dict) -> None:
    """The coarse stage's own time since ``start`` (chamfer maps, search, solve); its renders
    count as "render" (``before``: the clock's stages at ``start``)."""
    inner = sum(fitter.clock.times[k] - before[k] for k in before)
    fitter.clock.times["coarse"] += time.perf_counter() - start - inner


def normal_schedule(fitter: Fitter, rough: Camera) -> EdgeFit:
    """The search along the normal on every level, coarse to fine."""
    pose = solver.PoseState.of(rough, _edges_centre(fitter.edges, rough))
    options, pyramid = fitter.options, fitter.pyramid
    reports: list[LevelReport] = []
    for index in reversed(range(len(pyramid))):
        # the first level's scale: the rough pose's error, a third of the search radius
        sigma = options.search_px * pyramid[index].scale / solver.TUKEY_C if not reports else NEXT_LEVEL_SIGMA
        pose, report = fitter.run_level(pyramid[index], pose, sigma, judge_parts=bool(reports))
        reports.append(report)
    return verdict.finish(fitter, pose, rough, reports)


def chamfer_schedule(fitter: Fitter, rough: Camera, searched: coarse.Searched, pose: solver.PoseState) -> EdgeFit:
    """From ``pose`` (the search's choice or an alternate): the descent on the chamfer distance
    down to the second finest level, then the two finest levels along the normal."""
    options = fitter.options
    start, before = time.perf_counter(), dict(fitter.clock.times)
    descent = coarse.descend(searched, pose, fitter.camera, fitter.samples_for, options.iterations, options.rerender_px)
    _count_coarse(fitter, start, before)
    return _fine_levels(fitter, rough, descent.pose)


def _fine_levels(fitter: Fitter, rough: Camera, pose: solver.PoseState) -> EdgeFit:
    """The two finest levels along the normal from ``pose``, then the verdict."""
    reports: list[LevelReport] = []
    for index in reversed(range(min(2, len(fitter.pyramid)))):
        pose, report = fitter.run_level(fitter.pyramid[index], pose, NEXT_LEVEL_SIGMA, judge_parts=True)
        reports.append(report)
    return verdict.finish(fitter, pose, rough, reports)


def _edges_centre(edges: model.EdgeSet, camera: Camera) -> np.ndarray:
    """A centre for the pose's rotation: the mean of the edge midpoints in front of the camera."""
    mid = edges.mid
    # the mean as a matrix-vector product of the 0/1 weights (numpy's mean over the rows of a
    # (n, 3) array took 5.6 ms of the 7.4 ms this took per video frame on the generated cell)
    ahead = ((mid @ camera.R[2] + camera.t[2]) > 0).astype(np.float64)
    if not np.any(ahead):
        ahead[:] = 1.0
    return (ahead @ mid) / np.sum(ahead)


__all__ = ["refine_pose", "photo_pyramid", "chamfer_schedule", "normal_schedule"]
