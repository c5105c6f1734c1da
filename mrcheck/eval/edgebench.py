"""The edge registration against OpenCV's RAPID tracker (``cv2.rapid``), on the same cases.

Cases: photos ray cast by Open3D (:mod:`mrcheck.eval.edgephotos`: sun and sky, shadows, albedo
noise, lens distortion, blur, sensor noise, clutter boxes the CAD lacks, one CAD part left out)
of a scene from a viewpoint, each with a rough pose 15-40 px off. Both methods start from the
same rough pose; the figure is the median reprojection error on CAD surface points in view
against the true pose (px), and the wall-clock time of the refinement.

RAPID gets its best chance: the scene as one mesh (float32 about the scene's centre; only the
part instances wholly inside the rough view, as its contour sampler fails on the others), the photo
undistorted first (``cv2.rapid`` knows no lens distortion; the undistortion is not timed), and
:data:`RAPID_ITERATIONS` iterations of ``cv2.rapid.rapid`` with a search radius that shrinks from
the rough pose's error to a few pixels. mrcheck's snap runs with its defaults.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.eval.edgephotos import make_case, reprojection_error
from mrcheck.mr.edges import EdgeFitError, refine_pose, scene_edges
from mrcheck.scene.model import Scene

RAPID_ITERATIONS = 10
RAPID_LINES = 2000
SUCCESS_PX = 1.0


@dataclass
class EdgeBenchRow:
    """One method on one case: ``error_px`` median reprojection error on the scene points (None
    when the method gave up), ``seconds`` its time, ``note`` why it gave up."""

    case: str
    method: str
    offset_px: float
    error_px: float | None
    seconds: float
    note: str = ""


def _soup(scene: Scene, centre: np.ndarray, camera: Camera):
    """One mesh of the instances wholly inside the view of ``camera`` (``cv2.rapid``'s contour
    sampler fails on a mesh reaching out of the image or behind the camera: a floor, a wall),
    about ``centre``."""
    verts, faces, base = [], [], 0
    for part in scene.parts:
        for T in part.transforms:
            world = part.vertices.astype(np.float64) @ T[:3, :3].T + T[:3, 3]
            uv = camera.project(world) if np.min(world @ camera.R[2] + camera.t[2]) > 0.05 else None
            if uv is None or uv.min() < 0 or np.any(uv.max(axis=0) > (camera.width - 1, camera.height - 1)):
                continue
            verts.append(world - centre)
            faces.append(part.faces.astype(np.int64) + base)
            base += len(part.vertices)
    if not verts:
        raise MrcheckError("no part lies wholly in front of the camera")
    return np.concatenate(verts).astype(np.float32), np.concatenate(faces).astype(np.int32)


def rapid_refine(scene: Scene, camera: Camera, grey: np.ndarray, initial: Camera, search_px: float) -> Camera:
    """``initial`` refined by :data:`RAPID_ITERATIONS` iterations of ``cv2.rapid.rapid`` on the
    undistorted ``grey`` (``camera``: the photo's intrinsics and distortion)."""
    centre = scene.bounds().mean(axis=0)
    pts, tris = _soup(scene, centre, initial)
    image = cv2.undistort(grey, camera.K, camera.dist) if camera.dist.size else grey
    rvec = cv2.Rodrigues(initial.R)[0]
    tvec = (initial.t + initial.R @ centre).reshape(3, 1)
    for i in range(RAPID_ITERATIONS):
        radius = max(3, int(round(search_px * (1.0 - i / RAPID_ITERATIONS))))
        _, rvec, tvec, _ = cv2.rapid.rapid(image, RAPID_LINES, radius, pts, tris, camera.K, rvec, tvec)
    R = cv2.Rodrigues(rvec)[0]
    return initial.with_pose(R, tvec.ravel() - R @ centre)


def bench_cases(name: str, scene: Scene, camera: Camera, seeds, progress=None) -> list[EdgeBenchRow]:
    """Both methods on the case ``seed`` of every seed; ``progress(str)`` per case."""
    rows = []
    edges = scene_edges(scene)
    for seed in seeds:
        case = make_case(scene, camera, seed)
        label = f"{name}#{seed}"
        start = time.perf_counter()
        try:
            fit = refine_pose(scene, camera, case.photo, initial=case.rough, edges=edges)
            ours = EdgeBenchRow(
                label,
                "mrcheck edges",
                case.offset_px,
                float(np.median(reprojection_error(case.truth, fit.camera, case.points))),
                time.perf_counter() - start,
            )
        except EdgeFitError as exc:
            ours = EdgeBenchRow(label, "mrcheck edges", case.offset_px, None, time.perf_counter() - start, str(exc))
        start = time.perf_counter()
        try:
            snapped = rapid_refine(scene, camera, case.photo, case.rough, 1.5 * case.offset_px)
            theirs = EdgeBenchRow(
                label,
                "cv2.rapid",
                case.offset_px,
                float(np.median(reprojection_error(case.truth, snapped, case.points))),
                time.perf_counter() - start,
            )
        except (cv2.error, MrcheckError) as exc:
            theirs = EdgeBenchRow(
                label, "cv2.rapid", case.offset_px, None, time.perf_counter() - start, str(exc).splitlines()[0][:120]
            )
        rows += [ours, theirs]
        if progress:
            progress(
                f"{label}: edges {_fmt(ours.error_px)}, rapid {_fmt(theirs.error_px)} (from {case.offset_px:.1f} px)"
            )
    return rows


def _fmt(value) -> str:
    return "failed" if value is None else f"{value:.2f} px"


def summary_lines(rows: list[EdgeBenchRow]) -> list[str]:
    """The table: per case both methods side by side, then per method the median error, the
    cases within :data:`SUCCESS_PX` and the median time."""
    lines = [f"{'case':<18} {'start px':>8} {'edges px':>9} {'edges s':>8} {'rapid px':>9} {'rapid s':>8}"]
    by_case = {}
    for row in rows:
        by_case.setdefault(row.case, {})[row.method] = row
    for case, pair in by_case.items():
        ours, theirs = pair["mrcheck edges"], pair["cv2.rapid"]
        err = lambda r: "failed" if r.error_px is None else f"{r.error_px:.2f}"  # noqa: E731
        lines.append(
            f"{case:<18} {ours.offset_px:8.1f} {err(ours):>9} {ours.seconds:8.2f} {err(theirs):>9} "
            f"{theirs.seconds:8.2f}"
        )
    for method in ("mrcheck edges", "cv2.rapid"):
        mine = [r for r in rows if r.method == method]
        errors = np.array([np.inf if r.error_px is None else r.error_px for r in mine])
        lines.append(
            f"{method}: median error {np.median(errors):.2f} px, within {SUCCESS_PX:g} px in "
            f"{int(np.sum(errors <= SUCCESS_PX))} of {len(mine)}, failed {int(np.sum(~np.isfinite(errors)))}, "
            f"median time {np.median([r.seconds for r in mine]):.2f} s"
        )
    return lines


def edge_bench(quick: bool = False, progress=None) -> list[str]:
    """``mrcheck bench --edges``: both methods on the crate scene
    (:mod:`mrcheck.eval.edgescenes`) and on the generated cell's ``overview``, at 640x480 with
    lens distortion, 10 seeds each (3 with ``quick``); the lines of :func:`summary_lines` per scene."""
    from mrcheck.core.resources import shipped_scene
    from mrcheck.eval.edgescenes import crate_camera, crate_scene
    from mrcheck.scene.model import load_scene

    seeds = range(3 if quick else 10)
    cell = load_scene(shipped_scene("cell"))
    crates = crate_camera(640, 480)
    lines = []
    for name, scene, camera in (
        ("crates", crate_scene(), crates),
        ("cell-overview", cell, cell.camera("overview", 640)),
    ):
        camera = Camera(camera.width, camera.height, camera.K, camera.R, camera.t, crates.dist)
        rows = bench_cases(name, scene, camera, seeds, progress)
        lines += [
            f"== edge registration: {name}, {camera.width}x{camera.height}, {len(seeds)} cases ==",
            *summary_lines(rows),
        ]
    return lines


__all__ = ["EdgeBenchRow", "rapid_refine", "bench_cases", "summary_lines", "edge_bench", "RAPID_ITERATIONS"]
