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

The pose: RANSAC (``cv2.solvePnPRansac``, AP3P minimal samples) over all points of all markers
jointly, a refit on the inliers (IPPE's two solutions when the points are coplanar, SQPnP otherwise)
and ``cv2.solvePnPRefineLM``; the candidate with the lowest RMS wins. All of it runs in the points'
own frame (centred on their mean, axes along their principal directions), so the result does not
depend on where the world frame is: OpenCV's RANSAC works in float32 (useless 1e6 m from the
origin) and its EPnP fails on coplanar points for about half the orientations of their plane.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import click
import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import read_image
from mrcheck.core.inputs import check_input
from mrcheck.core.jsonfile import read_json
from mrcheck.core.output import check_not_inputs, check_output_path, write_text
from mrcheck.mr.markers import Group, detect_markers, load_marker_map, parse_marker_map
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import MESH_SUFFIXES, load_scene

# corner noise assumed when the residuals cannot tell (exact synthetic data, a single marker):
# subpixel ArUco/ChArUco corners are good to a few tenths of a pixel
_MIN_SIGMA_PX = 0.3
_WARN_OVERLAY_PX = 3.0  # predicted overlay error worth a warning
_WARN_DISTANCE_RATIO = 15.0  # mean distance / extent of the points
_WARN_FRONTAL_DEG = 20.0  # coplanar points whose plane faces the camera within this angle
_FAR_MARGIN_M = 5.0  # a camera this far outside the scene (or one scene extent) is suspicious
# up to this many points (clicks), every 4-point subset is a pose hypothesis (C(12, 4) = 495 AP3P
# solves, ~10 ms); beyond, RANSAC's consensus alone (markers: many corners, ties are rare)
_EXHAUSTIVE_MAX = 12
_LIST_MAX = 12  # the summary line lists the markers or points used up to this many


def fit_camera(camera: Camera, width: int, height: int, source=None):
    """``camera`` at the photo's size: as is, rescaled (same aspect ratio, with a warning), or an error."""
    if (width, height) == (camera.width, camera.height):
        return camera, []
    # a resized photo keeps the aspect ratio up to rounding of one pixel
    if abs(width * camera.height - height * camera.width) <= max(camera.width, camera.height, width, height):
        warning = (f"photo is {width}x{height} but the intrinsics are for {camera.width}x{camera.height}: "
                   "K rescaled (same aspect ratio; a crop would be wrong)")
        return camera.resized(width, height), [warning]
    raise MrcheckError(f"photo is {width}x{height} but the intrinsics are for {camera.width}x{camera.height} "
                       "(another aspect ratio: a crop or another camera mode; calibrate at this size)", source)


def read_photo(path) -> np.ndarray:
    """The photo as (H, W) uint8 grey, or a one-line error."""
    return read_image(path, "photo", grey=True)


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
        if pixel.shape != (2,) or world.shape != (3,) or not np.all(np.isfinite(pixel)) or not np.all(np.isfinite(world)):
            raise MrcheckError(f"point #{i} needs 'pixel': [u, v] and 'world': [x, y, z], finite numbers", source)
        groups.append(Group({"index": i, "pixel": pixel.tolist(), "world": world.tolist()}, pixel[None], world[None]))
    if len(groups) < 4:
        raise MrcheckError(f"need at least 4 correspondences, got {len(groups)}", source)
    return groups


# -- the pose ---------------------------------------------------------------------------------

@dataclass
class Pose:
    R: np.ndarray
    t: np.ndarray
    errors: np.ndarray  # (n,) reprojection error of every point, px
    inliers: np.ndarray  # (n,) bool
    threshold: float
    rival: tuple | None = None  # (inliers, rms) of another consensus of the same size, if any

    @property
    def rms(self) -> float:
        return _inlier_rms(self.errors, self.inliers)


def _inlier_rms(errors: np.ndarray, inliers: np.ndarray) -> float:
    return float(np.sqrt(np.mean(errors[inliers] ** 2)))


def _reprojection_errors(camera, rvec, tvec, pixels, world) -> np.ndarray:
    projected, _ = cv2.projectPoints(world, rvec, tvec, camera.K, camera.dist)
    return np.linalg.norm(projected.reshape(-1, 2) - pixels, axis=1)


def _principal(world):
    """``(c, s, Q)``: the points' mean, the singular values of the centred points (3, zero-padded)
    and their principal axes as the columns of a rotation (det +1; the last column is the normal
    of their best plane). ``X_local = Q^T (X - c)`` puts coplanar points in z = 0 and keeps
    coordinates small however far from the origin they are."""
    c = world.mean(axis=0)
    _, s, vt = np.linalg.svd(world - c)
    Q = vt.T.copy()  # n >= 3 points (2-D pixels padded with z = 0): vt is 3 x 3
    if np.linalg.det(Q) < 0:
        Q[:, 2] = -Q[:, 2]
    return c, np.concatenate([s, np.zeros(3 - s.size)]), Q


