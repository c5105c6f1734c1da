"""The screen-constant sampling radius the vector, gtao and vbao passes share.

``radius_px`` pixels at the output resolution (or a fraction of the image height); each shader
grows the world radius with depth, ``r_S = r_px * Z / f_y`` (NOTES 1), so its projection is
``r_px`` at every depth, and an optional clamp bounds the world radius (NOTES 6). NOTES n: item
n of docs/papers_notes.md.
"""

from __future__ import annotations

import moderngl

NO_CLAMP = (0.0, 3.4e38)  # world-radius limits that never bite


def set_screen_radius(program: moderngl.Program, settings, scale: float) -> None:
    """Set ``u_radius_px``, ``u_radius_clamp`` and ``u_falloff`` of a screen-radius pass.

    radius_px is at the output resolution; a half-resolution pass (``scale`` 0.5) has half the
    pixels (its f_y is halved too, so the world radius r_px * Z / f_y stays the same).
    """
    program["u_radius_px"] = float(settings.radius_px) * scale
    lo = settings.min_world_radius or NO_CLAMP[0]
    hi = settings.max_world_radius or NO_CLAMP[1]
    program["u_radius_clamp"] = (float(lo), float(hi))
    program["u_falloff"] = float(settings.falloff)


__all__ = ["NO_CLAMP", "set_screen_radius"]
