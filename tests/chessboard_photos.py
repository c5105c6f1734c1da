"""Synthetic photos of a chessboard seen by a KNOWN camera (the review's "Calibrate" tests): the
board's plane mapped into the image with the homography K [r1 r2 t] (``cv2.warpPerspective``,
drawn at 4x and averaged down, so the squares' edges are anti-aliased), over a grey background,
with mild blur and noise. No distortion: a homography cannot draw it."""

from __future__ import annotations

import cv2
import numpy as np

from mrcheck.core.camera import Camera

BOARD = "chessboard:9x6:0.025"  # inner corners: 10 x 7 squares of 25 mm
COLS, ROWS, SQUARE = 9, 6, 0.025
TRUE = Camera(640, 480, np.array([[520.0, 0, 322.0], [0, 515.0, 236.0], [0, 0, 1]]))
TEXTURE_PX = 40  # texture pixels per square; the board has a white margin of one square
SUPER = 4  # drawn at 4x the size and averaged down


def _texture() -> np.ndarray:
    """The board (10 x 7 squares and the margin) as a grey image, TEXTURE_PX per square."""
    squares = np.indices((ROWS + 1, COLS + 1)).sum(axis=0) % 2 == 0
    board = np.where(squares, 0, 255).astype(np.uint8)
    board = np.pad(board, 1, constant_values=255)
    return np.kron(board, np.ones((TEXTURE_PX, TEXTURE_PX), np.uint8))


def board_poses(count: int, seed: int = 7) -> list:
    """``count`` varied (rvec, tvec) of the board, every corner inside the image by 30 px: tilts up
    to 35 degrees about either axis, a roll of up to 20, 0.35-0.7 m away; no two alike (:func:`_apart`)."""
    rng = np.random.default_rng(seed)
    corners = _object_corners()
    poses, seen = [], []
    while len(poses) < count:
        angles = np.radians([rng.uniform(-35, 35), rng.uniform(-35, 35), rng.uniform(-20, 20)])
        R = cv2.Rodrigues(np.array([angles[0], 0, 0]))[0] @ cv2.Rodrigues(np.array([0, angles[1], 0]))[0]
        R = R @ cv2.Rodrigues(np.array([0, 0, angles[2]]))[0]
        centre = np.array([(COLS - 1) * SQUARE / 2, (ROWS - 1) * SQUARE / 2, 0])
        z = rng.uniform(0.35, 0.7)
        aim = np.array([rng.uniform(-0.3, 0.3) * z, rng.uniform(-0.2, 0.2) * z, z])
        t = aim - R @ centre
        image = TRUE.K @ (corners @ R.T + t).T
        px = (image[:2] / image[2]).T
        inside = image[2].min() > 0 and px.min() > 30 and (px[:, 0].max() < 610) and (px[:, 1].max() < 450)
        if inside and all(_apart((R, t, px.mean(axis=0)), other) for other in seen):
            seen.append((R, t, px.mean(axis=0)))
            poses.append((cv2.Rodrigues(R)[0].ravel(), t))
    return poses


def _apart(view, other) -> bool:
    """Two poses a calibration tells apart well: the board turned by 12 degrees or more, or its
    centre 64 px or more apart in the image, or 15 % nearer or farther (the review keeps views
    that differ by 8 degrees, 40 px or 10 %: a margin for its guessed camera)."""
    turn = np.degrees(np.arccos(min(1.0, abs(float(view[0][:, 2] @ other[0][:, 2])))))
    return turn >= 12 or np.linalg.norm(view[2] - other[2]) >= 64 or abs(np.log(view[1][2] / other[1][2])) >= 0.15


def _object_corners() -> np.ndarray:
    """The board's outer corners (of its margin), in metres in its plane (z = 0)."""
    lo, hi = -2 * SQUARE, np.array([COLS + 1, ROWS + 1]) * SQUARE
    return np.array([[lo, lo, 0], [hi[0], lo, 0], [hi[0], hi[1], 0], [lo, hi[1], 0]])


def chessboard_photo(rvec, tvec, seed: int = 0) -> np.ndarray:
    """(480, 640, 3) uint8 RGB: the board at pose (rvec, tvec) seen by :data:`TRUE`."""
    texture = _texture()
    R = cv2.Rodrigues(np.asarray(rvec, np.float64))[0]
    # texture pixel (u, v) -> board metres: the inner corner (0, 0) lies where squares 2 and 3 meet
    to_board = np.array([[SQUARE / TEXTURE_PX, 0, -2 * SQUARE + SQUARE / TEXTURE_PX / 2],
                         [0, SQUARE / TEXTURE_PX, -2 * SQUARE + SQUARE / TEXTURE_PX / 2], [0, 0, 1]])  # fmt: skip
    scale = np.diag([SUPER, SUPER, 1.0]) @ np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1]])
    to_image = np.array([[1, 0, -0.5], [0, 1, -0.5], [0, 0, 1]]) @ scale  # pixel centres at 4x
    H = to_image @ TRUE.K @ np.column_stack((R[:, 0], R[:, 1], tvec)) @ to_board
    big = cv2.warpPerspective(texture, H, (TRUE.width * SUPER, TRUE.height * SUPER), flags=cv2.INTER_LINEAR,
                              borderValue=110)  # fmt: skip
    grey = cv2.resize(big, (TRUE.width, TRUE.height), interpolation=cv2.INTER_AREA).astype(np.float32)
    rng = np.random.default_rng(seed)
    grey = cv2.GaussianBlur(grey, (0, 0), 0.7) + rng.normal(0, 2.0, grey.shape)
    grey = np.clip(grey, 0, 255).astype(np.uint8)
    return np.repeat(grey[:, :, None], 3, axis=2)


def jpeg(photo: np.ndarray, quality: int = 90) -> bytes:
    return cv2.imencode(".jpg", cv2.cvtColor(photo, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, quality])[
        1
    ].tobytes()
