"""Registration: the camera pose of a photo in the factory, from markers or clicked points.

Conventions: OpenCV pinhole with distortion (see :mod:`mrcheck.core.camera`), ``X_cam = R @ X_world + t``,
world units metres, pixel centres at integer (u, v).

Inputs: a calibrated camera (intrinsics; its R, t are ignored) and either a marker map
(:mod:`mrcheck.mr.markers`) or correspondences JSON::

    {"points": [{"pixel": [u, v], "world": [x, y, z]}, ...]}     (>= 4, not collinear)

Output, SHOT.json: the camera JSON (``width``, ``height``, ``K``, ``dist``, ``R``, ``t``, so
``mrcheck render --camera SHOT.json`` takes it as is) plus::

    "photo": the photo's path relative to the SHOT.json's folder (:func:`photo_reference`),
    "method": "markers" | "points",
    "rms": reprojection RMS on the inliers (px),  "inlier_threshold_px": the RANSAC threshold,
    "used" / "rejected": [{"id": 7, "dictionary": ..., "error_px": worst corner}, {"board": 0, ...,
        "corners": n}, or for points {"index": i, "pixel": .., "world": .., "error_px": ..}],
    "unknown_ids" / "unseen_ids" (markers only), "camera_position": world [x, y, z],
    "expected_overlay_error_px": predicted overlay error at the points' depth (1 sigma, RMS
        over the image, first order, from the pose covariance), "warnings": [str, ...]

The pose itself is solved in :mod:`mrcheck.mr.pose`.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_camera, read_photo
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input
from mrcheck.core.jsonfile import read_json
from mrcheck.core.output import check_not_inputs, check_output_path, write_text
from mrcheck.mr.markers import Group, detect_markers, load_marker_map, parse_marker_map
from mrcheck.mr.pose import (
    Pose,
    expected_overlay_error,
    principal_axes,
    reprojection_errors,
    solve_pose,
)
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.meshes import MESH_SUFFIXES
from mrcheck.scene.model import load_scene

# corner noise assumed when the residuals cannot tell (exact synthetic data, a single marker):
# subpixel ArUco/ChArUco corners are good to a few tenths of a pixel
_MIN_SIGMA_PX = 0.3
_WARN_OVERLAY_PX = 3.0  # predicted overlay error worth a warning
_WARN_DISTANCE_RATIO = 15.0  # mean distance / extent of the points
_WARN_FRONTAL_DEG = 20.0  # coplanar points whose plane faces the camera within this angle
_FAR_MARGIN_M = 5.0  # a camera this far outside the scene (or one scene extent) is suspicious
_LIST_MAX = 12  # the summary line lists the markers or points used up to this many


def fit_camera(camera: Camera, width: int, height: int, source=None):
    """``camera`` at the photo's size: as is, rescaled (same aspect ratio, with a warning), or an error."""
    if (width, height) == (camera.width, camera.height):
        return camera, []
    # a resized photo keeps the aspect ratio up to rounding of one pixel
    if abs(width * camera.height - height * camera.width) <= max(camera.width, camera.height, width, height):
        warning = (
            f"photo is {width}x{height} but the intrinsics are for {camera.width}x{camera.height}: "
            "K rescaled (same aspect ratio; a crop would be wrong)"
        )
        return camera.resized(width, height), [warning]
    raise MrcheckError(
        f"photo is {width}x{height} but the intrinsics are for {camera.width}x{camera.height} "
        "(another aspect ratio: a crop or another camera mode; calibrate at this size)",
        source,
    )


def load_points(path) -> list:
    return _parse_points(read_json(path, "correspondences"), Path(path))


