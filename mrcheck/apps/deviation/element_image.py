"""``elements.png``: the CAD rendered with vector AO, every instance tinted by its tolerance
status, over the shot's photo when one is given, with a legend.

Colours: installed green, not found purple, not enough data light grey, occluded dark grey, out
of tolerance from orange (just over the
tolerance) to red (:data:`RED_AT` x the tolerance or more) by the size of the deviation (the
offset's length, or the residual when that is larger); the legend's bar gives the mm. The tint
multiplies the vector-AO render's brightness, so depth stays readable (AO darkens corners and
contacts). With a shot, the picture is in the photo's (distorted) geometry, blended 50 % over
it; without one, it is the scene's first viewpoint inside the scene's box, else a view that sees
the elements (:func:`overview_camera`: not from above a roof that hides them).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera

IN_COLOUR = np.array([70, 190, 90], np.float64)
FLAT_COLOURS = {  # the statuses without a deviation: one colour each
    "installed": IN_COLOUR,
    "not found": np.array([170, 70, 210], np.float64),
    "not enough data": np.array([170, 170, 170], np.float64),
    "occluded": np.array([95, 95, 95], np.float64),
}
OUT_LOW, OUT_HIGH = np.array([255, 170, 40], np.float64), np.array([220, 30, 30], np.float64)
RED_AT = 5.0  # deviation / tolerance at which the tint is fully red
PHOTO_ALPHA = 0.5
OVERVIEW_SIZE = (1024, 768)
PICK_SIZE = (160, 120)  # the candidate views' id renders: enough to count the elements each sees
BETTER_BY = 2.0
EYE_HEIGHT_M = 1.7
INSET = 0.1  # the inside views' eyes, as a fraction of the box from its corners
BACKGROUND = (40, 40, 40)


def _deviation_mm(row) -> float:
    return max(row.offset_norm_mm or 0.0, row.residual_mm or 0.0)


def status_colours(rows, tolerance_mm: float) -> np.ndarray:
    """(n, 3) float64 RGB of every row (module docstring)."""
    out = np.empty((len(rows), 3))
    for i, row in enumerate(rows):
        if row.status in FLAT_COLOURS:
            out[i] = FLAT_COLOURS[row.status]
        else:
            x = np.clip((_deviation_mm(row) / tolerance_mm - 1.0) / (RED_AT - 1.0), 0.0, 1.0)
            out[i] = OUT_LOW + x * (OUT_HIGH - OUT_LOW)
    return out


def overview_camera(scene) -> Camera:
    """The camera of the status picture without a shot: the scene's first viewpoint whose eye is
    inside the scene's box. With none inside (an imported IFC has only the computed overview,
    above the roof), the first viewpoint (else a view from above one corner of the box) unless
    a view from inside one of the box's corners at eye height sees more than
    :data:`BETTER_BY` times as many elements: from outside a building the roof hides them."""
    lo, hi = scene.bounds()
    for name in scene.viewpoints:
        camera = scene.camera(name, *OVERVIEW_SIZE)
        if _inside(camera.center, lo, hi):
            return camera
    outside = scene.camera(next(iter(scene.viewpoints)), *OVERVIEW_SIZE) if scene.viewpoints else _corner_view(lo, hi)
    inside = _inside_views(lo, hi)
    seen = [_elements_seen(scene, camera) for camera in [outside, *inside]]
    best = int(np.argmax(seen[1:]))
    return inside[best] if seen[1 + best] > BETTER_BY * seen[0] else outside


def _inside(point, lo, hi) -> bool:
    return bool(np.all(point > lo) and np.all(point < hi))


def _corner_view(lo, hi) -> Camera:
    centre, size = (lo + hi) / 2.0, hi - lo
    eye = centre + np.array([-0.6 * size[0], -0.8 * size[1], 0.5 * max(size[0], size[1])])
    return Camera.from_look_at(eye, centre, (0, 0, 1), 50.0, *OVERVIEW_SIZE)


def _inside_views(lo, hi) -> list[Camera]:
    """Views from just inside the box's four lower corners at eye height, across the box."""
    size = hi - lo
    z = lo[2] + min(EYE_HEIGHT_M, 0.5 * size[2])
    target = np.array([(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, lo[2] + 0.25 * size[2]])
    views = []
    for fx in (INSET, 1.0 - INSET):
        for fy in (INSET, 1.0 - INSET):
            eye = np.array([lo[0] + fx * size[0], lo[1] + fy * size[1], z])
            views.append(Camera.from_look_at(eye, target, (0, 0, 1), 60.0, *OVERVIEW_SIZE))
    return views


def _elements_seen(scene, camera: Camera) -> int:
    """How many instances a small render of ``camera`` shows."""
    from mrcheck.apps.discrepancies.ids import object_ids

    ids, _, _ = object_ids(scene, camera.resized(*PICK_SIZE))
    return len(np.unique(ids[ids >= 0]))


def legend(height: int, tolerance_mm: float) -> np.ndarray:
    """The legend panel: a swatch per status without a deviation, the out-of-tolerance bar in mm."""
    width = max(170, height // 4)
    panel = np.full((height, width, 3), BACKGROUND, np.uint8)
    scale = max(0.4, height / 1500.0)
    text = dict(
        fontFace=cv2.FONT_HERSHEY_SIMPLEX,
        fontScale=scale,
        color=(240, 240, 240),
        thickness=max(1, int(round(scale * 1.6))),
        lineType=cv2.LINE_AA,
    )
    y, step = int(height * 0.06), int(height * 0.06)
    for label, colour in FLAT_COLOURS.items():
        cv2.rectangle(panel, (8, y - step // 2), (8 + step // 2, y), tuple(int(c) for c in colour), -1)
        cv2.putText(panel, label, (16 + step // 2, y), **text)
        y += step
    cv2.putText(panel, "out of tolerance", (8, y), **text)
    cv2.putText(panel, "deviation (mm)", (8, y + step // 2 + 4), **text)
    top, bottom = y + step, int(height * 0.92)
    x = np.linspace(1.0, 0.0, max(bottom - top, 1))[:, None]
    panel[top:bottom, 8 : 8 + width // 6] = (OUT_LOW + x * (OUT_HIGH - OUT_LOW)).astype(np.uint8)[:, None, :]
    for fraction in (1.0, 0.5, 0.0):
        yy = int(round(top + (1.0 - fraction) * (bottom - top - 1)))
        value = tolerance_mm * (1.0 + fraction * (RED_AT - 1.0))
        label = (">= " if fraction == 1.0 else "") + f"{value:g}"
        cv2.putText(panel, label, (14 + width // 6, yy + 5), **text)
    return panel


def tinted(render: np.ndarray, ids: np.ndarray, colours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The render's brightness times each pixel's instance colour; ``(image, cad mask)``."""
    shade = render.astype(np.float64).mean(axis=2, keepdims=True) / 255.0
    cad = ids >= 0
    image = render.astype(np.float64).copy()
    image[cad] = np.clip(colours[ids[cad]] * (1.2 * shade[cad]) ** 1.5, 0, 255)  # AO darkens the tint
    return image.astype(np.uint8), cad


@dataclass(frozen=True)
class ElementPicture:
    """``elements.png`` and each row's pixel box in it (x0, y0, x1, y1; None: not seen)."""

    image: np.ndarray
    boxes: list


def pixel_boxes(ids: np.ndarray, count: int) -> list:
    """The box of each instance index 0..count-1 in an id image (-1: background); None unseen."""
    ys, xs = np.nonzero(ids >= 0)
    owner = ids[ys, xs]
    low_x, low_y = np.full(count, np.iinfo(np.int64).max), np.full(count, np.iinfo(np.int64).max)
    high_x, high_y = np.full(count, -1), np.full(count, -1)
    np.minimum.at(low_x, owner, xs)
    np.minimum.at(low_y, owner, ys)
    np.maximum.at(high_x, owner, xs)
    np.maximum.at(high_y, owner, ys)
    return [
        (int(low_x[i]), int(low_y[i]), int(high_x[i]), int(high_y[i])) if high_x[i] >= 0 else None for i in range(count)
    ]


def element_image(scene, rows, tolerance_mm: float, camera=None, photo=None) -> np.ndarray:
    """``elements.png`` (module docstring), :func:`element_picture`'s image."""
    return element_picture(scene, rows, tolerance_mm, camera, photo).image


def element_picture(scene, rows, tolerance_mm: float, camera=None, photo=None) -> ElementPicture:
    """``elements.png`` (module docstring) with the rows' boxes. ``rows`` in :func:`triangle_owners`
    order (as :func:`~mrcheck.apps.deviation.elements.element_status` returns them)."""
    from mrcheck.apps.discrepancies.ids import object_ids
    from mrcheck.mr.lens import distortion_map
    from mrcheck.mr.overlay import overlay_images
    from mrcheck.mr.shot import render_for_photo
    from mrcheck.render.renderer import Renderer, RenderSettings

    camera = overview_camera(scene) if camera is None else camera
    maps = distortion_map(camera)
    renderer = Renderer(scene)
    try:
        renders, _, offset, maps = render_for_photo(renderer, camera, ["vector"], RenderSettings(), False, maps)
    finally:
        renderer.release()
    base = np.zeros((camera.height, camera.width, 3), np.uint8) if photo is None else photo
    cad_only = overlay_images(base, renders, camera, 0.0, None, offset=offset, maps=maps)["vector"]
    ids, _, _ = object_ids(scene, camera, maps)
    image, cad = tinted(cad_only, ids, status_colours(rows, tolerance_mm))
    if photo is not None:
        blend = PHOTO_ALPHA * photo.astype(np.float64) + (1.0 - PHOTO_ALPHA) * image
        image = np.where(cad[..., None], blend, photo).astype(np.uint8)
    picture = np.hstack([image, legend(image.shape[0], tolerance_mm)])
    return ElementPicture(picture, pixel_boxes(ids, len(rows)))


__all__ = [
    "ElementPicture",
    "element_picture",
    "pixel_boxes",
    "element_image",
    "status_colours",
    "overview_camera",
    "legend",
    "tinted",
]
