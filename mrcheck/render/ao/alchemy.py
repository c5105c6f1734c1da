"""Alchemy AO (McGuire et al. 2011; Puri section 2.5): samples on a disk of world radius
``radius_world`` parallel to the image plane, projected to ``radius_world * f_y / Z`` pixels,
and the paper's estimator with sigma = ``intensity``, k = 1, beta = 1e-4, eps = 1e-4 (the
constants and the unit choice are explained in ``shaders/ao_alchemy.glsl``).

Kernel: ``samples`` points uniform on the unit disk (z = 0): stratified radii sqrt((i + u) / N)
on a golden-angle spiral with a seeded random start, rotated per pixel by the 4x4 tile.
"""

from __future__ import annotations

import numpy as np

from mrcheck.render.ao import kernel
from mrcheck.render.ao.base import AOPass

GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def disk_kernel(samples: int, seed: kernel.Seed = 0) -> np.ndarray:
    """(samples, 3) float32 points uniform on the unit disk, z = 0."""
    rng = np.random.default_rng(seed)
    i = np.arange(samples)
    radius = np.sqrt((i + rng.random(samples)) / samples)
    angle = rng.random() * 2.0 * np.pi + GOLDEN_ANGLE * i
    out = np.zeros((samples, 3), np.float32)
    out[:, 0], out[:, 1] = radius * np.cos(angle), radius * np.sin(angle)
    return out


class AlchemyAO(AOPass):
    shader = "ao_alchemy"
    mode = "alchemy"
    offsets = staticmethod(disk_kernel)


__all__ = ["AlchemyAO", "disk_kernel"]
