"""The photo overlay: the planned CAD rendered from a registered shot, blended over its photo.

A registered shot (``SHOT.json``: camera JSON plus ``photo``, see :mod:`mrcheck.core.camera`) says
where the camera stood and how its lens bends light. The renderer draws the ideal pinhole
image of K; the photo carries the lens distortion ``dist``. To line the two up this module
**distorts the render into the photo's geometry** (choice (a)) instead of undistorting the
photo (choice (b)):

* the planner judges the real hall, so the photo stays untouched: no resampling blur, no
  stretched corners, no cropped or black borders, every photo pixel is the one taken;
* the render is synthetic, so resampling it costs nothing that matters, and it can be drawn
  larger than the photo (:func:`padded_camera`: same fx, fy, principal point shifted by whole
  pixels) so that a barrel lens's corners, which see *more* than the pinhole frame, are filled
  with CAD rather than black.

The map goes photo pixel -> ideal pixel: for every (distorted) photo pixel
:func:`distortion_map` finds the undistorted pixel with ``cv2.undistortPoints`` (iterated to
1e-10) and ``cv2.remap`` samples the render there. (``cv2.initUndistortRectifyMap`` builds the
opposite map, the one that undistorts a photo.) Pixels whose inversion does not converge --
beyond the radius where the polynomial model folds back -- show no CAD.

CAD edges (``--edges``) come from the depth buffer alone (:func:`cad_edges`). On any plane the
*inverse* depth ``1/z`` is an affine function of the pixel coordinates, so its second
differences are zero on flat faces at every viewing angle (plain depth is not: a floor seen at
a grazing angle would light up). A crease between two faces is a step in the gradient of
``1/z``, a silhouette a step in ``1/z`` itself: both show up as a large second difference
relative to ``1/z``. The threshold is in units of ``1/fx`` because that is what a crease's
second difference scales with (a change of surface slope seen through the lens).

Blending: ``out = alpha * photo + (1 - alpha) * render``; ``alpha`` is the photo's opacity, so
0 gives the (distorted) render and 1 the photo, both exactly.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import read_image
from mrcheck.core.jsonfile import read_json
from mrcheck.core.output import (
    IMAGE_SUFFIXES,
    check_not_inputs,
    check_output_path,
    labelled_sheet,
    write_image,
)
from mrcheck.render.renderer import STUDY_LABELS, Renderer, RenderSettings
from mrcheck.render.views import warn_if_nothing_in_view
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

STUDY_ORDER = ("phong", "vector", "ssao")  # D1 | D2 | D3, as in commands.py and the paper
DEFAULT_EDGE_COLOR = (255, 0, 255)
CREASE_THRESHOLD = 0.3    # second difference of 1/z relative to 1/z, times fx (~17 degrees face-on)
_MAX_PAD_FRACTION = 0.5   # render at most half an image more on each side (wild dist models)
_FOLD_TOLERANCE_PX = 0.05  # an inverted pixel must re-distort to itself within this


# -- geometry of the lens -------------------------------------------------------------------
def _has_distortion(camera: Camera) -> bool:
    return bool(np.any(camera.dist != 0.0))


def distortion_map(camera: Camera) -> tuple[np.ndarray, np.ndarray] | None:
    """For every photo pixel, the pixel of the ideal pinhole image of ``camera.K`` seen there.

    Returns ``(map_x, map_y)``, each (H, W) float32 for ``cv2.remap``, or None without
    distortion. Pixels where the model cannot be inverted are -1e6 (remap's border: no CAD).
    """
    if not _has_distortion(camera):
        return None
    h, w = camera.height, camera.width
    jj, ii = np.mgrid[0:h, 0:w]
    photo = np.stack([ii.ravel(), jj.ravel()], axis=1).astype(np.float64)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)
    ideal = cv2.undistortPoints(photo.reshape(-1, 1, 2), camera.K, camera.dist, P=camera.K,
                                criteria=criteria).reshape(-1, 2)
    # the fixed-point inversion returns *something* where the model folds; keep only the
    # pixels that distort back onto themselves
    normalised = np.column_stack(((ideal - camera.K[:2, 2]) / [camera.fx, camera.fy], np.ones(len(ideal))))
    back, _ = cv2.projectPoints(normalised, np.zeros(3), np.zeros(3), camera.K, camera.dist)
    bad = ~np.all(np.isfinite(ideal), axis=1) | (np.linalg.norm(back.reshape(-1, 2) - photo, axis=1) > _FOLD_TOLERANCE_PX)
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
        return image[dy:dy + h, dx:dx + w].copy()
    map_x, map_y = maps
    return cv2.remap(image, map_x + np.float32(dx), map_y + np.float32(dy), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


# -- edges ----------------------------------------------------------------------------------
def cad_edges(depth: np.ndarray, fx: float, threshold: float = CREASE_THRESHOLD) -> np.ndarray:
    """(H, W) bool silhouette and crease pixels of a linear depth buffer (0 = background).

    A pixel is an edge when the second difference of inverse depth across it (horizontally or
    vertically) exceeds ``threshold / fx`` relative to its inverse depth, or when it is
    geometry next to background (background is inverse depth 0, the limit of a far surface).
    """
    depth = np.asarray(depth, np.float64)
    inverse = np.where(depth > 0.0, 1.0 / np.where(depth > 0.0, depth, 1.0), 0.0)  # background: 1/inf
    edges = np.zeros(depth.shape, bool)
    limit = threshold / fx
    for axis in (0, 1):
        w = np.moveaxis(inverse, axis, 0)
        centre = w[1:-1]
        second = np.abs(w[2:] - 2.0 * centre + w[:-2])
        scale = np.maximum(np.maximum(w[2:], w[:-2]), centre)  # the nearest of the three
        hit = second > limit * scale
        # a step marks the pixels on both sides of it: silhouettes are 2 px wide, centred on the edge
        np.moveaxis(edges, axis, 0)[1:-1] |= hit
    return edges


# -- blending -------------------------------------------------------------------------------
def parse_edge_color(text) -> tuple[int, int, int]:
    """``RRGGBB`` (optionally with ``#``) -> (r, g, b) ints."""
    if isinstance(text, tuple):
        return text
    match = re.fullmatch(r"#?([0-9a-fA-F]{6})", str(text).strip())
    if match is None:
        raise MrcheckError(f"edge colour must be hex RRGGBB (e.g. ff00ff), got {text!r}")
    value = match.group(1)
    return tuple(int(value[i:i + 2], 16) for i in (0, 2, 4))


def check_alpha(alpha) -> float:
    if not (isinstance(alpha, (int, float)) and 0.0 <= alpha <= 1.0):  # "not <=" rejects nan too
        raise MrcheckError(f"alpha (photo opacity) must be between 0 and 1, got {alpha}")
    return float(alpha)


def blend(photo: np.ndarray, render: np.ndarray, alpha: float) -> np.ndarray:
    """``alpha * photo + (1 - alpha) * render``, rounded; alpha 0 and 1 are exact."""
    if alpha == 1.0:
        return photo.copy()
    if alpha == 0.0:
        return render.copy()
    mixed = alpha * photo.astype(np.float64) + (1.0 - alpha) * render.astype(np.float64)
    return np.clip(np.rint(mixed), 0, 255).astype(np.uint8)


def draw_edges(image: np.ndarray, coverage: np.ndarray, color) -> np.ndarray:
    """``image`` with ``color`` laid over it by ``coverage`` (0..1, antialiased edge mask)."""
    cover = np.clip(coverage, 0.0, 1.0)[..., None]
    out = image.astype(np.float64) * (1.0 - cover) + np.asarray(color, np.float64) * cover
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def overlay_images(photo: np.ndarray, renders: dict, camera: Camera, alpha: float, edges=None,
                   edge_color=DEFAULT_EDGE_COLOR, offset=(0, 0), maps=None) -> dict:
    """Blend ideal CAD renders over a photo; the reusable core of ``mrcheck overlay``.

    Parameters
    ----------
    photo : (H, W, 3) uint8 RGB, taken by ``camera`` (its size is the camera's).
    renders : {name: (H', W', 3) uint8 RGB} ideal pinhole renders of ``camera`` -- or of its
        :func:`padded_camera`, then ``offset`` is the padding's ``(dx, dy)``.
    alpha : photo opacity, 0..1.
    edges : optional (H', W') bool CAD edge mask in the renders' frame (:func:`cad_edges`).
    edge_color : (r, g, b) or ``"RRGGBB"``.
    maps : :func:`distortion_map` of ``camera`` when already computed (it is the slow part).

    Returns ``{name: (H, W, 3) uint8}`` in the photo's (distorted) geometry.
    """
    alpha = check_alpha(alpha)
    color = parse_edge_color(edge_color)
    if photo.shape[:2] != (camera.height, camera.width):
        raise MrcheckError(f"photo is {photo.shape[1]}x{photo.shape[0]}, the camera {camera.width}x{camera.height}")
    if maps is None:
        maps = distortion_map(camera)
    shape = photo.shape[:2]
    coverage = None
    if edges is not None:
        coverage = distort_to_photo(edges.astype(np.float32), maps, offset, shape)
        coverage = np.minimum(coverage * 2.0, 1.0)  # a 1-px line split over two pixels stays solid
    out = {}
    for name, render in renders.items():
        mixed = blend(photo, distort_to_photo(render, maps, offset, shape), alpha)
        out[name] = mixed if coverage is None else draw_edges(mixed, coverage, color)
    return out


# -- the command ----------------------------------------------------------------------------
def load_shot(path) -> tuple[Camera, Path]:
    """The camera of a registered SHOT.json and the absolute path of its photo."""
    path = Path(path)
    data = read_json(path, "shot")   # a shot is JSON (camera keys + "photo"), never OpenCV YAML
    camera = Camera.from_dict(data, path)
    photo = data.get("photo")
    if not isinstance(photo, str) or not photo:
        raise MrcheckError("shot JSON has no \"photo\" path", path)
    photo_path = Path(photo)
    if not photo_path.is_absolute():
        photo_path = path.resolve().parent / photo_path
    return camera, photo_path


def read_photo(path: Path, camera: Camera) -> np.ndarray:
    """(H, W, 3) uint8 RGB of the photo, checked against the shot's image size."""
    rgb = read_image(path, "photo")
    h, w = rgb.shape[:2]
    if (w, h) != (camera.width, camera.height):
        raise MrcheckError(f"photo is {w}x{h} but the shot was registered at {camera.width}x{camera.height}", path)
    return rgb


def photo_frame(renderer: Renderer, camera: Camera, modes, settings: RenderSettings, maps=None):
    """The ideal render (a :class:`mrcheck.render.renderer.Frame`: images, depth) covering the
    photo's distorted frame. Returns ``(frame, render_camera, offset, maps)``."""
    if maps is None:
        maps = distortion_map(camera)
    render_camera, offset = padded_camera(camera, maps)
    # the AO radius stays that of the photo's height, not of the padded render's
    settings = settings.validated(camera.height)
    return renderer.render(render_camera, modes, settings), render_camera, offset, maps


def render_for_photo(renderer: Renderer, camera: Camera, modes, settings: RenderSettings, want_edges: bool,
                     maps=None):
    """Ideal renders covering the photo's distorted frame.

    ``maps``: the :func:`distortion_map` of ``camera`` when already computed (several renders
    of one shot). Returns ``(renders, edges, offset, maps)``, ready for :func:`overlay_images`.
    """
    frame, render_camera, offset, maps = photo_frame(renderer, camera, modes, settings, maps)
    edges = cad_edges(frame.depth, render_camera.fx) if want_edges else None
    return {m: frame[m].image for m in modes}, edges, offset, maps


def overlay_command(shot, scene, mode="vector", alpha=0.5, edges=False, edge_color="ff00ff",
                    intensity=1.0, samples=16, output=None):
    """``mrcheck overlay``: validate everything, render, blend, write atomically."""
    output = check_output_path(output, IMAGE_SUFFIXES)
    alpha = check_alpha(alpha)
    color = parse_edge_color(edge_color)
    settings = RenderSettings(samples=samples, intensity=intensity)
    camera, photo_path = load_shot(shot)
    check_not_inputs([output], [("the shot", shot), ("the shot's photo", photo_path), ("the scene", scene_files(scene))])
    settings.validated(camera.height)  # option errors before the scene is loaded
    photo = read_photo(photo_path, camera)

    modes = list(STUDY_ORDER) if mode == "all" else [mode]
    loaded = load_scene(scene, progress=True)
    renderer = Renderer(loaded)
    try:
        frame, render_camera, offset, maps = photo_frame(renderer, camera, modes, settings)
        renders = {m: frame[m].image for m in modes}
        edge_mask = cad_edges(frame.depth, render_camera.fx) if edges else None
        # the overlay would be the bare photo
        warn_if_nothing_in_view(frame.depth, None, shot, "shot", "a wrong pose, or the shot of another scene?")
    finally:
        renderer.release()
    mixed = overlay_images(photo, renders, camera, alpha, edge_mask, color, offset, maps)
    if mode == "all":
        virtual = overlay_images(photo, renders, camera, 0.0, None, color, offset, maps)
        image = study_sheet(virtual, mixed, alpha)
    else:
        image = mixed[mode]
    print(write_image(output, image))


def study_sheet(virtual: dict, mixed: dict, alpha: float) -> np.ndarray:
    """The study's sheet: D1 | D2 | D3 virtual (top row) and over the photo (bottom row)."""
    top = labelled_sheet([virtual[m] for m in STUDY_ORDER], [STUDY_LABELS[m] for m in STUDY_ORDER])
    bottom = labelled_sheet([mixed[m] for m in STUDY_ORDER],
                            [f"{STUDY_LABELS[m]} + photo {alpha:g}" for m in STUDY_ORDER])
    gap = np.full((max(2, top.shape[0] // 200), top.shape[1], 3), 255, np.uint8)
    return np.vstack([top, gap, bottom])


__all__ = [
    "overlay_command", "overlay_images", "render_for_photo", "photo_frame", "distortion_map", "padded_camera",
    "distort_to_photo", "cad_edges", "blend", "draw_edges", "parse_edge_color", "check_alpha",
    "load_shot", "read_photo", "study_sheet", "CREASE_THRESHOLD",
]
