"""The camera pose from 2D-3D point pairs, robust to outliers, and how well it is determined.

Conventions: OpenCV pinhole with distortion (see :mod:`mrcheck.core.camera`), ``X_cam = R @ X_world + t``.

The pose: RANSAC (``cv2.solvePnPRansac``, AP3P minimal samples) over all points of all markers
jointly, a refit on the inliers (IPPE's two solutions when the points are coplanar, SQPnP otherwise)
and ``cv2.solvePnPRefineLM``; the candidate with the lowest RMS wins. All of it runs in the points'
own frame (centred on their mean, axes along their principal directions), so the result does not
depend on where the world frame is: OpenCV's RANSAC works in float32 (useless 1e6 m from the
origin) and its EPnP fails on coplanar points for about half the orientations of their plane.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError

# up to this many points (clicks), every 4-point subset is a pose hypothesis (C(12, 4) = 495 AP3P
# solves, ~10 ms); beyond, RANSAC's consensus alone (markers: many corners, ties are rare)
_EXHAUSTIVE_MAX = 12
CLICK_SIGMA_PX = 1.5  # a careful click by eye on a corner: ~1.5 px (1 sigma per axis)
# a click's 2-D error over sigma is chi-distributed with 2 dof: 99.9 % of honest clicks lie within
# sqrt(-2 ln 0.001) = 3.72 sigma. At 99 % (3.03 sigma) one set of 8 clicks in 13 loses an honest
# one (LM-O's tuning photos, 160 cases: 18 of 1120 honest clicks lost at 99 %, 3 at 99.9 %, 0 at
# 99.99 %); 99.99 % (6.4 px at 1.5 px) would keep mis-clicks of 6-10 px, 99.9 % rejects them
CLICK_CONFIDENCE = 0.999
_REFITS = 5  # refit on the inliers until they no longer change (two rounds are the rule)


def click_threshold(sigma_px: float, confidence: float = CLICK_CONFIDENCE) -> float:
    """The outlier threshold (px) for clicks with Gaussian noise ``sigma_px`` per axis: the
    ``confidence`` quantile of the 2-D error, ``sigma * sqrt(-2 ln(1 - confidence))``."""
    return float(sigma_px) * math.sqrt(-2.0 * math.log(1.0 - confidence))


@dataclass(frozen=True)
class Rival:
    """Another consensus as large as the one used, on other points: its inliers, RMS (px) and how
    far its camera rotation is from the pose returned (deg)."""

    inliers: np.ndarray
    rms: float
    rotation_deg: float
    sigma_deg: float  # the returned pose's own rotation uncertainty (1 sigma, worst axis) at the click noise


@dataclass
class Pose:
    R: np.ndarray
    t: np.ndarray
    errors: np.ndarray  # (n,) reprojection error of every point, px
    inliers: np.ndarray  # (n,) bool
    threshold: float
    rival: Rival | None = None  # another consensus of the same size, if any

    @property
    def rms(self) -> float:
        return inlier_rms(self.errors, self.inliers)


def inlier_rms(errors: np.ndarray, inliers: np.ndarray) -> float:
    return float(np.sqrt(np.mean(errors[inliers] ** 2)))


def reprojection_errors(camera, rvec, tvec, pixels, world) -> np.ndarray:
    projected, _ = cv2.projectPoints(world, rvec, tvec, camera.K, camera.dist)
    return np.linalg.norm(projected.reshape(-1, 2) - pixels, axis=1)


def principal_axes(world):
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


def solve_pose(camera: Camera, pixels, world, max_error=None, noise_px=None) -> Pose:
    """Robust pose of ``camera`` from 2D-3D pairs: hypotheses of the inlier set, each refit and
    LM-refined; the most inliers win, then the lowest RMS.

    Hypotheses: RANSAC's inliers and, for up to :data:`_EXHAUSTIVE_MAX` points (manual clicks),
    the inliers of the AP3P pose of every 4-point subset. RANSAC alone keeps the first largest
    consensus it meets: with clicks, two sets of equal size (the right one, and one of two
    mis-clicks with good points that happen to agree) are common, and the better fit must win.

    Solved in the points' local frame (:func:`principal_axes`) and mapped back: the same points in any
    world frame give the same camera relative to them.

    The inlier threshold: ``max_error`` when given, else :func:`click_threshold` of ``noise_px``
    when given (clicks), else a few pixels, more for big photos (marker corners)."""
    pixels = np.ascontiguousarray(pixels, np.float64).reshape(-1, 2)
    world = np.ascontiguousarray(world, np.float64).reshape(-1, 3)
    n = len(world)
    if n < 4:
        raise MrcheckError(f"need at least 4 usable points for a pose, got {n}")
    c, s, Q = principal_axes(world)
    if s[0] < 1e-6 or s[1] < 1e-3 * s[0]:
        raise MrcheckError(
            "the world points are collinear (or coincide): the pose is undetermined; use points spread over an area"
        )
    if principal_axes(np.column_stack([pixels, np.zeros(n)]))[1][1] < 1e-3 * max(camera.width, camera.height):
        raise MrcheckError("the image points are collinear (or coincide): the pose is undetermined")
    planar = s[2] < 1e-3 * s[0]
    if max_error:
        threshold = float(max_error)
    elif noise_px:
        threshold = click_threshold(noise_px)
    else:  # corners: a few pixels, more for big photos (detection errors scale with size)
        threshold = max(3.0, 0.003 * math.hypot(camera.width, camera.height))

    world = np.ascontiguousarray((world - c) @ Q)  # from here on the local frame
    refits = [
        _refit(camera, pixels, world, inliers, seed, planar, threshold)
        for inliers, seed in _hypotheses(camera, pixels, world, threshold)
    ]
    fits = sorted((f for f in refits if f is not None), key=lambda f: (-f.inliers.sum(), f.rms))
    if not fits:
        raise MrcheckError(
            f"no consistent pose: fewer than 4 points agree within {threshold:.1f} px "
            "(check the survey, the ids and the intrinsics, or raise --max-error)"
        )
    best = fits[0]
    # another consensus as large as the one used, on other points: the data cannot tell them apart
    other = next(
        (f for f in fits[1:] if f.inliers.sum() == best.inliers.sum() and (f.inliers != best.inliers).any()), None
    )
    R_local = cv2.Rodrigues(best.rvec)[0]
    R = R_local @ Q.T  # X_cam = R_local Q^T (X - c) + t_local
    rival = None
    if other is not None:
        apart = rotation_angle(R_local, cv2.Rodrigues(other.rvec)[0])
        noise = noise_px or threshold / click_threshold(1.0)
        sigma = rotation_sigma(camera, R_local, best.tvec.ravel(), world[best.inliers], noise)
        rival = Rival(other.inliers, other.rms, apart, sigma)
    return Pose(R, best.tvec.ravel() - R @ c, best.errors, best.inliers, threshold, rival=rival)


def rotation_sigma(camera: Camera, R: np.ndarray, t: np.ndarray, world: np.ndarray, sigma_px: float) -> float:
    """The rotation's 1-sigma uncertainty (deg, its worst axis) of the pose ``R, t`` fit to
    ``world``'s points with pixel noise ``sigma_px``: the covariance ``sigma^2 (J^T J)^-1`` (Gauss-
    Newton, Hartley & Zisserman 5.2.3) with J over a small rotation applied before R and t,
    by central differences (an rvec's derivative is not an angle away from the identity)."""
    step = 1e-6

    def project(delta):
        turned = cv2.Rodrigues(delta[:3])[0] @ R
        return cv2.projectPoints(world, cv2.Rodrigues(turned)[0], t + delta[3:], camera.K, camera.dist)[0].ravel()

    J = np.column_stack([(project(step * e) - project(-step * e)) / (2 * step) for e in np.eye(6)])
    try:
        covariance = sigma_px**2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return float("inf")
    return math.degrees(math.sqrt(max(0.0, float(np.linalg.eigvalsh(covariance[:3, :3])[-1]))))


def rotation_angle(R1: np.ndarray, R2: np.ndarray) -> float:
    """The angle (deg) of the rotation between two rotation matrices."""
    cos = (np.trace(R1 @ R2.T) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, float(cos)))))


