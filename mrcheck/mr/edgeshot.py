"""``mrcheck register --initial ROUGH.json`` (and ``--markers/--points ... --refine``): a shot
registered by snapping the CAD onto the photo's edges (:func:`mrcheck.mr.edges.refine_pose`).

SHOT.json of an edge registration: the camera JSON (so ``render --camera`` and ``overlay`` take it
as is) plus::

    "photo": the photo, relative to the SHOT.json's folder,
    "method": "edges",  "start": "initial" | "markers" | "points" (where the rough pose came from),
    "rms": edge RMS (px): distance of the supported edge samples to the photo's edges,
    "support": share of the visible CAD edge samples that found a photo edge,
    "above_chance": that support beyond what a pose a few px off gets by chance (0 .. 1; a fit
        below 0.08 fails; the crates' good fits 0.56-0.83, the dense generated cell's 0.12-0.28),
    "samples": visible CAD edge samples at full resolution,
    "uncertainty": {"corner_px": {top_left, top_right, bottom_right, bottom_left} (1 sigma),
                    "depth_m", "position_mm" [x, y, z world], "position_camera_mm" [right, down,
                    forward], "angle_deg" [tilt, pan, roll], "weak_direction": str | null},
    "expected_overlay_error_px": RMS of the four corners' 1 sigma (the markers' field, same meaning),
    "camera_position": world [x, y, z], "moved_px": how far the snap moved the view from the start
        (median over the edge samples), "left_out": instance ids whose edges found no support,
    "times_s": seconds per stage, "warnings": [str, ...]

A failed fit (diverged, too little support) is an error: nothing is written, exit status 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera, read_camera, read_photo, write_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input
from mrcheck.core.output import check_not_inputs, check_output_path
from mrcheck.mr.edges import EdgeFit, EdgeFitError, EdgeOptions, refine_pose
from mrcheck.mr.markers import load_marker_map
from mrcheck.mr.registration import fit_camera, load_points, photo_reference, register_photo
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene


def edge_shot(fit: EdgeFit, photo, start: str, rough: Camera) -> dict:
    """The SHOT.json dict of an edge fit (absolute ``photo`` path; see the module docstring)."""
    u = fit.uncertainty
    camera = fit.camera
    corners = np.array(u.corner_px)
    return {
        **camera.to_dict(),
        "photo": str(Path(photo).resolve()),
        "method": "edges",
        "start": start,
        "rms": round(fit.rms_px, 4),
        "support": round(fit.support, 4),
        "above_chance": None if np.isnan(fit.above_chance) else round(fit.above_chance, 4),
        "samples": fit.samples,
        "uncertainty": u.to_dict(),
        "expected_overlay_error_px": round(float(np.sqrt(np.mean(corners**2))), 4),
        "camera_position": camera.center.tolist(),
        "moved_px": round(_moved(rough, camera), 3),
        "left_out": list(fit.dropped),
        "times_s": {k: round(v, 3) for k, v in fit.times_s.items()},
        "warnings": list(fit.warnings),
    }


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
) -> dict:
    """The SHOT dict of ``photo`` (a path) registered by snapping ``scene`` onto its edges from
    the pose of ``rough``; ``camera``: the photo's intrinsics (rescaled to the photo when it was
    resized). Raises :class:`~mrcheck.mr.edges.EdgeFitError` (naming the photo) on failure."""
    grey = read_photo(photo, grey=True)
    camera, warnings = fit_camera(camera, grey.shape[1], grey.shape[0], photo)
    rough = camera.with_pose(rough.R, rough.t)
    try:
        fit = refine_pose(scene, camera, grey, initial=rough, options=options)
    except EdgeFitError as exc:
        raise EdgeFitError(f"edge registration failed: {exc}", photo) from None
    shot = edge_shot(fit, photo, start, rough)
    shot["warnings"] = warnings + shot["warnings"]
    return shot


@dataclass
class EdgeRegistered:
    """What ``mrcheck register`` with edges did: the shot dict written (``"photo"`` absolute) and where."""

    shot: dict
    output: Path

    def summary(self) -> list[str]:
        """The lines ``mrcheck register`` prints (:func:`summary_lines`)."""
        return summary_lines(self.shot, self.output)


def register_edges_command(
    scene, photo, intrinsics, initial=None, markers=None, points=None, refine=True, max_error=None, output="SHOT.json"
) -> EdgeRegistered:
    """``mrcheck register`` with edges: the start from ``initial`` (a camera JSON with R and t),
    or from ``markers`` / ``points`` (refined by the edges unless ``refine`` is False, which is
    the plain marker registration); writes SHOT.json atomically (``photo`` relative to it) and
    returns what it did (the shot's ``photo`` absolute); the CLI prints its ``summary()``."""
    output = check_output_path(output, (".json",), "shot")
    starts = [
        name
        for name, value in (("--initial", initial), ("--markers", markers), ("--points", points))
        if value is not None
    ]
    if len(starts) != 1:
        raise MrcheckError("give exactly one start: --initial ROUGH.json, --markers MAP.json or --points CORR.json")
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
    camera = read_camera(intrinsics)
    model = load_scene(scene, progress=True)
    if initial is not None:
        rough, start = load_camera(initial), "initial"
        if refine is False:
            raise MrcheckError("--no-refine needs --markers or --points (--initial is only a start for the edges)")
    else:
        start = "markers" if markers is not None else "points"
        first = register_photo(
            photo,
            camera,
            marker_map=load_marker_map(markers) if markers else None,
            points=load_points(points) if points else None,
            max_error=max_error,
            scene_bounds=model.bounds(),
            points_file=points,
        )
        rough = Camera.from_dict(first)
    shot = snap_photo(photo, camera, model, rough, start)
    extra = {k: v for k, v in shot.items() if k not in ("width", "height", "K", "dist", "R", "t")}
    write_camera(output, Camera.from_dict(shot), {**extra, "photo": photo_reference(shot["photo"], output)})
    return EdgeRegistered(shot, output)


def _beyond(shot: dict) -> str:
    value = shot.get("above_chance")
    return "" if value is None else f" ({value:.2f} beyond chance)"


def summary_lines(shot: dict, output) -> list[str]:
    """The console report of an edge registration (what ``mrcheck register`` prints)."""
    u = shot["uncertainty"]
    x, y, z = shot["camera_position"]
    corners = u["corner_px"]
    px, py, pz = u["position_mm"]
    tilt, pan, roll = u["angle_deg"]
    times = shot["times_s"]
    stages = ", ".join(f"{k} {v:.2f}" for k, v in times.items() if k != "total")
    lines = [
        f"registered {shot['photo']} from edges (start: {shot['start']}): edge rms {shot['rms']:.3f} px, "
        f"support {shot['support']:.0%} of {shot['samples']} samples{_beyond(shot)}, "
        f"moved {shot['moved_px']:.1f} px",
        f"  camera at ({x:.3f}, {y:.3f}, {z:.3f}) m; 1-sigma: {px:.1f} / {py:.1f} / {pz:.1f} mm (x/y/z), "
        f"tilt {tilt:.3f}, pan {pan:.3f}, roll {roll:.3f} deg",
        "  overlay 1-sigma at the corners: "
        + ", ".join(f"{k.replace('_', ' ')} {v:.2f} px" for k, v in corners.items())
        + f" (at {u['depth_m']:.1f} m)",
    ]
    if shot["left_out"]:
        lines.append(
            f"  left out (no support in the photo): {', '.join(shot['left_out'][:12])}"
            + (f" and {len(shot['left_out']) - 12} more" if len(shot["left_out"]) > 12 else "")
        )
    lines.append(f"  time {times['total']:.2f} s ({stages})")
    lines += [f"  warning: {w}" for w in shot["warnings"]]
    lines.append(f"wrote {output}")
    return lines


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


__all__ = [
    "EdgeRegistered",
    "edge_shot",
    "snap_photo",
    "register_edges_command",
    "summary_lines",
    "view_camera",
    "scene_camera_command",
]
