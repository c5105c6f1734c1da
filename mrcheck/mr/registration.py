"""Registration: the camera pose of a photo in the factory, from markers or clicked points.

Conventions: OpenCV pinhole with distortion (see :mod:`mrcheck.core.camera`), ``X_cam = R @ X_world + t``,
world units metres, pixel centres at integer (u, v).

Inputs: a calibrated camera (intrinsics; its R, t are ignored) and either a marker map
(:mod:`mrcheck.mr.markers`) or correspondences JSON::

    {"points": [{"pixel": [u, v], "world": [x, y, z]}, ...]}     (>= 4, not collinear)

Output, SHOT.json: the camera JSON (``width``, ``height``, ``K``, ``dist``, ``R``, ``t``, so
``mrcheck render --camera SHOT.json`` takes it as is) plus::

    "photo": the photo's path relative to the SHOT.json's folder (:func:`mrcheck.core.shot.photo_reference`),
    "method": "markers" | "points",
    "rms": reprojection RMS on the inliers (px),  "inlier_threshold_px": the RANSAC threshold
        (points: :func:`~mrcheck.mr.pose.click_threshold` of the click noise, 3.72 sigma),
    "used" / "rejected": [{"id": 7, "dictionary": ..., "error_px": worst corner}, {"board": 0, ...,
        "corners": n}, or for points {"index": i, "pixel": .., "world": .., "error_px": ..}],
    "unknown_ids" / "unseen_ids" (markers only), "camera_position": world [x, y, z],
    "expected_overlay_error_px": predicted overlay error at the points' depth (1 sigma, RMS
        over the image, first order, from the pose covariance), "warnings": [str, ...]

The record is :class:`mrcheck.core.shot.Shot` (these keys after ``photo`` are its ``report``); the
pose itself is solved in :mod:`mrcheck.mr.pose`; ``mrcheck register`` is :mod:`mrcheck.mr.register`.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_photo
from mrcheck.core.errors import MrcheckError
from mrcheck.core.jsonfile import read_json
from mrcheck.core.shot import Anchors, Shot
from mrcheck.mr.markers import Group, detect_markers, parse_marker_map
from mrcheck.mr.pose import (
    CLICK_SIGMA_PX,
    Pose,
    expected_overlay_error,
    principal_axes,
    reprojection_errors,
    solve_pose,
)

# corner noise assumed when the residuals cannot tell (exact synthetic data, a single marker):
# subpixel ArUco/ChArUco corners are good to a few tenths of a pixel
_MIN_SIGMA_PX = 0.3
_WARN_OVERLAY_PX = 3.0  # predicted overlay error worth a warning
_WARN_DISTANCE_RATIO = 15.0  # mean distance / extent of the points
_WARN_FRONTAL_DEG = 20.0  # coplanar points whose plane faces the camera within this angle
_FAR_MARGIN_M = 5.0  # a camera this far outside the scene (or one scene extent) is suspicious
# two equally supported sets of clicks whose poses turn apart by more than this many of the pose's
# own 1-sigma rotation uncertainty (and at least AMBIGUOUS_DEG): the noise does not explain the
# difference, one of the sets holds a mis-click and which one is a guess, so the clicks are refused
AMBIGUOUS_SIGMAS = 3.0
AMBIGUOUS_DEG = 2.0  # a 2 deg turn is ~10 px at the edge of a 640 px view at 60 deg


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


def corner_noise(pose: Pose, n: int) -> float:
    """The corners' noise (px, 1 sigma) estimated from the residuals of ``n`` inliers (6 pose
    parameters use up 6 of the 2n residual dofs), at least :data:`_MIN_SIGMA_PX`."""
    return max(_MIN_SIGMA_PX, pose.rms * math.sqrt(2 * n / (2 * n - 6)) if 2 * n > 6 else 0.0)


def _geometry_warnings(camera: Camera, world, pose: Pose, single_marker: bool):
    """Warnings about poses the data barely constrain, and the predicted overlay error."""
    warnings = []
    n = len(world)
    sigma = corner_noise(pose, n)
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


def _register(camera: Camera, groups: list, method: str, max_error, warnings: list, noise_px=None) -> Shot:
    """Solve the pose over all groups jointly, reject bad markers or pairs: the shot (no photo file yet).
    ``noise_px``: the click noise the points' threshold follows from (points only)."""
    pixels = np.concatenate([g.pixels for g in groups])
    world = np.concatenate([g.world for g in groups])
    owner = np.concatenate([np.full(len(g.world), i) for i, g in enumerate(groups)])
    pose = solve_pose(camera, pixels, world, max_error, noise_px)
    if method == "points":
        refuse_ambiguous(pose)
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
    used: list[dict] = []
    rejected: list[dict] = []
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
    report = {
        "method": method,
        "rms": round(pose.rms, 4),
        "inlier_threshold_px": round(pose.threshold, 3),
        "used": used,
        "rejected": rejected,
        "camera_position": posed.center.tolist(),
        "expected_overlay_error_px": round(overlay, 2),
        "warnings": warnings + more,
    }
    # the clicks' noise as given, the markers' corners' as their residuals tell
    sigma = noise_px if noise_px is not None else corner_noise(pose, int(pose.inliers.sum()))
    return Shot(posed, None, report, Anchors(world[pose.inliers], pixels[pose.inliers], float(sigma)))


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
        inliers, rms = pose.rival.inliers, pose.rival.rms
        which = f" (0-based {', '.join(str(i) for i in np.unique(owner[inliers]))})" if method == "points" else ""
        out.append(
            f"ambiguous: another {int(inliers.sum())} {what}{which} agree as well, with RMS {rms:.2f} px "
            f"against {pose.rms:.2f} px for the ones used; check for mis-clicks or add points"
        )
    return out


