"""The pose uncertainty of an edge fit, in the terms a planner can use: the 1-sigma overlay error
at the image corners (px), the camera position (mm) and its angles (degrees), and which
direction is weak when the edges leave one undetermined.

All of it is first-order propagation of the pose covariance (:func:`mrcheck.mr.edges.solver.covariance`).
The corners are taken at the median depth of the edges used: an overlay is as good as the
pose at the depth of what it shows, and the edges' depth is where the photo pinned it down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.mr.edges.solver import PoseState

WEAK_RATIO = 4.0  # the largest pose sigma this many times the next: one direction is weak
WEAK_CORNER_PX = 2.0  # ... or the corners' 1-sigma error above this
PARALLEL_RATIO = 0.03  # the edges' normals: smaller / larger eigenvalue below this = all parallel
_CORNERS = ("top left", "top right", "bottom right", "bottom left")
_DIRECTIONS = (
    "sideways (camera x)",
    "up/down (camera y)",
    "forward/back (along the view)",
    "tilt (about camera x)",
    "pan (about camera y)",
    "roll (about the view axis)",
)


@dataclass
class PoseUncertainty:
    """1-sigma uncertainty of a pose.

    ``corner_px``: overlay error at the four image corners (top left, top right, bottom right,
    bottom left), px, at the depth ``depth_m``; ``position_mm``: camera position per world axis;
    ``position_camera_mm``: along the camera's right, down and viewing axes; ``angle_deg``: about
    the camera's right (tilt), down (pan) and viewing (roll) axes; ``weak``: the weakest pose
    direction in words, or None when no direction stands out; ``covariance``: the (6, 6)
    covariance of (rvec, t) about the edges' centre, as solved.
    """

    corner_px: list
    depth_m: float
    position_mm: list
    position_camera_mm: list
    angle_deg: list
    weak: str | None
    covariance: np.ndarray

    @property
    def max_corner_px(self) -> float:
        return float(max(self.corner_px))

    def to_dict(self) -> dict:
        return {
            "corner_px": dict(
                zip(("top_left", "top_right", "bottom_right", "bottom_left"), [round(v, 4) for v in self.corner_px])
            ),
            "depth_m": round(self.depth_m, 4),
            "position_mm": [round(v, 3) for v in self.position_mm],
            "position_camera_mm": [round(v, 3) for v in self.position_camera_mm],
            "angle_deg": [round(v, 5) for v in self.angle_deg],
            "weak_direction": self.weak,
        }


def corner_jacobians(state: PoseState, camera, depth: float) -> np.ndarray:
    """(4, 2, 6): d pixel / d pose of the world points seen at the image corners at ``depth``
    (pinhole: a distortion polynomial extrapolated to the corners would blow up)."""
    w, h = camera.width, camera.height
    corners = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], np.float64)
    rays = np.linalg.solve(camera.K, np.column_stack([corners, np.ones(4)]).T).T
    R = state.R
    local = (depth * rays - state.t) @ R  # R^T (P - t), row-wise
    _, jac = cv2.projectPoints(local, state.rvec, state.t, camera.K, np.zeros(5))
    return jac[:, :6].reshape(4, 2, 6)


def _numeric(f, state: PoseState, size: int) -> np.ndarray:
    """(size, 6) Jacobian of ``f(state)`` by central differences."""
    J = np.zeros((size, 6))
    for k in range(6):
        step = np.zeros(6)
        step[k] = 1e-6
        J[:, k] = (f(state.moved(step)) - f(state.moved(-step))) / 2e-6
    return J


def pose_uncertainty(state: PoseState, camera, cov: np.ndarray, depth: float) -> PoseUncertainty:
    """The uncertainty of ``state`` with covariance ``cov`` of (rvec, t)."""
    Jc = corner_jacobians(state, camera, depth)
    corner = [math.sqrt(max(float(np.trace(j @ cov @ j.T)), 0.0)) for j in Jc]
    R0 = state.R

    def centre(s):
        return -s.R.T @ s.t + s.centre

    def angles(s):
        # the camera-frame rotation of s from state, small: the axial vector of the skew part
        # (cv2.Rodrigues returns exactly zero below 1e-5 rad, which the differences need)
        M = s.R @ R0.T
        return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])

    Jp, Ja = _numeric(centre, state, 3), _numeric(angles, state, 3)
    cov_p, cov_a = Jp @ cov @ Jp.T, Ja @ cov @ Ja.T
    cov_pc = R0 @ cov_p @ R0.T
    sd = lambda c: [math.sqrt(max(v, 0.0)) for v in np.diag(c)]  # noqa: E731
    weak = weak_direction(
        np.vstack([R0 @ Jp * 1000.0, Ja * depth * 1000.0]) @ cov @ np.vstack([R0 @ Jp * 1000.0, Ja * depth * 1000.0]).T
    )
    return PoseUncertainty(
        corner,
        float(depth),
        [v * 1000 for v in sd(cov_p)],
        [v * 1000 for v in sd(cov_pc)],
        [math.degrees(v) for v in sd(cov_a)],
        weak,
        cov,
    )


def weak_direction(cov_mm: np.ndarray) -> str | None:
    """The weakest direction of a (6, 6) covariance of the camera's (right, down, forward)
    position and its (tilt, pan, roll) angles, all in mm (angles times the edges' depth), in
    words with its 1-sigma size; None when no direction is ``WEAK_RATIO`` times the third
    best constrained one. (Not the next: a few long parallel edges -- a bar across the view --
    leave two or three directions nearly free at once, and the largest of them is still the
    one to name.)"""
    values, vectors = np.linalg.eigh(cov_mm)
    values = np.maximum(values, 0.0)
    if values[-1] <= 0 or math.sqrt(values[-1]) < WEAK_RATIO * math.sqrt(max(values[2], 1e-30)):
        return None
    v = vectors[:, -1] ** 2
    order = np.argsort(v)[::-1]
    parts = [_DIRECTIONS[order[0]]] + ([_DIRECTIONS[order[1]]] if v[order[1]] > 0.25 else [])
    return f"{' coupled with '.join(parts)}: +-{math.sqrt(values[-1]):.0f} mm at the edges' depth"


def parallel_edges(normals: np.ndarray, weights: np.ndarray) -> float | None:
    """The image angle (degrees) of the edges when nearly all are parallel, else None."""
    if len(normals) == 0:
        return None
    T = normals.T @ (weights[:, None] * normals)
    values, vectors = np.linalg.eigh(T)
    if values[1] <= 0 or values[0] / values[1] >= PARALLEL_RATIO:
        return None
    nx, ny = vectors[:, 1]
    return float(round(math.degrees(math.atan2(nx, -ny))) % 180)  # the edge direction, perpendicular to n


__all__ = [
    "PoseUncertainty",
    "pose_uncertainty",
    "weak_direction",
    "parallel_edges",
    "corner_jacobians",
    "WEAK_CORNER_PX",
]
