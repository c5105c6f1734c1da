"""``mrcheck register``: one pipeline, a start then an optional edge refinement, and its result.

The start is one of markers (:func:`mrcheck.mr.registration.register_photo` with a marker map),
clicked points (the same with correspondences) or a rough pose (``--initial``, any camera JSON
with R and t). The edge stage (:func:`mrcheck.mr.edgeshot.snap_photo`) snaps the start's pose onto
the photo's edges: always after ``--initial``, after markers or points with ``--refine``. The
shot is written once, by :func:`mrcheck.core.shot.write_shot`; what the command did is a
:class:`RegistrationResult` (the shot and where it went), whose :meth:`~RegistrationResult.summary`
the CLI prints.

The refinement after markers or points is gated (:func:`refinement_gate`): the snapped pose is
kept only if it stays within the start's uncertainty or its edge evidence is strong; otherwise
the start's pose is written, with a warning and ``"refinement": "not applied: <reason>"`` in the
shot's report. A failed edge fit after markers or points keeps the start the same way.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera, read_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input
from mrcheck.core.output import check_not_inputs, check_output_path
from mrcheck.core.shot import Shot, write_shot
from mrcheck.mr.edges import EdgeOptions
from mrcheck.mr.edgeshot import snap_photo
from mrcheck.mr.markers import load_marker_map
from mrcheck.mr.pose import CLICK_SIGMA_PX, overlay_error_at
from mrcheck.mr.registration import load_points, register_photo
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.meshes import MESH_SUFFIXES
from mrcheck.scene.model import load_scene

PathArg = str | os.PathLike[str]  # a file the command is given
_LIST_MAX = 12  # the summary line lists the markers or points used up to this many
_LEFT_OUT_MAX = 12  # ... and the instances the edges left out
# the refined pose may move the overlay this many times the start's 1-sigma overlay error ...
_GATE_SIGMAS = 3.0
_GATE_FLOOR_PX = 1.0  # ... and at least this far (a start's sigma of 0.1 px is a model, not a limit)
# ... or further with edge support this far beyond chance (the crates' good fits 0.56-0.83)
_GATE_STRONG = 0.5
_SEARCH_FLOOR_PX = 4.0  # start_options: the refinement's search radius at least (px) ...
_SEARCH_LEVEL_PX = 4.0  # ... and about this many px of its coarsest level
_ANCHOR_CHI2 = 16.81  # chi-square, 6 degrees of freedom, 99 %: refinement_gate's test 1
_GAIN_CHI2 = 6.63  # chi-square, 1 degree of freedom, 99 %: refinement_gate's test 2


@dataclass(frozen=True)
class RegistrationResult:
    """What ``mrcheck register`` did: the shot written (its ``photo`` absolute) and where."""

    shot: Shot
    output: Path

    def summary(self) -> list[str]:
        """The lines ``mrcheck register`` prints (:func:`summary_lines`)."""
        return summary_lines(self.shot, self.output)


def _start_option(initial: PathArg | None, markers: PathArg | None, points: PathArg | None, edges: bool) -> None:
    """Exactly one start; ``--no-refine`` only after markers or points."""
    given = [value for value in (initial, markers, points) if value is not None]
    if len(given) != 1:
        raise MrcheckError(
            "give exactly one start: --initial ROUGH.json, --markers MAP.json or --points CORR.json"
            if edges
            else "give either --markers MAP.json or --points CORR.json (exactly one)"
        )


def _check_inputs(
    scene: PathArg,
    photo: PathArg,
    intrinsics: PathArg,
    initial: PathArg | None,
    markers: PathArg | None,
    points: PathArg | None,
    output: Path,
) -> None:
    """Before the work: no input is the output, and the scene the overlay will need is one."""
    check_not_inputs(
        [output],
        [
            ("--photo", photo),
            ("--intrinsics", intrinsics),
            ("--initial", initial),
            ("--markers", markers),
            ("--points", points),
            ("the scene", scene_files(scene)),
        ],
    )
    check_input(scene, "scene", folder_ok=True)
    if Path(scene).is_file() and Path(scene).suffix.lower() not in (".toml", *MESH_SUFFIXES):
        raise MrcheckError(f"not a scene (a .toml manifest or a mesh: {', '.join(MESH_SUFFIXES)})", scene)


_SILHOUETTE = {"auto": None, "on": True, "off": False}  # register_command: EdgeOptions.silhouette


def register_command(
    scene: PathArg,
    photo: PathArg,
    intrinsics: PathArg,
    markers: PathArg | None = None,
    points: PathArg | None = None,
    initial: PathArg | None = None,
    refine: bool | None = None,
    max_error: float | None = None,
    output: PathArg = "SHOT.json",
    click_sigma: float = CLICK_SIGMA_PX,
    silhouette: str = "auto",
) -> RegistrationResult:
    """``mrcheck register``: the start (``markers`` | ``points`` | ``initial``), the edge stage
    when ``initial`` is given or ``refine`` is true, then SHOT.json written atomically (its
    ``photo`` relative to it). Every input is read before the scene is loaded. ``click_sigma``:
    the clicked points' noise (px), which their outlier threshold follows from. ``silhouette``:
    ``"auto"``, ``"on"`` or ``"off"``: which parts' outlines the edge stage also matches by their
    colour regions (``EdgeOptions.silhouette``: the curved parts, every part, none)."""
    output = check_output_path(output, (".json",), "shot")
    edges = initial is not None or bool(refine)
    _start_option(initial, markers, points, edges)
    if initial is not None and refine is False:
        raise MrcheckError("--no-refine needs --markers or --points (--initial is only a start for the edges)")
    _check_inputs(scene, photo, intrinsics, initial, markers, points, output)
    camera = read_camera(intrinsics)  # its pose, if any, is ignored: the photo's is solved
    marker_map = load_marker_map(markers) if markers is not None else None
    pairs = load_points(points) if points is not None else None
    rough: Camera | None = load_camera(initial) if initial is not None else None
    model = load_scene(scene, progress=True)
    if rough is None:
        first = register_photo(
            photo,
            camera,
            marker_map=marker_map,
            points=pairs,
            max_error=max_error,
            scene_bounds=model.bounds(),
            points_file=points,
            click_sigma=click_sigma,
        )
        shot, rough = first, first.camera
    if silhouette not in _SILHOUETTE:
        raise MrcheckError(f"silhouette must be auto, on or off, got {silhouette!r}")
    options = EdgeOptions(silhouette=_SILHOUETTE[silhouette])
    if initial is not None:
        shot = snap_photo(photo, camera, model, rough, "initial", options)
    elif edges:
        how = "markers" if markers is not None else "points"
        shot = gated_refinement(shot, photo, camera, model, how, options)
    write_shot(output, shot)
    return RegistrationResult(shot, output)


def gated_refinement(
    start: Shot, photo: PathArg, camera: Camera, model, how: str, options: EdgeOptions | None = None
) -> Shot:
    """The edge refinement of a markers or points shot, or that shot with the reason it was not applied."""
    reason: str | None
    bounds = model.bounds()
    try:
        refined = snap_photo(photo, camera, model, start.camera, how, start_options(start, bounds, options))
    except MrcheckError as exc:
        reason = f"the edge fit failed ({exc.problem.removeprefix('edge registration failed: ')})"
    else:
        reason = refinement_gate(start, refined, bounds)
        if reason is None:
            return refined
    return start.with_report(
        refinement=f"not applied: {reason}", warnings=[*start.warnings, f"refinement not applied: {reason}"]
    )


def start_options(start: Shot, bounds: np.ndarray, options: EdgeOptions | None = None) -> EdgeOptions:
    """The edge stage's settings after markers or points: it searches only as far as the start
    can be off where the scene is (:data:`_GATE_SIGMAS` times :func:`start_sigma_px`, at least
    :data:`_SEARCH_FLOOR_PX`), along the normal from the pyramid level where that radius is about
    :data:`_SEARCH_LEVEL_PX` level px, not by a whole-pose search from a 160 px wide level. Why:
    on BOP LM-O (``tests/lmo_clicks.py --refine``, photos 3 and 402) a single scanned object
    showed 0-25 outline samples on that coarsest level, fewer than a fit needs, though the
    clicks had put it within 1-2 px."""
    settings = options if options is not None else EdgeOptions()
    search = max(_GATE_SIGMAS * start_sigma_px(start, bounds), _SEARCH_FLOOR_PX)
    levels = 1 + max(0, int(math.floor(math.log2(search / _SEARCH_LEVEL_PX))))
    return replace(settings, search_px=search, levels=min(levels, 8), coarse="normal")


def start_sigma_px(start: Shot, bounds: np.ndarray) -> float:
    """How far (px, 1 sigma) the start may put the scene: its pose covariance propagated to the
    corners and centre of the box ``bounds`` in front of the camera (``expected_overlay_error_px``,
    at the image's corners, where there is nothing in front or no correspondences)."""
    whole = float(start.report.get("expected_overlay_error_px") or 0.0)
    anchors = start.anchors
    points = _box_points(bounds)
    points = points[(points @ start.camera.R.T + start.camera.t)[:, 2] > 0]
    if anchors is None or len(anchors.world) < 4 or not len(points):
        return whole
    return overlay_error_at(start.camera, anchors.world, anchors.sigma_px, points)


def _box_points(bounds: np.ndarray) -> np.ndarray:
    """The 8 corners and the centre of the box ``bounds`` (2, 3)."""
    lo, hi = np.asarray(bounds, float)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return np.vstack([corners, (lo + hi) / 2])


def refinement_gate(start: Shot, refined: Shot, bounds: np.ndarray) -> str | None:
    """Why the edge-refined pose must not replace the markers' or points' pose, or None to take it.

    1. The start's own correspondences (:attr:`Shot.anchors`) must allow the refined pose: their
       squared reprojection errors may grow by at most :data:`_ANCHOR_CHI2` times their noise
       squared (the 99 % region of a 6-parameter pose solved from them). Why: on BOP LM-O
       (``tests/lmo_clicks.py --refine``: 8 clicks of 1.5 px on one scanned object, photos 3,
       402 and 819, seeds 0-4) the outline fit made 93 of the 98 refinements that test 2 let
       through worse than the clicks alone (median reprojection; at worst 0.9 -> 7.3 px and
       3 -> 28 deg on the symmetric glue bottle), with support beyond chance up to 0.57.
    2. The start's pose is known to :func:`start_sigma_px` at ``bounds``' corners and centre (1
       sigma, from its covariance); a refinement that moves the scene's overlay there by more
       than :data:`_GATE_SIGMAS` of that contradicts the start, and the edges must then prove themselves
       with support :data:`_GATE_STRONG` beyond chance: otherwise a few clutter edges win over
       clicks or markers that were right."""
    excess = anchor_excess(start, refined.camera)
    if excess is not None and excess > _ANCHOR_CHI2:
        what = "clicked points" if start.method == "points" else "marker corners"
        assert start.anchors is not None
        return (
            f"the edges' pose contradicts the {what}: their squared errors grow by {excess:.1f} times "
            f"their noise squared ({start.anchors.sigma_px:.2f} px), more than {_ANCHOR_CHI2:g} (99 % of a pose's)"
        )
    gained = support_gain(refined)
    if gained is not None and gained <= _GAIN_CHI2:
        change = refined.report["support_change"]
        return (
            f"the edges find no more support at their pose than at the start's ({change['gained']} samples "
            f"gained, {change['lost']} lost: McNemar's chi-square {gained:.1f}, at most {_GAIN_CHI2:g})"
        )
    allowed = max(_GATE_SIGMAS * start_sigma_px(start, bounds), _GATE_FLOOR_PX)
    moved = overlay_moved(start.camera, refined.camera, bounds)
    if moved <= allowed:
        return None
    chance = refined.report.get("above_chance")
    if chance is not None and chance >= _GATE_STRONG:
        return None
    evidence = "unknown" if chance is None else f"{chance:.2f}"
    return (
        f"the edges moved the overlay {moved:.1f} px, beyond {_GATE_SIGMAS:g} sigma of the start "
        f"({allowed:.1f} px), with support {evidence} beyond chance (< {_GATE_STRONG:g})"
    )


def support_gain(refined: Shot) -> float | None:
    """McNemar's chi-square of the samples the edge fit gained against those it lost between the
    start's pose and its own (signed: negative when it lost more), None when unreported."""
    change = refined.report.get("support_change")
    if not isinstance(change, dict):
        return None
    b, c = int(change.get("gained", 0)), int(change.get("lost", 0))
    if b + c == 0:
        return 0.0
    return float(np.sign(b - c) * (b - c) ** 2 / (b + c))


def anchor_excess(start: Shot, camera: Camera) -> float | None:
    """How much the squared reprojection errors of the start's correspondences grow from its
    pose to ``camera``'s, in units of their noise squared (None without correspondences): a
    chi-square with 6 degrees of freedom when ``camera`` is the true pose (linearised)."""
    anchors = start.anchors
    if anchors is None or len(anchors.world) == 0:
        return None
    before = np.sum((start.camera.project(anchors.world) - anchors.pixels) ** 2)
    after = np.sum((camera.project(anchors.world) - anchors.pixels) ** 2)
    return float((after - before) / anchors.sigma_px**2)


def overlay_moved(a: Camera, b: Camera, bounds: np.ndarray) -> float:
    """Median image displacement (px) between two poses of a camera at the corners and the centre
    of the box ``bounds`` (2, 3), over the points in front of both; inf if none is."""
    points = _box_points(bounds)
    front = ((points @ a.R.T + a.t)[:, 2] > 0) & ((points @ b.R.T + b.t)[:, 2] > 0)
    if not front.any():
        return float("inf")
    return float(np.median(np.linalg.norm(a.project(points[front]) - b.project(points[front]), axis=1)))


def summary_lines(shot: Shot, output: PathArg) -> list[str]:
    """A registration's console report: how the pose was found and how well, the camera
    position, each warning, the file written."""
    body = _edge_lines(shot) if shot.method == "edges" else _point_lines(shot)
    return [*body, *(f"  warning: {warning}" for warning in shot.warnings), f"wrote {output}"]


def _names(entries: list[dict[str, Any]], errors: bool = False) -> str:
    """Markers, boards or points by id, index or board number; with ``errors``, each one's error."""
    out = []
    for e in entries:
        name = str(e.get("id", e.get("index", f"board {e.get('board')}")))
        out.append(f"{name} ({e['error_px']:.1f} px)" if errors and "error_px" in e else name)
    return ", ".join(out) or "none"


def _point_lines(shot: Shot) -> list[str]:
    """Markers or points: those used and rejected, rms, camera position, expected overlay error."""
    r = shot.report
    x, y, z = r["camera_position"]
    which = "points (0-based positions in the points file)" if r["method"] == "points" else "markers"
    used = r["used"]
    # 54 chessboard corners are a count, not a list (the rejected are always listed)
    total = f" of {len(used) + len(r['rejected'])}" if r["method"] == "points" else ""  # a board can be in both
    used_text = _names(used) if len(used) <= _LIST_MAX else f"{len(used)}{total}"
    return [
        f"registered {shot.photo} from {which}: used {used_text}; rejected {_names(r['rejected'], errors=True)}",
        f"  rms {r['rms']:.3f} px, camera at ({x:.3f}, {y:.3f}, {z:.3f}) m, "
        f"expected overlay error ~{r['expected_overlay_error_px']:.1f} px",
    ]


def _edge_lines(shot: Shot) -> list[str]:
    """Edges: rms, support, how far the snap moved, the pose's 1-sigma, the instances left out, the times."""
    r = shot.report
    u = r["uncertainty"]
    x, y, z = r["camera_position"]
    px, py, pz = u["position_mm"]
    tilt, pan, roll = u["angle_deg"]
    times = r["times_s"]
    stages = ", ".join(f"{k} {v:.2f}" for k, v in times.items() if k != "total")
    beyond = "" if r.get("above_chance") is None else f" ({r['above_chance']:.2f} beyond chance)"
    lines = [
        f"registered {shot.photo} from edges (start: {r['start']}): edge rms {r['rms']:.3f} px, "
        f"support {r['support']:.0%} of {r['samples']} samples{beyond}, moved {r['moved_px']:.1f} px",
        f"  camera at ({x:.3f}, {y:.3f}, {z:.3f}) m; 1-sigma: {px:.1f} / {py:.1f} / {pz:.1f} mm (x/y/z), "
        f"tilt {tilt:.3f}, pan {pan:.3f}, roll {roll:.3f} deg",
        "  overlay 1-sigma at the corners: "
        + ", ".join(f"{k.replace('_', ' ')} {v:.2f} px" for k, v in u["corner_px"].items())
        + f" (at {u['depth_m']:.1f} m)",
    ]
    left_out = r["left_out"]
    if left_out:
        more = len(left_out) - _LEFT_OUT_MAX
        lines.append(
            f"  left out (no support in the photo): {', '.join(left_out[:_LEFT_OUT_MAX])}"
            + (f" and {more} more" if more > 0 else "")
        )
    if r.get("restart"):
        lines.append(f"  {r['restart']}")
    lines.append(f"  time {times['total']:.2f} s ({stages})")
    return lines


__all__ = [
    "RegistrationResult",
    "gated_refinement",
    "overlay_moved",
    "anchor_excess",
    "support_gain",
    "refinement_gate",
    "register_command",
    "summary_lines",
]