def refuse_ambiguous(pose: Pose) -> None:
    """Clicks whose two equally large consistent subsets give poses :data:`AMBIGUOUS_DEG` apart
    and more than :data:`AMBIGUOUS_SIGMAS` of its own rotation uncertainty apart are refused:
    returning the lower-RMS one is a coin toss on small or distant objects."""
    rival = pose.rival
    if rival is None or rival.rotation_deg <= max(AMBIGUOUS_DEG, AMBIGUOUS_SIGMAS * rival.sigma_deg):
        return

    def names(mask):
        return ", ".join(str(i) for i in np.flatnonzero(mask))

    # the two sets in point order (their index lists compared, so sets sharing their first point
    # are ordered too): which one the fit kept is a tie broken by rounding (exact clicks: both at
    # RMS 0.00 px), and the same clicks should read the same on any CPU
    (first, rms_1), (second, rms_2) = sorted(
        [(pose.inliers, pose.rms), (rival.inliers, rival.rms)], key=lambda s: tuple(np.flatnonzero(s[0]).tolist())
    )
    raise MrcheckError(
        f"ambiguous clicks: points {names(first)} (RMS {rms_1:.2f} px) and {names(second)} "
        f"(RMS {rms_2:.2f} px, 0-based) agree equally well within {pose.threshold:.1f} px but their poses "
        f"turn {rival.rotation_deg:.1f} deg apart (1 sigma {rival.sigma_deg:.1f} deg); fix the mis-clicks or add points"
    )


def register_markers(image: np.ndarray, camera: Camera, marker_map, max_error=None) -> Shot:
    """The shot (see the module docstring; no photo file) of an image with markers of ``marker_map``
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
    return shot.with_report(unknown_ids=detection.unknown, unseen_ids=detection.unseen)


def _detected(groups: list) -> str:
    """What the detector found, for an error: "board 0: 4 corners, markers 3, 7"."""
    boards = [f"board {g.label['board']}: {len(g.world)} corners" for g in groups if "board" in g.label]
    markers = [str(g.label["id"]) for g in groups if "id" in g.label]
    return ", ".join(boards + ([f"marker{'s' * (len(markers) > 1)} {', '.join(markers)}"] if markers else []))


def register_points(camera: Camera, pairs, max_error=None, click_sigma=CLICK_SIGMA_PX) -> Shot:
    """The shot (no photo file) of manual correspondences: ``{"points": [...]}`` or its list of
    ``{"pixel": [u, v], "world": [x, y, z]}`` (the camera must be at the photo's size);
    ``click_sigma``: the clicks' noise (px, 1 sigma per axis) the outlier threshold follows from."""
    return _register(camera, _parse_points(pairs), "points", max_error, [], click_sigma)


def register_photo(
    photo,
    camera: Camera,
    marker_map=None,
    points=None,
    max_error=None,
    scene_bounds=None,
    points_file=None,
    click_sigma=CLICK_SIGMA_PX,
) -> Shot:
    """The shot of the photo file ``photo``: registered from ``marker_map`` (a
    :class:`~mrcheck.mr.markers.MarkerMap` or its JSON) or from ``points`` (groups of
    :func:`load_points`, or the correspondences JSON).
    ``camera`` holds the intrinsics (rescaled to the photo when needed). ``scene_bounds``: the
    (2, 3) bounds of the scene the shot is for; a camera far outside them is a warning.
    ``points_file``: where ``points`` came from, named by errors about them (else the photo).
    ``click_sigma``: the points' click noise (px), see :func:`register_points`."""
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
            shot = _register(camera, groups, "points", max_error, warnings, click_sigma)
    except MrcheckError as exc:
        if exc.path is None:  # "no consistent pose", "collinear": of which photo or points file
            raise MrcheckError(str(exc), points_file if marker_map is None and points_file else photo) from None
        raise
    if scene_bounds is not None and (warning := _far_from_scene(shot.camera.center, scene_bounds)):
        shot = shot.with_report(warnings=[*shot.report["warnings"], warning])
    return shot.with_photo(photo)


def _check_pixels_inside(groups: list, width: int, height: int) -> None:
    """A clicked pixel outside the photo is a typo or a point of another photo: refused, rather
    than left to RANSAC as one more outlier to out-vote."""
    for g in groups:
        u, v = g.pixels[0]
        if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
            raise MrcheckError(
                f"point #{g.label['index']}: pixel ({u:g}, {v:g}) lies outside the {width}x{height} photo"
            )


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


__all__ = [
    "register_photo",
    "register_markers",
    "register_points",
    "fit_camera",
    "load_points",
    "refuse_ambiguous",
    "AMBIGUOUS_DEG",
    "AMBIGUOUS_SIGMAS",
]
