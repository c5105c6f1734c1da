"""The anti-aliasing reference: a frame rendered at ``factor`` times the size and area-averaged.

The issue's yardstick for anti-aliasing (docs/rendering.md, "Anti-aliasing"): the same view
rendered without anti-aliasing at 4x4 the pixels -- the screen radius, the level-of-detail error
and the blur kernel scaled with it, so the AO is that of the same view -- and each 4x4 block
averaged in linear light. :func:`image_mae` is the error of a frame against it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.antialias import area_average, supersampled_camera
from mrcheck.render.renderer import Renderer, RenderSettings

REFERENCE_FACTOR = 4  # the 4x4 supersampled render


def supersampled_reference(
    renderer: Renderer, camera: Camera, modes, settings: RenderSettings | None = None, factor: int = REFERENCE_FACTOR
) -> dict:
    """{mode: (H, W, 3) uint8 sRGB}: ``modes`` from ``camera`` rendered at ``factor`` x ``factor``
    the pixels without anti-aliasing and area-averaged to ``camera``'s size."""
    settings = (settings or RenderSettings()).validated(camera.height)
    big = replace(
        settings,
        antialias=False,
        radius_px=settings.radius_px * factor,
        lod_px=min(settings.lod_px * factor, 4.0),
        blur_size=factor * (settings.blur_size - 1) + 1,
    )
    frame = renderer.render(supersampled_camera(camera, factor), modes, big)
    return {mode: area_average(frame[mode].image, factor) for mode in modes}


def image_mae(image: np.ndarray, reference: np.ndarray) -> float:
    """Mean absolute difference of two uint8 images, in grey levels (0-255)."""
    return float(np.abs(image.astype(np.float32) - reference.astype(np.float32)).mean())


__all__ = ["supersampled_reference", "image_mae", "REFERENCE_FACTOR"]
