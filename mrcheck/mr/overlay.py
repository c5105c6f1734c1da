"""Blending: ideal CAD renders laid over their photo, in the photo's own geometry.

``out = alpha * photo + (1 - alpha) * render``; ``alpha`` is the photo's opacity, so 0 gives the
(distorted, :mod:`mrcheck.mr.lens`) render and 1 the photo, both exactly. CAD edges
(:func:`mrcheck.mr.shot.cad_edges`) are drawn over the blend in one colour. The study's sheet
(:func:`study_sheet`) puts D1 | D2 | D3 virtual above the same over the photo.
"""

from __future__ import annotations

import re

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import labelled_sheet
from mrcheck.mr.lens import distort_to_photo, distortion_map
from mrcheck.render.renderer import STUDY_LABELS
from mrcheck.render.views import STUDY_ORDER

DEFAULT_EDGE_COLOR = (255, 0, 255)


def parse_edge_color(text) -> tuple[int, int, int]:
    """``RRGGBB`` (optionally with ``#``) -> (r, g, b) ints."""
    if isinstance(text, tuple):
        return text
    match = re.fullmatch(r"#?([0-9a-fA-F]{6})", str(text).strip())
    if match is None:
        raise MrcheckError(f"edge colour must be hex RRGGBB (e.g. ff00ff), got {text!r}")
    value = match.group(1)
    return tuple(int(value[i : i + 2], 16) for i in (0, 2, 4))


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


def overlay_images(
    photo: np.ndarray,
    renders: dict,
    camera: Camera,
    alpha: float,
    edges=None,
    edge_color=DEFAULT_EDGE_COLOR,
    offset=(0, 0),
    maps=None,
) -> dict:
    """Blend ideal CAD renders over a photo; the reusable core of ``mrcheck overlay``.

    Parameters
    ----------
    photo : (H, W, 3) uint8 RGB, taken by ``camera`` (its size is the camera's).
    renders : {name: (H', W', 3) uint8 RGB} ideal pinhole renders of ``camera`` -- or of its
        :func:`mrcheck.mr.lens.padded_camera`, then ``offset`` is the padding's ``(dx, dy)``.
    alpha : photo opacity, 0..1.
    edges : optional (H', W') bool CAD edge mask in the renders' frame (:func:`mrcheck.mr.shot.cad_edges`).
    edge_color : (r, g, b) or ``"RRGGBB"``.
    maps : :func:`mrcheck.mr.lens.distortion_map` of ``camera`` when already computed (it is the slow part).

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


def study_sheet(virtual: dict, mixed: dict, alpha: float) -> np.ndarray:
    """The study's sheet: D1 | D2 | D3 virtual (top row) and over the photo (bottom row)."""
    top = labelled_sheet([virtual[m] for m in STUDY_ORDER], [STUDY_LABELS[m] for m in STUDY_ORDER])
    bottom = labelled_sheet(
        [mixed[m] for m in STUDY_ORDER], [f"{STUDY_LABELS[m]} + photo {alpha:g}" for m in STUDY_ORDER]
    )
    gap = np.full((max(2, top.shape[0] // 200), top.shape[1], 3), 255, np.uint8)
    return np.vstack([top, gap, bottom])


__all__ = [
    "overlay_images",
    "blend",
    "draw_edges",
    "parse_edge_color",
    "check_alpha",
    "study_sheet",
    "STUDY_ORDER",
    "DEFAULT_EDGE_COLOR",
]
