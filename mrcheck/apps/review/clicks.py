"""Register a photo by clicks (the review's "Add photo"): pairs of a photo pixel and a pixel of a
CAD render beside it. The CAD pixel becomes a 3D point by the review's ray cast
(:class:`~mrcheck.apps.review.pick.Picker`), so the planner never types a coordinate; the pose is
solved from the pairs as ``mrcheck register --points`` solves it
(:func:`mrcheck.mr.registration.register_points`), then snapped onto the photo's edges
(:func:`mrcheck.mr.edges.refine_pose`, as ``register --points --refine``).

The snap is kept only when it does not make the clicks' residual worse beyond their own noise:
the clicks' RMS under the snapped pose may exceed the click pose's by at most the threshold
within which the pose solver counts a click as agreeing with a pose (``inlier_threshold_px``:
3 px, more for big photos). An edge fit that moved the view further from the clicks than that
has locked onto other edges (or the CAD differs from what the photo shows). A
failed snap (too little support, diverged) keeps the click pose too; either way the result says
so (``snap_note``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.shot import Shot
from mrcheck.mr.edgeshot import edge_shot
from mrcheck.mr.pose import reprojection_errors
from mrcheck.mr.registration import fit_camera, register_points

MIN_PAIRS = 4


@dataclass(frozen=True)
class CadPoint:
    """What a click on the CAD render hit: the world point (m) and its part instance."""

    world: tuple
    instance: str


@dataclass
class ClickSolve:
    """The result of :func:`solve_clicks`.

    ``shot``: the shot (as ``mrcheck register`` makes it, its report with ``"clicks"`` too);
    ``camera``: the pose saved (the shot's); ``residuals_px``: per pair, under that pose;
    ``click_residuals_px``: per pair, under the pose of the clicks alone; ``snapped``: whether the
    edge snap was kept; ``snap_note``: what the snap did, in a sentence; ``warnings``: the
    shot's; ``rejected``: the pairs (0-based) the pose solver found inconsistent and left out."""

    shot: Shot
    camera: Camera
    residuals_px: list
    click_residuals_px: list
    snapped: bool
    snap_note: str
    warnings: list = field(default_factory=list)
    rejected: list = field(default_factory=list)  # 0-based pairs the pose solver left out (mis-clicks)

    @property
    def rms_px(self) -> float:
        """RMS residual of the pairs used (the rejected ones left out)."""
        used = [e for i, e in enumerate(self.residuals_px) if i not in self.rejected]
        return float(np.sqrt(np.mean(np.square(used))))


def cad_points(picker, view: Camera, pixels) -> list[CadPoint]:
    """The CAD point under each pixel of the render of ``view`` (ray cast), or a one-line error
    naming the first click that hits no CAD part (1-based, as the page numbers them)."""
    points = []
    for i, (u, v) in enumerate(pixels, start=1):
        if not (0 <= u < view.width and 0 <= v < view.height):
            raise MrcheckError(
                f"CAD click {i} at ({u:.0f}, {v:.0f}) lies outside the {view.width}x{view.height} render"
            )
        hit = picker.world_point(view, u, v)
        if hit is None:
            raise MrcheckError(f"CAD click {i} at ({u:.0f}, {v:.0f}) hits no CAD part: click on the model")
        points.append(CadPoint(tuple(float(c) for c in hit[0]), hit[1]))
    return points


def check_pairs(photo_pixels, cad_pixels, width: int, height: int) -> None:
    """At least :data:`MIN_PAIRS` complete pairs, every photo click inside the photo."""
    if len(photo_pixels) != len(cad_pixels):
        raise MrcheckError(
            f"{len(photo_pixels)} photo click(s) but {len(cad_pixels)} CAD click(s): click each point on both sides"
        )
    if len(photo_pixels) < MIN_PAIRS:
        raise MrcheckError(
            f"{len(photo_pixels)} pair(s) of clicks: at least {MIN_PAIRS} are needed "
            "(6 or more let a mis-click be found)"
        )
    for i, (u, v) in enumerate(photo_pixels, start=1):
        if not (0 <= u < width and 0 <= v < height):
            raise MrcheckError(f"photo click {i} at ({u:.0f}, {v:.0f}) lies outside the {width}x{height} photo")


def _errors(camera: Camera, pixels: np.ndarray, world: np.ndarray) -> np.ndarray:
    return reprojection_errors(camera, cv2.Rodrigues(camera.R)[0], camera.t, pixels, world)


def solve_clicks(photo, shape: tuple, intrinsics: Camera, photo_pixels, cad: list[CadPoint], snap=None) -> ClickSolve:
    """The pose of the photo file ``photo`` ((height, width) ``shape``) from the pairs (photo
    pixels, :func:`cad_points`), snapped by ``snap(rough camera) -> EdgeFit`` unless None.
    ``intrinsics``: the photo's calibration (rescaled to the photo at the same aspect ratio, with
    a warning, as ``mrcheck register`` does; another aspect ratio is an error)."""
    height, width = shape
    check_pairs(photo_pixels, cad, width, height)
    camera, warnings = fit_camera(intrinsics, width, height, photo)
    pixels = np.asarray(photo_pixels, np.float64)
    world = np.asarray([c.world for c in cad], np.float64)
    pairs = [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels, world)]
    clicked = register_points(camera, pairs)
    rough = clicked.camera
    before = _errors(rough, pixels, world)
    shot, final, note = clicked, rough, "edge snap not asked for: the pose of the clicks"
    if snap is not None:
        shot, final, note = _snapped(snap, rough, clicked, photo, pixels, world, before)
    after = _errors(final, pixels, world)
    rejected = {r["index"] for r in clicked.report["rejected"]}
    # the clicks' own warnings (a rejected mis-click, only 4 pairs) stay when the edges' are added
    own = clicked.warnings + (shot.warnings if shot is not clicked else [])
    shot = shot.with_photo(photo).with_report(
        warnings=warnings + own + ([note] if final is rough else []),
        clicks=[
            {
                "pixel": p.tolist(),
                "world": w.tolist(),
                "instance": c.instance,
                "used": i not in rejected,
                "error_px": round(float(e), 3),
                "click_pose_error_px": round(float(b), 3),
            }
            for i, (p, w, c, e, b) in enumerate(zip(pixels, world, cad, after, before))
        ],
    )
    return ClickSolve(
        shot,
        final,
        [round(float(e), 3) for e in after],
        [round(float(e), 3) for e in before],
        final is not rough,
        note,
        shot.report["warnings"],
        sorted(rejected),
    )


