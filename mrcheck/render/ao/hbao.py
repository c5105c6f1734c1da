"""Horizon-based AO (Bavoil & Sainz 2008; Puri section 2.4): per pixel, directions in the image
plane rotated by the 4x4 tile, steps along each up to the projected world radius
``radius_world * f_y / Z``, horizon angle against tangent angle, W(r) = 1 - r^2 / R^2. The math
is in ``shaders/ao_hbao.glsl``.

``samples`` is the depth-fetch budget: 4 directions below 64 samples, 8 from 64 on, and
``samples // directions`` steps each (16 -> 4 x 4, 36 -> 4 x 9, 64 -> 8 x 8, 128 -> 8 x 16).
The sphere kernel is not used (the shader does not declare it live).
"""

from __future__ import annotations

from mrcheck.render.ao.base import AOPass


def directions_and_steps(samples: int) -> tuple[int, int]:
    """(directions, steps per direction) for a budget of ``samples`` fetches: the one place that
    splits it (the shader is compiled with the result as HBAO_DIRS and HBAO_STEPS)."""
    dirs = 8 if samples >= 64 else 4 if samples >= 4 else samples
    return dirs, samples // dirs


class HBAO(AOPass):
    shader = "ao_hbao"
    mode = "hbao"

    def method_defines(self, samples: int) -> dict:
        dirs, steps = directions_and_steps(samples)
        return {"HBAO_DIRS": dirs, "HBAO_STEPS": steps}


__all__ = ["HBAO", "directions_and_steps"]
