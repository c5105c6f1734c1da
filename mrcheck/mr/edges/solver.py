"""The pose solver of the edge registration: point-to-edge residuals, robust Gauss-Newton steps
and the pose covariance.

The pose is ``(rvec, t)`` of OpenCV (Rodrigues vector, translation) for world points moved to a
centre ``c`` near the edges (``X_cam = R (X - c) + t_c``): the rotation's lever arm is then the
edges' extent, not their distance from the world origin, and the normal equations stay well
conditioned in a hall 1e6 m from it (as in :mod:`mrcheck.mr.registration`).

A sample's residual is the distance along its image normal ``n`` from its projection ``p`` to
the matched photo edge ``m``: ``r = n . (p - m)``; only the distance across the edge is
measured (the aperture problem: along an edge nothing is seen), with the Jacobian ``n^T dp/dpose``
from ``cv2.projectPoints`` (lens distortion as calibrated). Robust: Tukey's biweight on a MAD
scale (iteratively reweighted least squares), which gives zero weight to matches more than
4.685 sigma off -- clutter the CAD lacks, and CAD parts missing from the hall.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera

TUKEY_C = 4.685  # 95 % efficiency at the normal distribution
_MAD_TO_SIGMA = 1.4826
_RIDGE = 1e-12
MIN_PART_CLUSTERS = 20  # covariance(): parts as clusters only when at least this many found support


@dataclass
class PoseState:
    """``X_cam = R(rvec) (X - centre) + t``."""

    rvec: np.ndarray
    t: np.ndarray
    centre: np.ndarray

    @classmethod
    def of(cls, camera: Camera, centre) -> "PoseState":
        centre = np.asarray(centre, np.float64)
        return cls(cv2.Rodrigues(camera.R)[0].ravel(), camera.t + camera.R @ centre, centre)

    def moved(self, delta: np.ndarray) -> "PoseState":
        return PoseState(self.rvec + delta[:3], self.t + delta[3:], self.centre)

    @property
    def R(self) -> np.ndarray:
        return cv2.Rodrigues(self.rvec)[0]

    def camera(self, intrinsics: Camera) -> Camera:
        """``intrinsics`` at this pose (world frame again)."""
        R = self.R
        return intrinsics.with_pose(R, self.t - R @ self.centre)


@dataclass
class Projection:
    """``uv``: (n, 2) pixels (lens distortion applied); ``J``: (n, 2, 6) d uv / d (rvec, t);
    ``normal``: (n, 2) unit image normals of the edges; ``depth``: (n,) camera z."""

    uv: np.ndarray
    J: np.ndarray
    normal: np.ndarray
    depth: np.ndarray


def project(state: PoseState, camera: Camera, points: np.ndarray, tangents: np.ndarray) -> Projection:
    """The samples at ``state`` through ``camera``'s lens; the normal from the projected tangent."""
    if len(points) == 0:  # cv2.projectPoints returns None for no points
        return Projection(np.zeros((0, 2)), np.zeros((0, 2, 6)), np.zeros((0, 2)), np.zeros(0))
    local = points - state.centre
    uv, jac = cv2.projectPoints(local, state.rvec, state.t, camera.K, camera.dist)
    uv = uv.reshape(-1, 2)
    J = jac[:, :6].reshape(-1, 2, 6)
    depth = local @ state.R[2] + state.t[2]
    step = (1e-3 * depth)[:, None] * tangents  # a millimetre per metre along the edge
    ahead, _ = cv2.projectPoints(local + step, state.rvec, state.t, camera.K, camera.dist)
    d = ahead.reshape(-1, 2) - uv
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return Projection(uv, J, np.column_stack([-d[:, 1], d[:, 0]]), depth)


def tukey_weights(residuals: np.ndarray, sigma_floor: float, sigma: float | None = None) -> tuple[np.ndarray, float]:
    """Tukey's biweight of each residual and the scale used: ``sigma`` when given, else the
    residuals' robust scale (MAD), at least ``sigma_floor``."""
    if sigma is None:
        mad = _MAD_TO_SIGMA * float(np.median(np.abs(residuals))) if residuals.size else 0.0
        sigma = max(mad, sigma_floor)
    x = residuals / (TUKEY_C * sigma)
    return np.where(np.abs(x) < 1.0, (1.0 - x * x) ** 2, 0.0), sigma


def tukey_cost(residuals: np.ndarray, sigma: float) -> float:
    """The robust cost: Tukey's rho summed; a residual of inf (no match) costs the maximum."""
    c = TUKEY_C * sigma
    x = np.minimum(np.abs(residuals) / c, 1.0)
    return float(np.sum((c * c / 6.0) * (1.0 - (1.0 - x * x) ** 3)))


def normal_rows(projection: Projection, scale: float) -> np.ndarray:
    """(n, 6) rows ``n^T dp/dpose`` in level pixels (``scale`` = the level's ``2**-l``)."""
    return np.einsum("ni,nij->nj", projection.normal, projection.J) * scale


