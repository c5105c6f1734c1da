"""One edge fit's levels (:class:`Fitter`): the visible edges at a pose, their matches along the
normal and the robust Levenberg-Marquardt of a pyramid level.

At each level the CAD is rendered at the current pose (the depth buffer says which mesh edges
are seen, :mod:`mrcheck.mr.edges.model`), points are sampled along the visible edges every few
level pixels, each is matched to the nearest photo edge along its image normal
(:mod:`mrcheck.mr.edges.photo`), and robust Gauss-Newton steps move the pose
(:mod:`mrcheck.mr.edges.solver`); the visible edges are found again when the pose has moved by
more than a pixel or two of the level. Parts whose edges find (almost) no support are dropped
from the finer levels (a CAD part missing in the hall).

The pose is a :class:`~mrcheck.mr.edges.solver.PoseState` passed in and returned: a level (and
the coarse stage, :mod:`mrcheck.mr.edges.coarse`) takes the pose it starts from and returns the
pose it ends at. The fitter keeps what the levels leave for the next and for the verdict
(:mod:`mrcheck.mr.edges.verdict`): the parts left out, the last visible samples.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.mr.edges import model, photo, region, silhouette, solver
from mrcheck.mr.edges.candidates import CandidateEdges
from mrcheck.mr.edges.options import MIN_SAMPLES, EdgeFitError, EdgeOptions, LevelReport, VisibilityRender
from mrcheck.render.settings import RenderSettings

if TYPE_CHECKING:
    from mrcheck.render.renderer import Renderer

NEXT_LEVEL_SIGMA = 1.5  # a finer level starts here (level px): the coarser one's floor, doubled
_CANDIDATES = 24  # edge points made per sample kept (in a dense hall most are hidden or not salient)
_PART_MIN_SAMPLES = 12  # a part with fewer samples is never judged on its own
_PART_MIN_SUPPORT = 0.2  # ... and one whose samples find support less often than this is dropped
_CONVERGED_PX = 0.02  # a step moving no sample more than this (level px) ends the level
_SIGMA_FLOOR_PX = 0.3  # the robust scale's floor at full resolution (level px: twice this)
_ANNEAL = 0.7  # the robust scale shrinks by this after every step kept
_REGION_SNAP_PX = 1.5  # region_match: a gradient peak this near (level px) the region's split refines it
_RENDER_MAX_WIDTH = 800  # renders for the visible edges at most this wide (see _render_size)
STAGES = ("render", "edges", "photo", "coarse", "match", "solve", "uncertainty")  # EdgeFit.times_s


class Clock:
    """Seconds per stage of one fit (:data:`STAGES`)."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {k: 0.0 for k in STAGES}

    def add(self, stage: str, start: float) -> float:
        """Add the time since ``start`` to ``stage``; returns the time now (the next stage's start)."""
        self.times[stage] += time.perf_counter() - start
        return time.perf_counter()


@dataclass
class _Evaluation:
    r: np.ndarray
    rows: np.ndarray
    proj: solver.Projection
    found: photo.Matches
    weights: np.ndarray
    sigma: float
    cost: float


def _radius(sigma: float) -> int:
    """The search radius (level px) of a robust scale: the Tukey support, at least 3 px."""
    return max(3, int(math.ceil(solver.TUKEY_C * sigma)))


def thinned(samples: model.Samples, most: int) -> model.Samples:
    """``samples`` evenly thinned to at most ``most``."""
    if len(samples) <= most:
        return samples
    return model.subset(samples, np.linspace(0, len(samples) - 1, most).astype(int))


def render_depth(renderer: Renderer, camera: Camera, with_normals: bool = False):
    """(H, W) float32 linear depth of ``camera`` (0 = background), from the renderer's
    G-buffer alone (no shading pass; full detail: a simplified mesh moves the edges; single-
    sampled: every pixel's own centre, and no multisampled pass to pay); with ``with_normals``
    also the (H, W, 3) camera-space normals."""
    frame = renderer.render(camera, [], RenderSettings(lod_px=0.0, antialias=False), want_normals=with_normals)
    return (frame.depth, frame.normals) if with_normals else frame.depth


