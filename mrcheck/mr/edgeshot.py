"""A shot registered by snapping the CAD onto the photo's edges (:func:`mrcheck.mr.edges.refine_pose`):
the edge stage of ``mrcheck register --initial ROUGH.json`` (and ``--markers/--points ... --refine``,
:mod:`mrcheck.mr.register`), and ``mrcheck scene camera``'s rough start.

SHOT.json of an edge registration: the camera JSON (so ``render --camera`` and ``overlay`` take it
as is) plus::

    "photo": the photo, relative to the SHOT.json's folder,
    "method": "edges",  "start": "initial" | "markers" | "points" (where the rough pose came from),
    "rms": edge RMS (px): distance of the supported edge samples to the photo's edges,
    "support": share of the visible CAD edge samples that found a photo edge,
    "start_support": the same samples' support at the start's pose (null when unknown),
    "support_change": {"gained", "lost"}: samples supported at the fit's pose and not at the
        start's, and the reverse, "outlined": instance ids whose outlines were fitted,
    "above_chance": that support beyond what a pose a few px off gets by chance (0 .. 1; a fit
        below 0.08 fails; the crates' good fits 0.56-0.83, the dense generated cell's 0.12-0.28),
    "samples": visible CAD edge samples at full resolution,
    "uncertainty": {"corner_px": {top_left, top_right, bottom_right, bottom_left} (1 sigma),
                    "depth_m", "position_mm" [x, y, z world], "position_camera_mm" [right, down,
                    forward], "angle_deg" [tilt, pan, roll], "weak_direction": str | null},
    "expected_overlay_error_px": RMS of the four corners' 1 sigma (the markers' field, same meaning),
    "camera_position": world [x, y, z], "moved_px": how far the snap moved the view from the start
        (median over the edge samples), "left_out": instance ids whose edges found no support,
    "part_above": {instance id: its own support beyond chance} (the parts with >= 20 samples),
    "restart": what was done when one part fitted far worse than the others (made again from
        poses along the weakest directions, :mod:`mrcheck.mr.edges.restarts`), or null,
    "times_s": seconds per stage, "warnings": [str, ...]

These keys after ``photo`` are the :class:`mrcheck.core.shot.Shot`'s ``report``. A failed fit
(diverged, too little support) is an error: nothing is written, exit status 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_camera, read_photo, write_camera
from mrcheck.core.inputs import check_input
from mrcheck.core.output import check_not_inputs, check_output_path
from mrcheck.core.shot import Shot
from mrcheck.mr.edges import EdgeFit, EdgeFitError, EdgeOptions, refine_pose
from mrcheck.mr.registration import fit_camera
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene


def edge_shot(fit: EdgeFit, photo, start: str, rough: Camera) -> Shot:
    """The shot of an edge fit of the photo file ``photo`` (see the module docstring)."""
    u = fit.uncertainty
    camera = fit.camera
    corners = np.array(u.corner_px)
    report = {
        "method": "edges",
        "start": start,
        "rms": round(fit.rms_px, 4),
        "support": round(fit.support, 4),
        "start_support": None if np.isnan(fit.start_support) else round(fit.start_support, 4),
        "support_change": {"gained": fit.gained[0], "lost": fit.gained[1]},
        "above_chance": None if np.isnan(fit.above_chance) else round(fit.above_chance, 4),
        "samples": fit.samples,
        "uncertainty": u.to_dict(),
        "expected_overlay_error_px": round(float(np.sqrt(np.mean(corners**2))), 4),
        "camera_position": camera.center.tolist(),
        "moved_px": round(_moved(rough, camera), 3),
        "left_out": list(fit.dropped),
        "outlined": list(fit.outlined),
        "part_above": dict(fit.part_above),
        "restart": fit.restart or None,
        "times_s": {k: round(v, 3) for k, v in fit.times_s.items()},
        "warnings": list(fit.warnings),
    }
    return Shot(camera, Path(photo).resolve(), report)


def _moved(rough: Camera, camera: Camera) -> float:
    """Median image displacement between two poses of the same camera at points 1 .. 20 m ahead."""
    u, v = np.meshgrid(np.linspace(0, camera.width - 1, 5), np.linspace(0, camera.height - 1, 5))
    rays = np.linalg.solve(camera.K, np.stack([u.ravel(), v.ravel(), np.ones(u.size)]))
    moved = []
    for depth in (1.0, 5.0, 20.0):
        world = (depth * rays - camera.t[:, None]).T @ camera.R
        moved.append(np.linalg.norm(rough.project(world) - camera.project(world), axis=1))
    return float(np.median(np.concatenate(moved)))


def snap_photo(
    photo, camera: Camera, scene, rough: Camera, start: str = "initial", options: EdgeOptions | None = None
) -> Shot:
    """The shot of ``photo`` (a path) registered by snapping ``scene`` onto its edges from
    the pose of ``rough``; ``camera``: the photo's intrinsics (rescaled to the photo when it was
    resized). Raises :class:`~mrcheck.mr.edges.EdgeFitError` (naming the photo) on failure."""
    # the region criterion of the silhouette samples compares colours: the photo as it is then
    grey = read_photo(photo, grey=not (options or EdgeOptions()).reads_colour)
    camera, warnings = fit_camera(camera, grey.shape[1], grey.shape[0], photo)
    rough = camera.with_pose(rough.R, rough.t)
    try:
        fit = refine_pose(scene, camera, grey, initial=rough, options=options)
    except EdgeFitError as exc:
        raise EdgeFitError(f"edge registration failed: {exc}", photo) from None
    shot = edge_shot(fit, photo, start, rough)
    return shot.with_report(warnings=warnings + shot.warnings)


def view_camera(scene_path, view: str, intrinsics=None) -> Camera:
    """The camera of the scene's named viewpoint ``view``: its pose with the intrinsics of the
    camera file ``intrinsics`` (a photo's calibration: size, K, distortion), or the viewpoint's
    own camera without one. A rough start for ``register --initial``."""
    check_input(scene_path, "scene", folder_ok=True)
    scene = load_scene(scene_path)
    own = scene.camera(view)
    if intrinsics is None:
        return own
    return read_camera(intrinsics).with_pose(own.R, own.t)


def scene_camera_command(scene, view, intrinsics=None, output="ROUGH.json") -> Path:
    """``mrcheck scene camera``: write the viewpoint's camera JSON atomically; returns its path."""
    output = check_output_path(output, (".json", ".yml", ".yaml"), "camera")
    check_not_inputs([output], [("--intrinsics", intrinsics), ("the scene", scene_files(scene))])
    camera = view_camera(scene, view, intrinsics)
    return write_camera(output, camera, {"view": view})


__all__ = ["edge_shot", "snap_photo", "view_camera", "scene_camera_command"]