def solve_pose(camera: Camera, pixels, world, max_error=None) -> Pose:
    """Robust pose of ``camera`` from 2D-3D pairs: hypotheses of the inlier set, each refit and
    LM-refined; the most inliers win, then the lowest RMS.

    Hypotheses: RANSAC's inliers and, for up to :data:`_EXHAUSTIVE_MAX` points (manual clicks),
    the inliers of the AP3P pose of every 4-point subset. RANSAC alone keeps the first largest
    consensus it meets: with clicks, two sets of equal size (the right one, and one of two
    mis-clicks with good points that happen to agree) are common, and the better fit must win.

    Solved in the points' local frame (:func:`_principal`) and mapped back: the same points in any
    world frame give the same camera relative to them."""
    pixels = np.ascontiguousarray(pixels, np.float64).reshape(-1, 2)
    world = np.ascontiguousarray(world, np.float64).reshape(-1, 3)
    n = len(world)
    if n < 4:
        raise MrcheckError(f"need at least 4 usable points for a pose, got {n}")
    c, s, Q = _principal(world)
    if s[0] < 1e-6 or s[1] < 1e-3 * s[0]:
        raise MrcheckError("the world points are collinear (or coincide): the pose is undetermined; "
                           "use points spread over an area")
    if _principal(np.column_stack([pixels, np.zeros(n)]))[1][1] < 1e-3 * max(camera.width, camera.height):
        raise MrcheckError("the image points are collinear (or coincide): the pose is undetermined")
    planar = s[2] < 1e-3 * s[0]
    # automatic threshold: a few pixels, more for big photos (clicks and corners scale with size)
    threshold = float(max_error) if max_error else max(3.0, 0.003 * math.hypot(camera.width, camera.height))

    world = np.ascontiguousarray((world - c) @ Q)  # from here on the local frame
    fits = [_refit(camera, pixels, world, inliers, seed, planar, threshold)
            for inliers, seed in _hypotheses(camera, pixels, world, threshold)]
    fits = sorted((f for f in fits if f is not None), key=lambda f: (-f.inliers.sum(), f.rms))
    if not fits:
        raise MrcheckError(f"no consistent pose: fewer than 4 points agree within {threshold:.1f} px "
                           "(check the survey, the ids and the intrinsics, or raise --max-error)")
    best = fits[0]
    # another consensus as large as the one used, on other points: the data cannot tell them apart
    rival = next((f for f in fits[1:] if f.inliers.sum() == best.inliers.sum()
                  and (f.inliers != best.inliers).any()), None)
    R_local = cv2.Rodrigues(best.rvec)[0]
    R = R_local @ Q.T  # X_cam = R_local Q^T (X - c) + t_local
    return Pose(R, best.tvec.ravel() - R @ c, best.errors, best.inliers, threshold,
                rival=None if rival is None else (rival.inliers, rival.rms))


@dataclass
class _Fit:
    rvec: np.ndarray
    tvec: np.ndarray
    errors: np.ndarray
    inliers: np.ndarray

    @property
    def rms(self) -> float:
        return _inlier_rms(self.errors, self.inliers)


def _hypotheses(camera, pixels, world, threshold):
    """(inlier mask, seed poses) to refit: all points when there are 4 (nothing to vote on),
    RANSAC's consensus, and for few points the consensus of every 4-point subset's pose."""
    n = len(world)
    if n == 4:
        return [(np.ones(n, bool), [])]
    hypotheses = {}
    # AP3P samples: valid for coplanar points in any orientation (EPnP's are not); the inliers are
    # RANSAC's, the pose it returns (an EPnP fit on them) is only one more seed
    ok, rvec, tvec, idx = cv2.solvePnPRansac(world, pixels, camera.K, camera.dist, iterationsCount=1000,
                                             reprojectionError=threshold, confidence=0.9999, flags=cv2.SOLVEPNP_AP3P)
    if ok and idx is not None and len(idx) >= 4:
        inliers = np.zeros(n, bool)
        inliers[np.ravel(idx)] = True
        hypotheses[inliers.tobytes()] = (inliers, [(rvec, tvec)])
    if n <= _EXHAUSTIVE_MAX:
        for subset in itertools.combinations(range(n), 4):
            sub = list(subset)
            try:
                ok, rvec, tvec = cv2.solvePnP(world[sub], pixels[sub], camera.K, camera.dist, flags=cv2.SOLVEPNP_AP3P)
            except cv2.error:
                continue
            if not ok:
                continue
            inliers = _reprojection_errors(camera, rvec, tvec, pixels, world) < threshold
            if inliers.sum() >= 4:
                hypotheses.setdefault(inliers.tobytes(), (inliers, []))[1].append((rvec, tvec))
    return list(hypotheses.values())