def gauss_newton_step(
    rows: np.ndarray, residuals: np.ndarray, weights: np.ndarray, damping: float = 1e-4, ridge: float = _RIDGE
):
    """The step ``delta`` minimising ``sum w (r + row . delta)^2``, Levenberg-damped (the
    diagonal times ``1 + damping``), or None when the normal equations are singular.
    ``ridge``: times the trace, added to the diagonal (see below)."""
    H = rows.T @ (weights[:, None] * rows)
    g = rows.T @ (weights * residuals)
    # Marquardt's diagonal scaling, plus a trace-relative ridge: a direction no edge constrains
    # (all edges parallel) has a zero column, and its step is then zero instead of singular
    H = H + damping * np.diag(np.diag(H)) + ridge * max(np.trace(H), 1e-30) * np.eye(6)
    try:
        return -np.linalg.solve(H, g)
    except np.linalg.LinAlgError:
        return None


def covariance(
    rows: np.ndarray, residuals: np.ndarray, weights: np.ndarray, clusters: np.ndarray, parts: np.ndarray | None = None
) -> np.ndarray:
    """(6, 6) covariance of ``(rvec, t)`` at the solution (full-resolution pixel rows).

    Samples along one CAD edge do not err independently (the photo's edge is bent, blurred or
    partly hidden over a length, the CAD edge is off by a tolerance): the plain ``sigma^2 H^-1``
    would count a long edge's hundred samples as a hundred measurements. The cluster-robust
    ("sandwich") covariance ``H^-1 (sum_g s_g s_g^T) H^-1`` with ``s_g`` the score of edge g
    (White 1980; Liang & Zeger 1986) counts each edge once, as far as its samples agree. With
    ``parts`` (the instance of every sample) the same two bounds are taken with one cluster per
    part as well: a part as built stands a little off its plan, and all its edges share that
    offset (measured on the generated cell, 640x480, seeds 0-9: with clusters of edges alone the
    true corner error reached 6.0x the reported sigma, with parts 1.8x); only with at least
    :data:`MIN_PART_CLUSTERS` parts: a cluster-robust estimate from a handful of clusters is no
    estimate (a scene of eight crates gave 10 px at the corners of a fit 0.1 px off). The largest (by trace)
    is returned (a few clusters alone underestimate it as well).
    """
    used = weights > 0
    rows, residuals, weights, clusters = rows[used], residuals[used], weights[used], clusters[used]
    H = rows.T @ (weights[:, None] * rows)
    H = H + _RIDGE * max(np.trace(H), 1e-30) * np.eye(6)  # an unconstrained direction: huge, not singular
    try:
        H_inv = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return np.full((6, 6), np.inf)
    sigma2 = float(np.sum(weights * residuals**2) / max(np.sum(weights) - 6, 1))
    candidates = [sigma2 * H_inv, *_clustered(rows, residuals, weights, clusters, H_inv, sigma2)]
    if parts is not None and len(np.unique(np.asarray(parts)[used])) >= MIN_PART_CLUSTERS:
        candidates += _clustered(rows, residuals, weights, np.asarray(parts)[used], H_inv, sigma2)
    return max(candidates, key=np.trace)


def _clustered(rows, residuals, weights, clusters, H_inv, sigma2) -> tuple:
    """``(sandwich, per_cluster)`` covariances of :func:`covariance` for one kind of cluster."""
    n = len(residuals)
    score = rows * (weights * residuals)[:, None]
    _, cluster = np.unique(clusters, return_inverse=True)
    m = int(cluster.max()) + 1 if n else 0
    S = np.zeros((m, 6))
    np.add.at(S, cluster, score)
    correction = (m / max(m - 1, 1)) * ((n - 1) / max(n - 6, 1))  # the usual small-sample factor
    sandwich = correction * H_inv @ (S.T @ S) @ H_inv
    # a cluster's samples share one error of its position (a shadow beside an edge, a bent or
    # worn real edge, a part set a little off): counted as ONE measurement of the residuals'
    # scale at the cluster's mean row; what the residuals cannot show (a bias shared by the
    # cluster) this bounds from below
    sums = np.zeros((m, 6))
    np.add.at(sums, cluster, rows * weights[:, None])
    mass = np.bincount(cluster, weights=weights, minlength=m)
    mean_rows = sums / np.maximum(mass, 1e-12)[:, None]
    try:
        G = mean_rows.T @ mean_rows
        per_cluster = sigma2 * np.linalg.inv(G + _RIDGE * max(np.trace(G), 1e-30) * np.eye(6))
    except np.linalg.LinAlgError:
        per_cluster = np.full((6, 6), np.inf)
    return sandwich, per_cluster


__all__ = [
    "PoseState",
    "Projection",
    "project",
    "tukey_weights",
    "tukey_cost",
    "normal_rows",
    "gauss_newton_step",
    "covariance",
    "TUKEY_C",
]
