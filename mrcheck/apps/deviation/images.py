"""Pictures of a deviation: the scan coloured by signed distance, seen from above, from the
front, and through a shot's camera over its render and its photo overlay.

Colours: a diverging map, blue (d < 0, behind the CAD surface) - white (0) - red (d > 0, in
front of it), symmetric about 0 and saturating at +-S, S the 95th percentile of ``|d|`` rounded
up to 1, 2 or 5 x 10^k mm (:func:`colour_scale_mm`); the legend bar gives the scale in mm.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from mrcheck.core.arrays import bounding_box
from mrcheck.scene.model import Scene

VIEW_IMAGES = {"top": "deviation_top.png", "side": "deviation_side.png"}
SHOT_IMAGES = {"deviation_render.png": 0.0, "deviation_overlay.png": 0.5}  # name: the photo's alpha
IMAGE_SIZE = 1024  # longest side of the orthographic images, pixels
SPLAT_RADIUS = 1  # splat half-size in pixels (3x3 squares)
BACKGROUND = (40, 40, 40)
# diverging control points (ColorBrewer RdBu, reversed so that + is red), from -1 to +1
_RDBU = np.array(
    [
        [5, 48, 97],
        [33, 102, 172],
        [67, 147, 195],
        [146, 197, 222],
        [209, 229, 240],
        [247, 247, 247],
        [253, 219, 199],
        [244, 165, 130],
        [214, 96, 77],
        [178, 24, 43],
        [103, 0, 31],
    ],
    np.float64,
)


def colour_scale_mm(d: np.ndarray) -> float:
    """S of the colour map in mm: the 95th percentile of |d| rounded up to 1, 2 or 5 x 10^k."""
    p95 = max(float(np.percentile(np.abs(d), 95)) * 1000.0, 1e-3)
    exponent = math.floor(math.log10(p95))
    for step in (1, 2, 5, 10):
        if step * 10.0**exponent >= p95 * (1 - 1e-9):
            return step * 10.0**exponent
    return 10.0 ** (exponent + 1)


def diverging_colours(d: np.ndarray, scale_m: float) -> np.ndarray:
    """(N, 3) uint8 RGB of signed distances, blue - white - red, saturating at +-scale_m."""
    x = np.clip(np.asarray(d, np.float64) / scale_m, -1.0, 1.0)
    stops = np.linspace(-1.0, 1.0, len(_RDBU))
    rgb = np.column_stack([np.interp(x, stops, _RDBU[:, c]) for c in range(3)])
    return np.rint(rgb).astype(np.uint8)


def splat(image: np.ndarray, uv: np.ndarray, depth: np.ndarray, colours: np.ndarray, radius: int = SPLAT_RADIUS):
    """Draw points as (2r+1)^2 squares into ``image`` in place, the nearest (smallest depth) on top
    (of equally near ones the first in scan order).

    A point's square covers pixel q when its centre pixel p is within r of q (max norm), so the
    point on top at q is the nearest of the nearest points of the centres around q: a z-buffer
    of the centres (``minimum.at``, no sort) and a (2r+1)^2 minimum filter of it. At 10 M points
    the former lexsort of the 9 x 10 M splatted pixels took a minute per image."""
    h, w = image.shape[:2]
    size_h, size_w = h + 2 * radius, w + 2 * radius  # centres up to r outside still paint the edge
    u = np.rint(uv[:, 0]).astype(np.int64) + radius
    v = np.rint(uv[:, 1]).astype(np.int64) + radius
    index = np.nonzero((u >= 0) & (u < size_w) & (v >= 0) & (v < size_h))[0]
    if index.size == 0:
        return image
    pix, z = v[index] * size_w + u[index], depth[index]
    nearest = np.full(size_h * size_w, np.inf)
    np.minimum.at(nearest, pix, z)
    first = z == nearest[pix]  # the nearest of its pixel
    winner = np.full(size_h * size_w, len(depth), np.int64)  # len(depth): no point
    np.minimum.at(winner, pix[first], index[first])
    nearest, winner = nearest.reshape(size_h, size_w), winner.reshape(size_h, size_w)
    top_z, top = np.full((h, w), np.inf), np.full((h, w), len(depth), np.int64)
    for dv in range(2 * radius + 1):
        for du in range(2 * radius + 1):
            z, i = nearest[dv : dv + h, du : du + w], winner[dv : dv + h, du : du + w]
            better = (z < top_z) | ((z == top_z) & (i < top))
            top_z, top = np.where(better, z, top_z), np.where(better, i, top)
    drawn = top < len(depth)
    image[drawn] = colours[top[drawn]]
    return image


def add_legend(image: np.ndarray, scale_mm: float, title: str = "signed distance (mm)") -> np.ndarray:
    """``image`` with a vertical colour bar and its mm scale on a panel to its right."""
    h = image.shape[0]
    width = max(130, h // 5)
    panel = np.full((h, width, 3), BACKGROUND, np.uint8)
    top, bottom = int(h * 0.12), int(h * 0.9)
    bar_x0, bar_x1 = int(width * 0.12), int(width * 0.28)
    values = np.linspace(1.0, -1.0, bottom - top) * scale_mm / 1000.0  # + at the top
    panel[top:bottom, bar_x0:bar_x1] = diverging_colours(values, scale_mm / 1000.0)[:, None, :]
    font_scale = max(0.35, h / 1400.0)
    thickness = max(1, int(round(font_scale * 1.6)))
    cv2.putText(
        panel,
        title,
        (4, int(h * 0.06)),
        cv2.FONT_HERSHEY_SIMPLEX,
        font_scale * 0.8,
        (240, 240, 240),
        thickness,
        cv2.LINE_AA,
    )
    for fraction in (1.0, 0.5, 0.0, -0.5, -1.0):
        y = int(round(top + (1.0 - fraction) / 2.0 * (bottom - top - 1)))
        value = fraction * scale_mm
        label = f"{value:+g}" if fraction else "0"
        if abs(fraction) == 1.0:
            label = (">= " if fraction > 0 else "<= ") + label  # the map saturates there
        cv2.line(panel, (bar_x1, y), (bar_x1 + 6, y), (240, 240, 240), 1)
        cv2.putText(
            panel,
            label,
            (bar_x1 + 9, y + int(5 * font_scale / 0.5)),
            cv2.FONT_HERSHEY_SIMPLEX,
            font_scale,
            (240, 240, 240),
            thickness,
            cv2.LINE_AA,
        )
    return np.hstack([image, panel])


def orthographic_image(points: np.ndarray, colours: np.ndarray, view: str, size: int = IMAGE_SIZE) -> np.ndarray:
    """A splat image of the scan seen from above (``"top"``: x right, y up, highest on top) or
    from the front (``"side"``: x right, z up, looking along +y, smallest y on top)."""
    across, up, toward = (0, 1, 2) if view == "top" else (0, 2, 1)
    lo, hi = bounding_box(points)
    extent = max(hi[across] - lo[across], hi[up] - lo[up], 1e-9)
    pixel = extent / (size - 8)
    w = int(math.ceil((hi[across] - lo[across]) / pixel)) + 8
    h = int(math.ceil((hi[up] - lo[up]) / pixel)) + 8
    uv = np.column_stack(((points[:, across] - lo[across]) / pixel + 4, (hi[up] - points[:, up]) / pixel + 4))
    depth = -points[:, toward] if view == "top" else points[:, toward]
    image = np.full((max(h, 64), w, 3), BACKGROUND, np.uint8)
    return splat(image, uv, depth, colours)


def project_to_shot(points: np.ndarray, camera):
    """Pixel positions (with lens distortion) and depths of the points in front of ``camera``."""
    cam = points @ camera.R.T + camera.t  # float64 throughout
    front = cam[:, 2] > 1e-6
    cam = cam[front]
    x, y = cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2]
    # keep the points within 1.5 image of the pinhole frame: a polynomial lens model folds back
    # far outside the field of view and would scatter them over the photo
    margin_x, margin_y = 0.75 * camera.width / camera.fx, 0.75 * camera.height / camera.fy
    cx, cy = (camera.cx - camera.width / 2) / camera.fx, (camera.cy - camera.height / 2) / camera.fy
    near = (np.abs(x + cx) < margin_x) & (np.abs(y + cy) < margin_y)
    cam = cam[near]
    uv, _ = cv2.projectPoints(cam.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), camera.K, camera.dist)
    index = np.nonzero(front)[0][near]
    return uv.reshape(-1, 2), cam[:, 2], index


def shot_images(scene: Scene, camera, photo, points, colours, scale_mm) -> dict:
    """The scan splatted over the shot's CAD render and over the photo + CAD overlay:
    ``{file name: image}`` of :data:`SHOT_IMAGES`."""
    from mrcheck.mr.overlay import overlay_images
    from mrcheck.mr.shot import render_for_photo
    from mrcheck.render.renderer import Renderer, RenderSettings

    renderer = Renderer(scene)
    try:
        renders, _, offset, maps = render_for_photo(renderer, camera, ["phong"], RenderSettings(), False)
    finally:
        renderer.release()
    uv, depth, index = project_to_shot(points, camera)
    out = {}
    for name, alpha in SHOT_IMAGES.items():
        base = overlay_images(photo, renders, camera, alpha, None, offset=offset, maps=maps)["phong"]
        out[name] = add_legend(splat(base.copy(), uv, depth, colours[index]), scale_mm)
    return out


def view_images(points: np.ndarray, colours: np.ndarray, scale_mm: float) -> dict:
    """``{file name: image}`` of :data:`VIEW_IMAGES`: the top and side splats with their legend."""
    return {name: add_legend(orthographic_image(points, colours, view), scale_mm) for view, name in VIEW_IMAGES.items()}


__all__ = [
    "colour_scale_mm",
    "diverging_colours",
    "splat",
    "add_legend",
    "orthographic_image",
    "project_to_shot",
    "shot_images",
    "view_images",
    "VIEW_IMAGES",
    "SHOT_IMAGES",
]