def _parse_points(data, source="correspondences") -> list:
    points = data.get("points") if isinstance(data, dict) else data
    if not isinstance(points, list):
        raise MrcheckError('correspondences must be {"points": [{"pixel": [u, v], "world": [x, y, z]}, ...]}', source)
    groups = []
    for i, entry in enumerate(points):
        try:
            if any(isinstance(v, bool) for v in [*entry["pixel"], *entry["world"]]):
                raise TypeError("true/false is not a coordinate")
            pixel = np.asarray(entry["pixel"], np.float64)
            world = np.asarray(entry["world"], np.float64)
        except (TypeError, KeyError, ValueError):
            pixel = world = np.zeros(0)
        if (
            pixel.shape != (2,)
            or world.shape != (3,)
            or not np.all(np.isfinite(pixel))
            or not np.all(np.isfinite(world))
        ):
            raise MrcheckError(f"point #{i} needs 'pixel': [u, v] and 'world': [x, y, z], finite numbers", source)
        groups.append(Group({"index": i, "pixel": pixel.tolist(), "world": world.tolist()}, pixel[None], world[None]))
    if len(groups) < 4:
        raise MrcheckError(f"need at least 4 correspondences, got {len(groups)}", source)
    return groups


def _geometry_warnings(camera: Camera, world, pose: Pose, single_marker: bool):
    """Warnings about poses the data barely constrain, and the predicted overlay error."""
    warnings = []
    n = len(world)
    # residuals estimate the corner noise (6 pose parameters use up 6 of the 2n residual dofs)
    sigma = max(_MIN_SIGMA_PX, pose.rms * math.sqrt(2 * n / (2 * n - 6)) if 2 * n > 6 else 0.0)
    overlay = expected_overlay_error(camera, world, sigma)
    if single_marker:
        warnings.append(
            "only one marker was used: a pose from a single small target is weak "
            "away from it (a 20 cm marker at 10 m: ~30 px overlay error); add markers spread over the view"
        )
    _, s, Q = principal_axes(world)
    normal = Q[:, 2]
    extent = 2.0 * s[0] / math.sqrt(n)  # ~ the points' spread along their longest direction
    distance = float(np.mean(np.linalg.norm(world @ camera.R.T + camera.t, axis=1)))
    if extent > 0 and distance / extent > _WARN_DISTANCE_RATIO:
        warnings.append(
            f"the points span ~{extent:.2f} m seen from {distance:.1f} m (ratio {distance / extent:.0f}): "
            "far, small targets; use bigger boards or markers spread wider"
        )
    if s[2] < 1e-3 * s[0]:
        tilt = math.degrees(math.acos(min(1.0, abs(float(normal @ camera.R[2])))))
        if tilt < _WARN_FRONTAL_DEG:
            warnings.append(
                f"the points lie in one plane facing the camera (tilt {tilt:.0f} deg): distance and "
                "rotation trade off; add points at other depths or view the plane obliquely"
            )
    if overlay > _WARN_OVERLAY_PX:
        warnings.append(
            f"weak geometry: expected overlay error ~{overlay:.1f} px (1 sigma) across the image at {distance:.1f} m"
        )
    return overlay, warnings


# -- registration -----------------------------------------------------------------------------