@dataclass
class _Fit:
    rvec: np.ndarray
    tvec: np.ndarray
    errors: np.ndarray
    inliers: np.ndarray

    @property
    def rms(self) -> float:
        return inlier_rms(self.errors, self.inliers)


def _hypotheses(camera, pixels, world, threshold):
    """(inlier mask, seed poses) to refit: all points when there are 4 (nothing to vote on),
    RANSAC's consensus, and for few points the consensus of every 4-point subset's pose."""
    n = len(world)
    if n == 4:
        return [(np.ones(n, bool), [])]
    hypotheses = {}
    # AP3P samples: valid for coplanar points in any orientation (EPnP's are not); the inliers are
    # RANSAC's, the pose it returns (an EPnP fit on them) is only one more seed
    ok, rvec, tvec, idx = cv2.solvePnPRansac(
        world,
        pixels,
        camera.K,
        camera.dist,
        iterationsCount=1000,
        reprojectionError=threshold,
        confidence=0.9999,
        flags=cv2.SOLVEPNP_AP3P,
    )
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
            inliers = reprojection_errors(camera, rvec, tvec, pixels, world) < threshold
            if inliers.sum() >= 4:
                hypotheses.setdefault(inliers.tobytes(), (inliers, []))[1].append((rvec, tvec))
    return list(hypotheses.values())


