"""The records of the edge registration (:func:`mrcheck.mr.edges.refine_pose`): its settings
(:class:`EdgeOptions`), its pyramid's schedule (:func:`level_count`), what it returns
(:class:`EdgeFit`, :class:`LevelReport`), what it may be given (:class:`VisibilityRender`) and
how it fails (:class:`EdgeFitError`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.mr.edges.uncertainty import PoseUncertainty

MIN_SAMPLES = 30  # a fit needs at least this many visible edge samples (and max_samples this many)
_COARSEST_WIDTH = 160  # the pyramid's coarsest level is about this wide (see level_count)


class EdgeFitError(MrcheckError):
    """The edge fit failed: it diverged, or ended with too little support (the message says which)."""


@dataclass
class EdgeOptions:
    """Settings of :func:`~mrcheck.mr.edges.refine_pose`; the defaults suit photos of 640 to 4000 px.

    ``search_px``: how far (full-resolution px) the rough pose may put an edge from the photo's;
    ``spacing_px``: sample spacing along the edges in level pixels; ``max_samples``: per level
    (evenly thinned beyond); ``iterations``: at most per level (20: with 10 the fine levels of
    a crate photo stopped at 0.5 px, still moving, where 14 reach 0.04 px); ``min_support``:
    the share of samples (of the parts kept) that must find a photo edge at the end (0.3: the
    generated cell's good fits reach 0.35-0.59, many of its CAD edges show no contrast in a
    photo, and its wrong ones as much: the support beyond chance is the test); ``levels``:
    pyramid levels (None: the coarsest about 160 px wide); ``rerender_px``: re-find the visible
    edges after the pose moved by this many level pixels; ``coarse``: the coarse stage,
    ``"chamfer"`` (:mod:`mrcheck.mr.edges.coarse`) or ``"normal"`` (the search along the normal
    on every level); ``max_left_out``: the share of the visible edge samples that the parts left
    out (no support) may hold at the end (see :func:`~mrcheck.mr.edges.refine_pose`);
    ``descent_only``: keep a step only when it lowers the robust cost of the re-matched samples
    (Levenberg-Marquardt, the default: from a rough pose many px off a step may jump to other
    edges); off, every step is kept (iteratively reweighted least squares within the trust
    region: a video frame, a few px from its prediction, where the cost test can keep the pose
    where it began, see :data:`mrcheck.apps.track.TRACK_OPTIONS`); ``silhouette``: also sample
    the outline of the rendered parts (:mod:`mrcheck.mr.edges.silhouette`: depth discontinuities
    against the background or a farther part), for scanned and smooth meshes with few creases:
    ``None`` (automatic, the default) for the curved parts
    (:func:`~mrcheck.mr.edges.silhouette.curved_parts`) when their outline samples outnumber the
    crease samples in the first view (:meth:`~mrcheck.mr.edges.fitter.Fitter.judge_outlines`),
    ``True`` for every part, ``False`` for none; ``region``: match those outline samples by the
    colour region criterion
    (:mod:`mrcheck.mr.edges.region`) instead of the nearest gradient peak (needs the photo);
    ``restarts``: make an accepted fit again from poses along its weakest directions when one
    part fits far worse than the others (:mod:`mrcheck.mr.edges.restarts`; off for video frames,
    a few px from their prediction, where a dozen more fits per frame would not keep up).
    """

    search_px: float = 48.0
    spacing_px: float = 3.0
    max_samples: int = 3000
    iterations: int = 20
    min_support: float = 0.3
    levels: int | None = None
    rerender_px: float = 1.5
    coarse: str = "chamfer"
    max_left_out: float = 0.7
    descent_only: bool = True
    silhouette: bool | None = None
    region: bool = True
    restarts: bool = True

    @property
    def reads_colour(self) -> bool:
        """Whether the fit reads the photo in colour: outlines may be sampled and matched by the
        region criterion, which compares colours (else the photo is read grey)."""
        return self.silhouette is not False and self.region

    def validated(self) -> EdgeOptions:
        checks = [
            (0 < self.search_px < math.inf, f"search radius must be positive, got {self.search_px}"),
            (0.5 <= self.spacing_px < math.inf, f"sample spacing must be >= 0.5 px, got {self.spacing_px}"),
            (self.max_samples >= MIN_SAMPLES, f"max samples must be >= {MIN_SAMPLES}, got {self.max_samples}"),
            (self.iterations >= 1, f"iterations must be >= 1, got {self.iterations}"),
            (0 <= self.min_support <= 1, f"min support must be in [0, 1], got {self.min_support}"),
            (0 <= self.max_left_out <= 1, f"max left-out share must be in [0, 1], got {self.max_left_out}"),
            (self.levels is None or 1 <= self.levels <= 8, f"levels must be 1..8, got {self.levels}"),
            (self.coarse in ("chamfer", "normal"), f"coarse must be chamfer or normal, got {self.coarse!r}"),
        ]
        for ok, message in checks:
            if not ok:
                raise MrcheckError(message)
        return self


def level_count(width: int, options: EdgeOptions) -> int:
    """The pyramid levels of a photo ``width`` px wide: ``options.levels``, else as many as
    halve it to about :data:`_COARSEST_WIDTH` px."""
    if options.levels is not None:
        return options.levels
    return max(1, 1 + int(math.floor(math.log2(max(width, 1) / _COARSEST_WIDTH))))


@dataclass
class LevelReport:
    """What one pyramid level did: its scale, iterations, samples, support share and RMS (level
    px), and ``steps``: the iterations whose step was kept (0: no step lowered the cost, the
    pose stayed where the level began)."""

    scale: float
    iterations: int
    samples: int
    support: float
    rms_px: float
    steps: int = 0


@dataclass
class EdgeFit:
    """The result of :func:`~mrcheck.mr.edges.refine_pose`.

    ``camera``: the photo's camera at the refined pose; ``rms_px``: RMS distance of the supported
    samples to their photo edges (full-resolution px); ``support``: share of the visible edge
    samples that found a photo edge with a non-zero robust weight; ``samples``: visible samples
    at full resolution; ``uncertainty``: :class:`~mrcheck.mr.edges.uncertainty.PoseUncertainty`;
    ``warnings``: sentences; ``times_s``: seconds per stage (``render``, ``edges``, ``photo``,
    ``coarse``, ``match``, ``solve``, ``uncertainty``, ``total``); ``dropped``: instance ids whose
    edges found no support (left out); ``levels``: one :class:`LevelReport` per level, coarse to
    fine; ``above_chance``: the support of all visible samples (the left-out parts' too) beyond
    what a pose a few px off gets by chance (:func:`~mrcheck.mr.edges.photo.support_above_chance`);
    ``start_support``: the support of the same samples at the start's pose, at the same scale;
    ``gained``: (samples supported at the fit's pose but not at the start's, the reverse);
    ``outlined``: the instances whose outlines were sampled (:attr:`EdgeOptions.silhouette`);
    ``part_above``: instance id -> the same figure as ``above_chance`` on that part's samples
    alone (the parts with at least 20 of them); ``restart``: when one part fitted far worse than
    the others and the fit was made again (:mod:`~mrcheck.mr.edges.restarts`), what was done.
    """

    camera: Camera
    rms_px: float
    support: float
    samples: int
    uncertainty: PoseUncertainty
    warnings: list[str] = field(default_factory=list)
    times_s: dict[str, float] = field(default_factory=dict)
    dropped: list[str] = field(default_factory=list)
    levels: list[LevelReport] = field(default_factory=list)
    above_chance: float = math.nan
    start_support: float = math.nan
    gained: tuple[int, int] = (0, 0)
    outlined: list[str] = field(default_factory=list)
    part_above: dict[str, float] = field(default_factory=dict)
    restart: str = ""


@dataclass
class VisibilityRender:
    """A render of the scene from a pose near the fit's start, given to
    :func:`~mrcheck.mr.edges.refine_pose` to find the visible edges without a render of its own
    (a video's overlay of the frame before).

    ``camera``: the pinhole camera it was rendered with (pose and intrinsics; the same view as
    the photo's, a padded frame allowed); ``depth``: (H, W) linear depth (0 = background) and
    ``normals``: (H, W, 3) camera-space normals, at ``camera``'s size, at full detail (a
    simplified mesh moves surfaces off the exact edges' planes, see
    :func:`~mrcheck.mr.edges.model.salient`)."""

    camera: Camera
    depth: np.ndarray
    normals: np.ndarray


__all__ = [
    "EdgeFitError",
    "EdgeOptions",
    "EdgeFit",
    "LevelReport",
    "VisibilityRender",
    "level_count",
    "MIN_SAMPLES",
]