def _register(camera: Camera, groups: list, method: str, max_error, warnings: list) -> dict:
    """Solve the pose over all groups jointly, reject bad markers or pairs, and build the shot dict."""
    pixels = np.concatenate([g.pixels for g in groups])
    world = np.concatenate([g.world for g in groups])
    owner = np.concatenate([np.full(len(g.world), i) for i, g in enumerate(groups)])
    pose = solve_pose(camera, pixels, world, max_error)
    atomic = [owner == i for i, g in enumerate(groups) if g.atomic]
    for _ in range(2):
        keep = pose.inliers.copy()
        for mine in atomic:
            keep[mine] = keep[mine].all()  # one bad corner: the marker moved or was misdetected
        if (keep == pose.inliers).all():
            break
        if keep.sum() < 4:
            raise MrcheckError("fewer than 4 usable points after rejecting inconsistent markers")
        refit = solve_pose(camera, pixels[keep], world[keep], pose.threshold)
        errors = reprojection_errors(camera, cv2.Rodrigues(refit.R)[0], refit.t, pixels, world)
        pose = Pose(refit.R, refit.t, errors, keep & (errors < refit.threshold), refit.threshold)
    used, rejected = [], []
    for i, group in enumerate(groups):
        mine = owner == i
        entry = dict(group.label, error_px=round(float(pose.errors[mine].max()), 3))
        if not group.atomic:
            entry["corners"] = int((mine & pose.inliers).sum())
            if (mine & ~pose.inliers).any():
                rejected.append(
                    dict(
                        group.label,
                        corners=int((mine & ~pose.inliers).sum()),
                        error_px=round(float(pose.errors[mine & ~pose.inliers].max()), 3),
                    )
                )
        (used if (mine & pose.inliers).any() else rejected).append(entry)
    posed = camera.with_pose(pose.R, pose.t)
    if len(groups) < 6 and method == "points":
        warnings.append(f"only {len(groups)} correspondences: outliers cannot be detected (use 6 or more)")
    warnings += _consensus_warnings(pose, owner, method)
    single = len(used) == 1 and method == "markers" and "id" in used[0]  # a board is many corners
    overlay, more = _geometry_warnings(posed, world[pose.inliers], pose, single)
    shot = posed.to_dict()
    shot.update(
        method=method,
        rms=round(pose.rms, 4),
        inlier_threshold_px=round(pose.threshold, 3),
        used=used,
        rejected=rejected,
        camera_position=posed.center.tolist(),
        expected_overlay_error_px=round(overlay, 2),
        warnings=warnings + more,
    )
    return shot


def _consensus_warnings(pose: Pose, owner: np.ndarray, method: str) -> list:
    """Warnings when the points that agree barely pin the pose down: only 4 of more (a single
    spare equation pair checks it), or another set of as many points agrees as well."""
    what = "points" if method == "points" else "marker corners"
    n, agree = len(pose.inliers), int(pose.inliers.sum())
    out = []
    if agree == 4 and n > 4:
        out.append(
            f"only 4 of {n} {what} agree within {pose.threshold:.1f} px: the pose rests on the minimum; "
            "add points or check the rejected ones"
        )
    if pose.rival is not None:
        inliers, rms = pose.rival
        which = f" (0-based {', '.join(str(i) for i in np.unique(owner[inliers]))})" if method == "points" else ""
        out.append(
            f"ambiguous: another {int(inliers.sum())} {what}{which} agree as well, with RMS {rms:.2f} px "
            f"against {pose.rms:.2f} px for the ones used; check for mis-clicks or add points"
        )
    return out


def register_markers(image: np.ndarray, camera: Camera, marker_map, max_error=None) -> dict:
    """The shot dict (see the module docstring) of a photo with markers of ``marker_map``
    (parsed JSON or :class:`~mrcheck.mr.markers.MarkerMap`); ``camera`` is rescaled to the photo."""
    marker_map = parse_marker_map(marker_map)
    camera, warnings = fit_camera(camera, image.shape[1], image.shape[0])
    detection = detect_markers(image, marker_map)
    unknown = [m["id"] for m in detection.unknown]
    if not detection.groups:
        found = f"; found only markers not in the map: {unknown[:20]}" if unknown else ""
        raise MrcheckError(f"no marker of the map was found in the photo{found}")
    if unknown:
        warnings.append(f"markers in the photo but not in the map (ignored): {unknown[:20]}")
    try:
        shot = _register(camera, detection.groups, "markers", max_error, warnings)
    except MrcheckError as exc:  # say what was found: 4 corners of a board is a small or blurred photo
        order = (
            "; a map's marker corners go top-left, top-right, bottom-right, bottom-left as seen from the front"
            if any("id" in g.label for g in detection.groups)
            else ""
        )
        raise MrcheckError(f"{exc} (detected: {_detected(detection.groups)}{order})", exc.path) from None
    shot.update(unknown_ids=detection.unknown, unseen_ids=detection.unseen)
    return shot