def _refit(camera, pixels, world, inliers, seeds, planar, threshold) -> _Fit | None:
    """The best pose for one consensus: seeds plus an IPPE / SQPnP fit on the inliers, LM-refined;
    then once more on the inliers of that fit. None when fewer than 4 points agree."""
    candidates, best = list(seeds), None
    for _ in range(2):  # refit on the inliers, then once more on the inliers of the refit
        if inliers.sum() < 4:
            break
        flag = cv2.SOLVEPNP_IPPE if planar else cv2.SOLVEPNP_SQPNP
        try:
            count, rvecs, tvecs, _ = cv2.solvePnPGeneric(world[inliers], pixels[inliers], camera.K, camera.dist, flags=flag)
        except cv2.error:
            count, rvecs, tvecs = 0, [], []
        candidates += list(zip(rvecs, tvecs))[:count]
        found = _best(camera, candidates, pixels, world, inliers)
        if found is None:
            break
        best = found
        inliers = best[2] < threshold
    if best is None or inliers.sum() < 4:
        return None
    return _Fit(best[0], best[1], best[2], inliers)


def _best(camera, candidates, pixels, world, inliers):
    """LM-refine every candidate on the inliers; the lowest RMS with all inliers in front wins."""
    best, best_rms = None, np.inf
    for rvec, tvec in candidates:
        rvec, tvec = cv2.solvePnPRefineLM(world[inliers], pixels[inliers], camera.K, camera.dist,
                                          rvec.copy(), tvec.copy())
        R = cv2.Rodrigues(rvec)[0]
        if np.any((world[inliers] @ R.T + tvec.ravel())[:, 2] <= 0):
            continue  # the mirror solution of a plane puts the points behind the camera
        errors = _reprojection_errors(camera, rvec, tvec, pixels, world)
        rms = np.sqrt(np.mean(errors[inliers] ** 2))
        if rms < best_rms:
            best, best_rms = (rvec, tvec, errors), rms
    return best


def expected_overlay_error(camera: Camera, world, sigma_px: float) -> float:
    """Predicted overlay error (px, 1 sigma, RMS over a 5x5 grid filling the image) at the points' depth.

    The pose covariance ``sigma^2 (J^T J)^-1`` of the registration points, propagated to points that
    fill the image at the median depth of the registration points: a small far marker pins down
    only its own neighbourhood, and this number says how badly the rest of the view may be off.
    Computed with the world origin moved to the points' mean (the same first-order result; with the
    points 1e6 m from the origin the rotation columns of J would swamp the normal matrix).
    """
    world = np.asarray(world, np.float64).reshape(-1, 3)
    centre = world.mean(axis=0)
    world, t = world - centre, camera.t + camera.R @ centre
    rvec, no_dist = cv2.Rodrigues(camera.R)[0], np.zeros(5)
    # pinhole Jacobians: a distortion polynomial extrapolated to the image corners would blow up
    _, J = cv2.projectPoints(world, rvec, t, camera.K, no_dist)
    information = J[:, :6].T @ J[:, :6]
    depth = float(np.median(world @ camera.R[2] + t[2]))
    u, v = np.meshgrid(np.linspace(0, camera.width - 1, 5), np.linspace(0, camera.height - 1, 5))
    rays = np.linalg.solve(camera.K, np.stack([u.ravel(), v.ravel(), np.ones(u.size)]))
    grid = (depth * rays - t[:, None]).T @ camera.R  # R.T @ (depth * ray - t), row-wise
    _, Jg = cv2.projectPoints(grid, rvec, t, camera.K, no_dist)
    try:
        covariance = sigma_px ** 2 * np.linalg.inv(information)
    except np.linalg.LinAlgError:
        return float("inf")
    per_point = np.einsum("ij,jk,ik->i", Jg[:, :6], covariance, Jg[:, :6]).reshape(-1, 2).sum(axis=1)
    return float(np.sqrt(per_point.mean()))