def _refit(camera, pixels, world, inliers, seeds, planar, threshold) -> _Fit | None:
    """The best pose for one consensus: seeds plus an IPPE / SQPnP fit on the inliers, LM-refined;
    then on the inliers of that fit until they stay the same. None when fewer than 4 points agree."""
    candidates, best = list(seeds), None
    for _ in range(_REFITS):
        if inliers.sum() < 4:
            break
        flag = cv2.SOLVEPNP_IPPE if planar else cv2.SOLVEPNP_SQPNP
        try:
            count, rvecs, tvecs, _ = cv2.solvePnPGeneric(
                world[inliers], pixels[inliers], camera.K, camera.dist, flags=flag
            )
        except cv2.error:
            count, rvecs, tvecs = 0, [], []
        candidates += list(zip(rvecs, tvecs))[:count]
        found = _best(camera, candidates, pixels, world, inliers)
        if found is None:
            break
        best = found
        if ((best[2] < threshold) == inliers).all():
            break
        inliers = best[2] < threshold
    if best is None or inliers.sum() < 4:
        return None
    return _Fit(best[0], best[1], best[2], inliers)


def _best(camera, candidates, pixels, world, inliers):
    """LM-refine every candidate on the inliers; the lowest RMS with all inliers in front wins."""
    best, best_rms = None, np.inf
    for rvec, tvec in candidates:
        rvec, tvec = cv2.solvePnPRefineLM(
            world[inliers], pixels[inliers], camera.K, camera.dist, rvec.copy(), tvec.copy()
        )
        R = cv2.Rodrigues(rvec)[0]
        if np.any((world[inliers] @ R.T + tvec.ravel())[:, 2] <= 0):
            continue  # the mirror solution of a plane puts the points behind the camera
        errors = reprojection_errors(camera, rvec, tvec, pixels, world)
        rms = np.sqrt(np.mean(errors[inliers] ** 2))
        if rms < best_rms:
            best, best_rms = (rvec, tvec, errors), rms
    return best


def expected_overlay_error(camera: Camera, world, sigma_px: float) -> float:
    """Predicted overlay error (px, 1 sigma, RMS over a 5x5 grid filling the image) at the points' depth.

    The pose covariance ``sigma^2 (J^T J)^-1`` of the registration points, propagated to points that
    fill the image at the median depth of the registration points: a small far marker pins down
    only its own neighbourhood, and this number says how badly the rest of the view may be off.
    """
    world = np.asarray(world, np.float64).reshape(-1, 3)
    depth = float(np.median(world @ camera.R[2] + camera.t[2]))
    u, v = np.meshgrid(np.linspace(0, camera.width - 1, 5), np.linspace(0, camera.height - 1, 5))
    rays = np.linalg.solve(camera.K, np.stack([u.ravel(), v.ravel(), np.ones(u.size)]))
    grid = (depth * rays - camera.t[:, None]).T @ camera.R  # R.T @ (depth * ray - t), row-wise
    return overlay_error_at(camera, world, sigma_px, grid)


def overlay_error_at(camera: Camera, world, sigma_px: float, targets) -> float:
    """Predicted overlay error (px, 1 sigma, RMS) at the world points ``targets`` of a pose
    registered on the points ``world`` with noise ``sigma_px``: the pose covariance
    ``sigma^2 (J^T J)^-1`` propagated to them (first order). Computed with the world origin moved
    to the points' mean (the same first-order result; with the points 1e6 m from the origin the
    rotation columns of J would swamp the normal matrix)."""
    world = np.asarray(world, np.float64).reshape(-1, 3)
    centre = world.mean(axis=0)
    t = camera.t + camera.R @ centre
    rvec, no_dist = cv2.Rodrigues(camera.R)[0], np.zeros(5)
    # pinhole Jacobians: a distortion polynomial extrapolated to the image corners would blow up
    _, J = cv2.projectPoints(world - centre, rvec, t, camera.K, no_dist)
    information = J[:, :6].T @ J[:, :6]
    _, Jg = cv2.projectPoints(np.asarray(targets, np.float64).reshape(-1, 3) - centre, rvec, t, camera.K, no_dist)
    try:
        covariance = sigma_px**2 * np.linalg.inv(information)
    except np.linalg.LinAlgError:
        return float("inf")
    per_point = np.einsum("ij,jk,ik->i", Jg[:, :6], covariance, Jg[:, :6]).reshape(-1, 2).sum(axis=1)
    return float(np.sqrt(per_point.mean()))


__all__ = [
    "CLICK_SIGMA_PX",
    "Pose",
    "Rival",
    "click_threshold",
    "rotation_angle",
    "rotation_sigma",
    "solve_pose",
    "expected_overlay_error",
    "overlay_error_at",
    "principal_axes",
    "reprojection_errors",
    "inlier_rms",
]