def _render_size(camera: Camera, scale: float) -> tuple[int, int]:
    """The size of the render that finds a level's visible edges: the level's, halved until at
    most :data:`_RENDER_MAX_WIDTH` wide. Why: a render of 1280x960 took 0.6-1.4 s on llvmpipe
    (2 cores shared), four times one of 640x480, and there were four or more per fit; the
    samples' positions stay the exact 3D edges, only their depth test and the salience probes
    (:func:`model.salient`, 1 and 2 render px) are on the coarser buffer."""
    while scale > 1e-3 and camera.width * scale > _RENDER_MAX_WIDTH:
        scale *= 0.5
    return max(1, round(camera.width * scale)), max(1, round(camera.height * scale))


class Fitter:
    """One fit's inputs (the edges, the renderer, the photo's camera and pyramid, the options,
    the clock) and what its levels leave behind: ``dropped`` (per instance: left out, no
    support), ``last_full`` (the full-resolution level's last samples of the parts kept, reused
    by the verdict), ``visible_groups`` and ``all_visible`` (the last render's visible, salient
    samples and their instances, the left-out parts' too), ``candidates`` (the edges' samples
    kept between renders) and ``seed`` (a :class:`VisibilityRender` for the first
    full-resolution sampling, used once)."""

    def __init__(
        self,
        edges: model.EdgeSet,
        renderer: Renderer,
        camera: Camera,
        pyramid: list[photo.Level],
        options: EdgeOptions,
        clock: Clock,
        candidates: CandidateEdges | None = None,
        seed: VisibilityRender | None = None,
        colour: np.ndarray | None = None,
    ) -> None:
        self.edges, self.renderer, self.camera, self.options, self.clock = edges, renderer, camera, options, clock
        self.pyramid = pyramid
        self.dropped = np.zeros(len(edges.group_names), bool)
        self.last_full: model.Samples | None = None
        self.visible_groups = np.zeros(0, np.int64)
        self.all_visible: model.Samples | None = None
        self.candidates = candidates if candidates is not None else CandidateEdges(edges)
        self.seed = seed
        # per instance: its outline is sampled (EdgeOptions.silhouette; automatic: the curved parts,
        # when their outline outnumbers the crease samples in the first view, see judge_outlines)
        self.outlined = np.full(len(self.dropped), options.silhouette is True)
        self.judged = options.silhouette is not None
        if options.silhouette is None:
            self.outlined = silhouette.curved_parts(edges)
        self.contours = silhouette.ContourModel(edges) if np.any(self.outlined) else None
        # the region criterion's colour bins per level and foreground posterior per level scale
        use_region = self.contours is not None and options.region
        self.bins = region.colour_levels(colour, len(pyramid)) if use_region and colour is not None else []
        self.posteriors: dict[float, np.ndarray] = {}

    def outlined_names(self) -> list[str]:
        """The instances whose outlines were sampled (none when the view's judgement turned them off)."""
        if self.contours is None:
            return []
        return [name for name, on in zip(self.edges.group_names, self.outlined) if on]

    def restart(self) -> None:
        """Forget what a failed schedule left (the parts left out, the last samples, the
        region statistics) before the fit is made again from the start."""
        self.dropped[:] = False
        self.last_full, self.all_visible = None, None
        self.visible_groups = np.zeros(0, np.int64)
        self.posteriors = {}

    def visible_samples(self, pose: solver.PoseState, scale: float) -> model.Samples:
        """Samples of the visible, salient edges at ``pose`` (:func:`model.salient` on the
        render's depth and normals at the level's size, at most :data:`_RENDER_MAX_WIDTH` wide,
        or on the :class:`VisibilityRender` given to the fit), thinned to ``max_samples``."""
        start = time.perf_counter()
        cam = pose.camera(self.camera)
        view, depth, normals = self.render_for(cam, scale)
        start = self.clock.add("render", start)
        samples, fresh = self.candidates.sample(
            cam, scale, self.options.spacing_px / scale, _CANDIDATES * self.options.max_samples
        )
        # seen and salient as judged from the render's viewpoint (the current one, or a given
        # render's near it): the edges' 3D points projected by the camera that made the buffers
        samples = model.subset(samples, model.visible(samples, view, depth))
        if len(samples) >= MIN_SAMPLES or (self.contours is not None and len(samples)):
            uv, normal, local = model.pinhole_samples(view, samples, depth.shape)
            keep, outside = model.salient(uv, normal, local, depth, normals, view.resized(*depth.shape[::-1]).K)
            samples.outside = outside
            samples = model.subset(samples, keep)
        if fresh:
            self.candidates.remember(cam, scale, samples)
        if self.contours is not None:  # the rendered outline's samples (mrcheck.mr.edges.silhouette)
            spacing = self.options.spacing_px * depth.shape[1] / (self.camera.width * scale)
            every = silhouette.contour_samples(self.contours, view, depth, spacing, self.options.max_samples)
            if not self.judged:
                self.judge_outlines(samples, model.subset(every, self.outlined[every.group]))
            found = model.subset(every, self.outlined[every.group])
            samples = silhouette.joined(samples, found)
            if len(found):
                self.update_posterior(depth, scale, view, found)
        # the left-out parts' samples are counted (the share they hold is a test of the fit, see
        # mrcheck.mr.edges.verdict)
        self.visible_groups = samples.group
        self.all_visible = samples
        samples = model.subset(samples, ~self.dropped[samples.group])
        self.clock.add("edges", start)
        return thinned(samples, self.options.max_samples)

    def judge_outlines(self, edges: model.Samples, outline: model.Samples) -> None:
        """Automatic outlines (``EdgeOptions.silhouette`` None), judged once, in the first view:
        when the curved parts' outline samples ``outline`` outnumber the samples on crease edges
        in ``edges`` (every part's visible mesh-edge samples; a curved mesh's own facet contours
        do not count), the view rests on outlines and every part's outline is used; else none for
        the whole fit. Why the view as a whole, measured at the level searched: the generated
        cell (rollers, pipes, bollards among racks and fences; ``mrcheck bench --edges``, seeds
        0-9) has 542-652 such outline samples against 1752-2063 crease ones, and its curved
        parts' outlines turned 2 of 10 good fits into refusals; LM-O's scanned objects have
        337-453 against 0-1, M3T's bottle 47-63 against the prism's and the bottle's 17-41
        crease samples, and the fit rests on them. Why every part's then: M3T frame 200 from 20
        px off (seeds 0-3) ended 1.3-7.0 px from the published pose with the bottle's outline
        alone, 1.5-2.9 px with the 3D-printed prism's outline as well (its low-contrast creases
        find few photo edges)."""
        self.judged = True
        creases = int(np.count_nonzero(self.edges.crease[edges.edge])) if len(edges) else 0
        if len(outline) > creases:
            self.outlined[:] = True
            return
        self.outlined[:] = False
        self.contours = None

    def match(
        self, level: photo.Level, pose: solver.PoseState, samples: model.Samples, radius: int, polarity
    ) -> tuple[np.ndarray, np.ndarray, solver.Projection, photo.Matches]:
        """Residuals (level px; nan without a match), rows and the projection of the samples at
        ``pose``, and their matches."""
        start = time.perf_counter()
        proj = solver.project(pose, self.camera, samples.points, samples.tangents)
        uv = photo.to_level(proj.uv, level.scale)
        found = photo.search(level, uv, proj.normal, radius, polarity, outside=samples.outside)
        if samples.contour is not None and level.scale in self.posteriors:
            self.region_match(level, uv, proj.normal, radius, samples, found)
        self.clock.add("match", start)
        return -found.offset, solver.normal_rows(proj, level.scale), proj, found

    def update_posterior(self, depth: np.ndarray, scale: float, cam: Camera, contour: model.Samples) -> None:
        """The per-instance foreground posteriors of the level at ``scale`` from the rendered mask
        ``depth > 0`` around the ``contour`` samples at ``cam`` (:func:`region.posteriors`)."""
        scales = [level.scale for level in self.pyramid]
        index = scales.index(scale) if scale in scales else -1
        if index < 0 or index >= len(self.bins):
            return
        bins = self.bins[index]
        mask = cv2.resize((depth > 0).astype(np.uint8), bins.shape[::-1], interpolation=cv2.INTER_NEAREST) > 0
        seeds = photo.to_level(model.project_pinhole(cam, contour.points), scale)
        groups = len(self.edges.group_names)
        self.posteriors[scale] = region.posteriors(bins, mask, seeds, contour.group, groups)

    def region_match(
        self, level: photo.Level, uv: np.ndarray, normal: np.ndarray, radius: int, samples: model.Samples, found
    ) -> None:
        """Replace the matches of the ``contour`` samples in ``found`` by the region criterion's
        split (:func:`region.step_search`) refined to the gradient peak within
        :data:`_REGION_SNAP_PX` of it (the region says which edge is the outline, the gradient
        where it is); no split, no match."""
        if samples.contour is None or not np.any(samples.contour):
            return
        c = np.flatnonzero(samples.contour)
        bins = self.bins[[p.scale for p in self.pyramid].index(level.scale)]
        off = region.step_search(bins, self.posteriors[level.scale], uv[c], normal[c], samples.group[c], radius)
        ok = np.isfinite(off)
        at = uv[c] + np.where(ok, off, 0.0)[:, None] * normal[c]
        near = photo.search(level, at, normal[c], 2)
        snap = ok & np.isfinite(near.offset) & (np.abs(near.offset) <= _REGION_SNAP_PX)
        found.offset[c] = np.where(snap, off + np.nan_to_num(near.offset), off)
        found.strength[c] = np.where(snap, near.strength, np.where(ok, level.threshold, 0.0))
        found.polarity[c] = 0.0

    def evaluate(
        self, level: photo.Level, pose: solver.PoseState, samples: model.Samples, radius: int, polarity, sigma: float
    ) -> _Evaluation:
        """Match the samples at ``pose``; Tukey weights and cost at the scale ``sigma``."""
        r, rows, proj, found = self.match(level, pose, samples, radius, polarity)
        start = time.perf_counter()
        ok = np.isfinite(r)
        weights = np.zeros(len(r))
        weights[ok] = solver.tukey_weights(r[ok], sigma, sigma)[0]
        cost = solver.tukey_cost(np.where(ok, r, np.inf), sigma)
        self.clock.add("solve", start)
        return _Evaluation(r, rows, proj, found, weights, sigma, cost)

    def render_for(self, cam: Camera, scale: float) -> tuple[Camera, np.ndarray, np.ndarray]:
        """``(camera, depth, normals)`` that find the visible edges at ``cam``'s pose and level
        ``scale``: the :class:`VisibilityRender` given to the fit (once, on the full-resolution
        level), else a render at ``cam`` of the level's render size."""
        seed, self.seed = self.seed, None
        if seed is not None and scale == 1.0:
            return seed.camera, seed.depth, seed.normals
        level_camera = cam.resized(*_render_size(cam, scale))
        try:
            return (cam, *render_depth(self.renderer, level_camera, with_normals=True))
        except MrcheckError as exc:  # the pose moved into a part (measured on the generated cell)
            raise EdgeFitError(f"the edge fit diverged: {exc}") from None

    def render_ratio(self, scale: float) -> float:
        """Render pixels per level pixel of the renders for the visible edges at ``scale``."""
        return _render_size(self.camera, scale)[0] / (self.camera.width * scale)

    def samples_for(self, pose: solver.PoseState, scale: float) -> model.Samples:
        """:meth:`visible_samples`, or :class:`EdgeFitError` when too few are in view."""
        samples = self.visible_samples(pose, scale)
        if len(samples) < MIN_SAMPLES:
            raise EdgeFitError(
                f"only {len(samples)} visible CAD edge samples in view (at least {MIN_SAMPLES} "
                "needed): is the rough pose looking at the scene?"
            )
        return samples

    def run_level(
        self, level: photo.Level, pose: solver.PoseState, sigma: float, judge_parts: bool
    ) -> tuple[solver.PoseState, LevelReport]:
        """Levenberg-Marquardt on the robust cost from ``pose`` (a step is kept only when it
        lowers the cost of the re-matched samples; without ``descent_only`` every step is kept),
        re-finding the visible edges when the pose moved; returns the pose reached and the report.

        Graduated: the robust scale ``sigma`` (level px) starts wide -- on the coarsest level
        the rough pose's error, where most matches within the search radius are another edge's
        and a scale measured from the residuals (MAD) would take them all in -- and shrinks by
        :data:`_ANNEAL` after every step kept, to the level's floor; the search radius follows
        (the Tukey support, ``4.685 sigma``)."""
        floor = _SIGMA_FLOOR_PX if level.scale == 1.0 else 2 * _SIGMA_FLOOR_PX
        radius = _radius(sigma)
        samples = self.samples_for(pose, level.scale)
        now = self.evaluate(level, pose, samples, radius, None, sigma)
        polarity, moved, damping, iterations, steps = now.found.polarity, 0.0, 1e-3, 0, 0
        while iterations < self.options.iterations and damping < 1e4:
            iterations += 1
            ok = np.isfinite(now.r)
            if np.count_nonzero(now.weights) < 6:
                raise EdgeFitError(
                    f"the CAD's edges found no photo edges near them ({np.count_nonzero(ok)} of "
                    f"{len(now.r)} samples): the rough pose is too far off or the photo shows another view"
                )
            step = solver.gauss_newton_step(now.rows[ok], now.r[ok], now.weights[ok], damping)
            if step is None:
                raise EdgeFitError("the edges found do not determine the pose (singular normal equations)")
            shift = float(np.max(np.abs(now.rows @ step)))
            limit = max(radius / 2.0, 1.0)  # a trust region: no sample moves more than half the search
            if shift > limit:
                step, shift = step * (limit / shift), limit
            moved_pose = pose.moved(step)
            trial = self.evaluate(level, moved_pose, samples, radius, polarity, sigma)
            if trial.cost >= now.cost and self.options.descent_only:
                damping = damping * 10.0
                continue
            pose = moved_pose
            damping, moved, steps = max(damping / 10.0, 1e-6), moved + shift, steps + 1
            polarity = np.where(polarity == 0, trial.found.polarity, polarity)
            if shift < _CONVERGED_PX and sigma <= floor:
                now = trial
                break
            sigma = max(floor, sigma * _ANNEAL)
            radius = _radius(sigma)
            # re-render after rerender_px of the render's pixels (a level wider than the render's);
            # the new samples' polarity is matched anew
            if moved * self.render_ratio(level.scale) > self.options.rerender_px:
                samples, moved = self.samples_for(pose, level.scale), 0.0
                now = self.evaluate(level, pose, samples, radius, None, sigma)
                polarity = now.found.polarity
            else:
                now = self.evaluate(level, pose, samples, radius, polarity, sigma)
        if judge_parts:  # not on the coarsest level: a part may still be off by the search radius there
            self.drop_unsupported(samples, now.weights)
        if level.scale == 1.0:
            self.last_full = model.subset(samples, ~self.dropped[samples.group])
        ok = np.isfinite(now.r) & (now.weights > 0)
        rms = float(np.sqrt(np.average(now.r[ok] ** 2, weights=now.weights[ok]))) if np.any(ok) else math.inf
        return pose, LevelReport(level.scale, iterations, len(samples), float(np.mean(now.weights > 0)), rms, steps)

    def drop_unsupported(self, samples: model.Samples, weights: np.ndarray) -> None:
        """Leave out the instances whose edges (enough of them) found support too rarely."""
        count = np.bincount(samples.group, minlength=len(self.dropped))
        supported = np.bincount(samples.group, weights=(weights > 0).astype(float), minlength=len(self.dropped))
        judged = count >= _PART_MIN_SAMPLES
        self.dropped |= judged & (supported < _PART_MIN_SUPPORT * np.maximum(count, 1))


__all__ = ["Fitter", "Clock", "STAGES", "NEXT_LEVEL_SIGMA", "render_depth", "thinned"]