def _geometry_warnings(camera: Camera, world, pose: Pose, single_marker: bool):
    """Warnings about poses the data barely constrain, and the predicted overlay error."""
    warnings = []
    n = len(world)
    # residuals estimate the corner noise (6 pose parameters use up 6 of the 2n residual dofs)
    sigma = max(_MIN_SIGMA_PX, pose.rms * math.sqrt(2 * n / (2 * n - 6)) if 2 * n > 6 else 0.0)
    overlay = expected_overlay_error(camera, world, sigma)
    if single_marker:
        warnings.append("only one marker was used: a pose from a single small target is weak "
                        "away from it (a 20 cm marker at 10 m: ~30 px overlay error); add markers spread over the view")
    _, s, Q = _principal(world)
    normal = Q[:, 2]
    extent = 2.0 * s[0] / math.sqrt(n)  # ~ the points' spread along their longest direction
    distance = float(np.mean(np.linalg.norm(world @ camera.R.T + camera.t, axis=1)))
    if extent > 0 and distance / extent > _WARN_DISTANCE_RATIO:
        warnings.append(f"the points span ~{extent:.2f} m seen from {distance:.1f} m (ratio {distance / extent:.0f}): "
                        "far, small targets; use bigger boards or markers spread wider")
    if s[2] < 1e-3 * s[0]:
        tilt = math.degrees(math.acos(min(1.0, abs(float(normal @ camera.R[2])))))
        if tilt < _WARN_FRONTAL_DEG:
            warnings.append(f"the points lie in one plane facing the camera (tilt {tilt:.0f} deg): distance and "
                            "rotation trade off; add points at other depths or view the plane obliquely")
    if overlay > _WARN_OVERLAY_PX:
        warnings.append(f"weak geometry: expected overlay error ~{overlay:.1f} px (1 sigma) across the image "
                        f"at {distance:.1f} m")
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
        errors = _reprojection_errors(camera, cv2.Rodrigues(refit.R)[0], refit.t, pixels, world)
        pose = Pose(refit.R, refit.t, errors, keep & (errors < refit.threshold), refit.threshold)
    used, rejected = [], []
    for i, group in enumerate(groups):
        mine = owner == i
        entry = dict(group.label, error_px=round(float(pose.errors[mine].max()), 3))
        if not group.atomic:
            entry["corners"] = int((mine & pose.inliers).sum())
            if (mine & ~pose.inliers).any():
                rejected.append(dict(group.label, corners=int((mine & ~pose.inliers).sum()),
                                     error_px=round(float(pose.errors[mine & ~pose.inliers].max()), 3)))
        (used if (mine & pose.inliers).any() else rejected).append(entry)
    posed = camera.with_pose(pose.R, pose.t)
    if len(groups) < 6 and method == "points":
        warnings.append(f"only {len(groups)} correspondences: outliers cannot be detected (use 6 or more)")
    warnings += _consensus_warnings(pose, owner, method)
    single = len(used) == 1 and method == "markers" and "id" in used[0]  # a board is many corners
    overlay, more = _geometry_warnings(posed, world[pose.inliers], pose, single)
    shot = posed.to_dict()
    shot.update(method=method, rms=round(pose.rms, 4), inlier_threshold_px=round(pose.threshold, 3),
                used=used, rejected=rejected, camera_position=posed.center.tolist(),
                expected_overlay_error_px=round(overlay, 2), warnings=warnings + more)
    return shot


def _consensus_warnings(pose: Pose, owner: np.ndarray, method: str) -> list:
    """Warnings when the points that agree barely pin the pose down: only 4 of more (a single
    spare equation pair checks it), or another set of as many points agrees as well."""
    what = "points" if method == "points" else "marker corners"
    n, agree = len(pose.inliers), int(pose.inliers.sum())
    out = []
    if agree == 4 and n > 4:
        out.append(f"only 4 of {n} {what} agree within {pose.threshold:.1f} px: the pose rests on the minimum; "
                   "add points or check the rejected ones")
    if pose.rival is not None:
        inliers, rms = pose.rival
        which = (f" (0-based {', '.join(str(i) for i in np.unique(owner[inliers]))})" if method == "points" else "")
        out.append(f"ambiguous: another {int(inliers.sum())} {what}{which} agree as well, with RMS {rms:.2f} px "
                   f"against {pose.rms:.2f} px for the ones used; check for mis-clicks or add points")
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
    except MrcheckError as exc:   # say what was found: 4 corners of a board is a small or blurred photo
        order = ("; a map's marker corners go top-left, top-right, bottom-right, bottom-left as seen from the front"
                 if any("id" in g.label for g in detection.groups) else "")
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