def _detected(groups: list) -> str:
    """What the detector found, for an error: "board 0: 4 corners, markers 3, 7"."""
    boards = [f"board {g.label['board']}: {len(g.world)} corners" for g in groups if "board" in g.label]
    markers = [str(g.label["id"]) for g in groups if "id" in g.label]
    return ", ".join(boards + ([f"marker{'s' * (len(markers) > 1)} {', '.join(markers)}"] if markers else []))


def register_points(camera: Camera, pairs, max_error=None) -> dict:
    """The shot dict of manual correspondences: ``{"points": [...]}`` or its list of
    ``{"pixel": [u, v], "world": [x, y, z]}`` (the camera must be at the photo's size)."""
    return _register(camera, _parse_points(pairs), "points", max_error, [])


def register_photo(
    photo, camera: Camera, marker_map=None, points=None, max_error=None, scene_bounds=None, points_file=None
) -> dict:
    """The SHOT.json dict of the photo file ``photo``: registered from ``marker_map`` (a
    :class:`~mrcheck.mr.markers.MarkerMap` or its JSON) or from ``points`` (groups of
    :func:`load_points`, or the correspondences JSON), with the absolute ``"photo"`` path.
    ``camera`` holds the intrinsics (rescaled to the photo when needed). ``scene_bounds``: the
    (2, 3) bounds of the scene the shot is for; a camera far outside them is a warning.
    ``points_file``: where ``points`` came from, named by errors about them (else the photo)."""
    image = read_photo(photo, grey=True)
    try:
        if marker_map is not None:
            shot = register_markers(image, camera, marker_map, max_error)
        else:
            camera, warnings = fit_camera(camera, image.shape[1], image.shape[0], photo)
            groups = (
                points
                if isinstance(points, list) and points and isinstance(points[0], Group)
                else _parse_points(points)
            )
            _check_pixels_inside(groups, image.shape[1], image.shape[0])
            shot = _register(camera, groups, "points", max_error, warnings)
    except MrcheckError as exc:
        if exc.path is None:  # "no consistent pose", "collinear": of which photo or points file
            raise MrcheckError(str(exc), points_file if marker_map is None and points_file else photo) from None
        raise
    if scene_bounds is not None and (warning := _far_from_scene(np.asarray(shot["camera_position"]), scene_bounds)):
        shot["warnings"].append(warning)
    return {
        **{k: shot[k] for k in ("width", "height", "K", "dist", "R", "t") if k in shot},
        "photo": str(Path(photo).resolve()),
        **shot,
    }


def _check_pixels_inside(groups: list, width: int, height: int) -> None:
    """A clicked pixel outside the photo is a typo or a point of another photo: refused, rather
    than left to RANSAC as one more outlier to out-vote."""
    for g in groups:
        u, v = g.pixels[0]
        if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
            raise MrcheckError(
                f"point #{g.label['index']}: pixel ({u:g}, {v:g}) lies outside the {width}x{height} photo"
            )


@dataclass(frozen=True)
class Registered:
    """What ``mrcheck register`` did: the shot dict written (its ``"photo"`` absolute) and where."""

    shot: dict
    output: Path

    def summary(self) -> list[str]:
        """The lines ``mrcheck register`` prints: what was used and rejected, the rms, the camera
        position, the expected overlay error, each warning, and the file written."""
        return summary_lines(self.shot, self.output)