def _snapped(snap, rough: Camera, clicked: Shot, photo, pixels, world, before) -> tuple[Shot, Camera, str]:
    """(shot, camera, note) of the edge snap from ``rough``, or of the clicks when it fails
    or moves the view away from the clicks (see the module docstring)."""
    try:
        fit = snap(rough)
    except MrcheckError as exc:  # an EdgeFitError (too little support, diverged) or any other input problem
        return clicked, rough, f"edge snap failed ({exc.problem}): the pose of the clicks is kept"
    used = np.ones(len(pixels), bool)
    used[[r["index"] for r in clicked.report["rejected"]]] = False  # a mis-click the solver left out is no measure
    rms_before = float(np.sqrt(np.mean(before[used] ** 2)))
    after = _errors(fit.camera, pixels, world)
    rms_after = float(np.sqrt(np.mean(after[used] ** 2)))
    if rms_after > rms_before + clicked.report["inlier_threshold_px"]:
        return (
            clicked,
            rough,
            (
                f"edge snap not used: it moved the view away from the clicks (click RMS {rms_after:.1f} px "
                f"against {rms_before:.1f} px): the pose of the clicks is kept"
            ),
        )
    shot = edge_shot(fit, photo, "points", rough)
    note = (
        f"snapped onto the photo's edges: edge RMS {fit.rms_px:.2f} px, support {fit.support:.0%}; "
        f"click RMS {rms_before:.2f} -> {rms_after:.2f} px"
    )
    return shot.with_report(click_rms=round(rms_before, 4)), fit.camera, note


__all__ = ["CadPoint", "ClickSolve", "cad_points", "check_pairs", "solve_clicks", "MIN_PAIRS"]