def register_photo(photo, camera: Camera, marker_map=None, points=None, max_error=None, scene_bounds=None,
                   points_file=None) -> dict:
    """The SHOT.json dict of the photo file ``photo``: registered from ``marker_map`` (a
    :class:`~mrcheck.mr.markers.MarkerMap` or its JSON) or from ``points`` (groups of
    :func:`load_points`, or the correspondences JSON), with the absolute ``"photo"`` path.
    ``camera`` holds the intrinsics (rescaled to the photo when needed). ``scene_bounds``: the
    (2, 3) bounds of the scene the shot is for; a camera far outside them is a warning.
    ``points_file``: where ``points`` came from, named by errors about them (else the photo)."""
    image = read_photo(photo)
    try:
        if marker_map is not None:
            shot = register_markers(image, camera, marker_map, max_error)
        else:
            camera, warnings = fit_camera(camera, image.shape[1], image.shape[0], photo)
            groups = points if isinstance(points, list) and points and isinstance(points[0], Group) else _parse_points(points)
            _check_pixels_inside(groups, image.shape[1], image.shape[0])
            shot = _register(camera, groups, "points", max_error, warnings)
    except MrcheckError as exc:
        if exc.path is None:  # "no consistent pose", "collinear": of which photo or points file
            raise MrcheckError(str(exc), points_file if marker_map is None and points_file else photo) from None
        raise
    if scene_bounds is not None and (warning := _far_from_scene(np.asarray(shot["camera_position"]), scene_bounds)):
        shot["warnings"].append(warning)
    return {**{k: shot[k] for k in ("width", "height", "K", "dist", "R", "t") if k in shot},
            "photo": str(Path(photo).resolve()), **shot}


def _check_pixels_inside(groups: list, width: int, height: int) -> None:
    """A clicked pixel outside the photo is a typo or a point of another photo: refused, rather
    than left to RANSAC as one more outlier to out-vote."""
    for g in groups:
        u, v = g.pixels[0]
        if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
            raise MrcheckError(f"point #{g.label['index']}: pixel ({u:g}, {v:g}) lies outside the {width}x{height} photo")


def register_command(scene, photo, intrinsics, markers=None, points=None, max_error=None, output="SHOT.json") -> dict:
    """``mrcheck register``: register ``photo``, write SHOT.json atomically, print a summary."""
    output = check_output_path(output, (".json",), "shot")
    if (markers is None) == (points is None):
        raise MrcheckError("give either --markers MAP.json or --points CORR.json (exactly one)")
    check_not_inputs([output], [("--photo", photo), ("--intrinsics", intrinsics), ("--markers", markers),
                                ("--points", points), ("the scene", scene_files(scene))])
    # fail before the work: the scene the overlay will need must load, and a quick check first
    check_input(scene, "scene", folder_ok=True)
    if Path(scene).is_file() and Path(scene).suffix.lower() not in (".toml", *MESH_SUFFIXES):
        raise MrcheckError(f"not a scene (a .toml manifest or a mesh: {', '.join(MESH_SUFFIXES)})", scene)
    camera = read_camera(intrinsics)  # its pose, if any, is ignored: the photo's is solved
    marker_map = load_marker_map(markers) if markers is not None else None
    pairs = load_points(points) if points is not None else None
    bounds = load_scene(scene, progress=True).bounds()
    shot = register_photo(photo, camera, marker_map=marker_map, points=pairs, max_error=max_error, scene_bounds=bounds,
                          points_file=points)
    write_text(output, json.dumps({**shot, "photo": photo_reference(shot["photo"], output)}, indent=2) + "\n")
    _print_summary(shot, output)
    return shot


def photo_reference(photo, shot_file) -> str:
    """The ``"photo"`` value of a SHOT.json written to ``shot_file``: the photo's path relative
    to the shot's folder (``overlay.load_shot`` resolves it against that folder), so that a
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
    return (f"the camera stands {outside:.4g} m outside the scene (extent {extent:.3g} m): are the world points "
            "in the scene's unit and frame (mm against m)?")


def _print_summary(shot: dict, output) -> None:
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
    click.echo(f"registered {shot['photo']} from {which}: used {used_text}; "
               f"rejected {names(shot['rejected'], errors=True)}")
    click.echo(f"  rms {shot['rms']:.3f} px, camera at ({x:.3f}, {y:.3f}, {z:.3f}) m, "
               f"expected overlay error ~{shot['expected_overlay_error_px']:.1f} px")
    for warning in shot["warnings"]:
        click.echo(f"  warning: {warning}")
    click.echo(f"wrote {output}")


__all__ = ["register_command", "register_photo", "photo_reference", "register_markers", "register_points", "solve_pose", "fit_camera",
           "expected_overlay_error", "read_photo", "load_points", "Pose"]