def register_command(
    scene, photo, intrinsics, markers=None, points=None, max_error=None, output="SHOT.json"
) -> Registered:
    """``mrcheck register``: register ``photo`` and write SHOT.json atomically."""
    output = check_output_path(output, (".json",), "shot")
    if (markers is None) == (points is None):
        raise MrcheckError("give either --markers MAP.json or --points CORR.json (exactly one)")
    check_not_inputs(
        [output],
        [
            ("--photo", photo),
            ("--intrinsics", intrinsics),
            ("--markers", markers),
            ("--points", points),
            ("the scene", scene_files(scene)),
        ],
    )
    # fail before the work: the scene the overlay will need must load, and a quick check first
    check_input(scene, "scene", folder_ok=True)
    if Path(scene).is_file() and Path(scene).suffix.lower() not in (".toml", *MESH_SUFFIXES):
        raise MrcheckError(f"not a scene (a .toml manifest or a mesh: {', '.join(MESH_SUFFIXES)})", scene)
    camera = read_camera(intrinsics)  # its pose, if any, is ignored: the photo's is solved
    marker_map = load_marker_map(markers) if markers is not None else None
    pairs = load_points(points) if points is not None else None
    bounds = load_scene(scene, progress=True).bounds()
    shot = register_photo(
        photo, camera, marker_map=marker_map, points=pairs, max_error=max_error, scene_bounds=bounds, points_file=points
    )
    write_text(output, json.dumps({**shot, "photo": photo_reference(shot["photo"], output)}, indent=2) + "\n")
    return Registered(shot, output)


def photo_reference(photo, shot_file) -> str:
    """The ``"photo"`` value of a SHOT.json written to ``shot_file``: the photo's path relative
    to the shot's folder (:func:`mrcheck.core.camerafiles.load_shot` resolves it against that folder), so that a
    project folder of shots and photos, or an export folder with the photos beside it, can be
    moved or copied to another machine as a whole; absolute when no relative path exists (a
    photo on another Windows drive). Pure path arithmetic: an export's Dask worker computes it
    for a folder on the client."""
    photo, folder = os.path.realpath(photo), os.path.dirname(os.path.realpath(shot_file))
    try:
        return Path(os.path.relpath(photo, folder)).as_posix()
    except ValueError:
        return photo


def _far_from_scene(position: np.ndarray, bounds: np.ndarray) -> str | None:
    """A warning when the solved camera stands far outside the scene: the world points (marker
    map, correspondences) are then in another unit or frame than the scene (mm against m puts
    the camera 1000 times too far), and every overlay of the shot would show nothing."""
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))
    outside = float(np.linalg.norm(np.maximum(bounds[0] - position, 0) + np.maximum(position - bounds[1], 0)))
    if outside <= max(_FAR_MARGIN_M, extent):
        return None
    return (
        f"the camera stands {outside:.4g} m outside the scene (extent {extent:.3g} m): are the world points "
        "in the scene's unit and frame (mm against m)?"
    )


def summary_lines(shot: dict, output) -> list[str]:
    """A registration's summary: markers or points used and rejected, rms, camera position,
    expected overlay error, the shot's warnings, the file written."""

    def names(entries, errors=False):
        out = []
        for e in entries:
            name = str(e.get("id", e.get("index", f"board {e.get('board')}")))
            out.append(f"{name} ({e['error_px']:.1f} px)" if errors and "error_px" in e else name)
        return ", ".join(out) or "none"

    x, y, z = shot["camera_position"]
    which = "points (0-based positions in the points file)" if shot["method"] == "points" else "markers"
    used = shot["used"]
    # 54 chessboard corners are a count, not a list (the rejected are always listed)
    total = f" of {len(used) + len(shot['rejected'])}" if shot["method"] == "points" else ""  # a board can be in both
    used_text = names(used) if len(used) <= _LIST_MAX else f"{len(used)}{total}"
    return [
        f"registered {shot['photo']} from {which}: used {used_text}; rejected {names(shot['rejected'], errors=True)}",
        f"  rms {shot['rms']:.3f} px, camera at ({x:.3f}, {y:.3f}, {z:.3f}) m, "
        f"expected overlay error ~{shot['expected_overlay_error_px']:.1f} px",
        *(f"  warning: {warning}" for warning in shot["warnings"]),
        f"wrote {output}",
    ]


__all__ = [
    "register_command",
    "register_photo",
    "photo_reference",
    "register_markers",
    "register_points",
    "fit_camera",
    "load_points",
    "summary_lines",
    "Registered",
]
