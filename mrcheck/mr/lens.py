"""Lens geometry: the photo's distortion against the renderer's ideal pinhole image.

A registered shot (``SHOT.json``, :mod:`mrcheck.core.camerafiles`) says where the camera stood
and how its lens bends light. The renderer draws the ideal pinhole image of K; the photo carries
the lens distortion ``dist``. To line the two up mrcheck **distorts the render into the photo's
geometry** (choice (a)) instead of undistorting the photo (choice (b)):

* the planner judges the real hall, so the photo stays untouched: no resampling blur, no
  stretched corners, no cropped or black borders, every photo pixel is the one taken;
* the render is synthetic, so resampling it costs nothing that matters, and it can be drawn
  larger than the photo (:func:`padded_camera`: same fx, fy, principal point shifted by whole
  pixels) so that a barrel lens's corners, which see *more* than the pinhole frame, are filled
  with CAD rather than black.

The map goes photo pixel -> ideal pixel: for every (distorted) photo pixel
:func:`distortion_map` finds the undistorted pixel with ``cv2.undistortPoints`` (iterated to
1e-10) and ``cv2.remap`` samples the render there (:func:`distort_to_photo`).
(``cv2.initUndistortRectifyMap`` builds the opposite map, the one that undistorts a photo.)
Pixels whose inversion does not converge -- beyond the radius where the polynomial model folds
back -- show no CAD.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from mrcheck.core.camera import Camera

_MAX_PAD_FRACTION = 0.5  # render at most half an image more on each side (wild dist models)
_FOLD_TOLERANCE_PX = 0.05  # an inverted pixel must re-distort to itself within this


def has_distortion(camera: Camera) -> bool:
    return bool(np.any(camera.dist != 0.0))


def distortion_map(camera: Camera) -> tuple[np.ndarray, np.ndarray] | None:
    """For every photo pixel, the pixel of the ideal pinhole image of ``camera.K`` seen there.

    Returns ``(map_x, map_y)``, each (H, W) float32 for ``cv2.remap``, or None without
    distortion. Pixels where the model cannot be inverted are -1e6 (remap's border: no CAD).
    """
    if not has_distortion(camera):
        return None
    h, w = camera.height, camera.width
    jj, ii = np.mgrid[0:h, 0:w]
    photo = np.stack([ii.ravel(), jj.ravel()], axis=1).astype(np.float64)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)
    ideal = cv2.undistortPoints(photo.reshape(-1, 1, 2), camera.K, camera.dist, P=camera.K, criteria=criteria).reshape(
        -1, 2
    )
    # the fixed-point inversion returns *something* where the model folds; keep only the
    # pixels that distort back onto themselves
    normalised = np.column_stack(((ideal - camera.K[:2, 2]) / [camera.fx, camera.fy], np.ones(len(ideal))))
    back, _ = cv2.projectPoints(normalised, np.zeros(3), np.zeros(3), camera.K, camera.dist)
    bad = ~np.all(np.isfinite(ideal), axis=1) | (
        np.linalg.norm(back.reshape(-1, 2) - photo, axis=1) > _FOLD_TOLERANCE_PX
    )
    ideal[bad] = -1e6
    return ideal[:, 0].reshape(h, w).astype(np.float32), ideal[:, 1].reshape(h, w).astype(np.float32)


def padded_camera(camera: Camera, maps=None) -> tuple[Camera, tuple[int, int]]:
    """The camera to render so that the distorted photo frame is covered, and its offset.

    Same fx, fy and pose; the image grows by whole pixels and the principal point moves with
    it, so pixel (u, v) of ``camera``'s ideal image is pixel (u + dx, v + dy) of the padded one.
    Returns ``(render_camera, (dx, dy))``; without distortion ``(camera, (0, 0))``.
    """
    if maps is None:
        return camera, (0, 0)
    w, h = camera.width, camera.height
    map_x, map_y = maps
    valid = map_x > -1e5
    if not valid.any():
        return camera, (0, 0)
    xs, ys = map_x[valid], map_y[valid]
    cap_x, cap_y = math.ceil(_MAX_PAD_FRACTION * w), math.ceil(_MAX_PAD_FRACTION * h)
    # +2: bilinear sampling reads the next pixel too
    left = min(cap_x, max(0, math.ceil(-xs.min()) + 2))
    right = min(cap_x, max(0, math.ceil(xs.max() - (w - 1)) + 2))
    top = min(cap_y, max(0, math.ceil(-ys.min()) + 2))
    bottom = min(cap_y, max(0, math.ceil(ys.max() - (h - 1)) + 2))
    K = camera.K.copy()
    K[0, 2] += left
    K[1, 2] += top
    padded = Camera(w + left + right, h + top + bottom, K, camera.R, camera.t, camera.dist)
    return padded, (left, top)


def distort_to_photo(image: np.ndarray, maps, offset=(0, 0), shape=None) -> np.ndarray:
    """An ideal (padded) render resampled into the photo's distorted geometry.

    Without distortion (``maps`` None) the render is cropped by ``offset`` to ``shape`` and
    returned unchanged, pixel for pixel.
    """
    dx, dy = offset
    if maps is None:
        h, w = shape if shape is not None else (image.shape[0] - dy, image.shape[1] - dx)
        return image[dy : dy + h, dx : dx + w].copy()
    map_x, map_y = maps
    return cv2.remap(
        image,
        map_x + np.float32(dx),
        map_y + np.float32(dy),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )


__all__ = ["has_distortion", "distortion_map", "padded_camera", "distort_to_photo"]
