"""Vector-based SSAO (Scheer & Keutel, section 3), the paper's D2. The math is in
``shaders/ao_vector.glsl``; this module turns the user's settings into its uniforms.

The sampling radius is given on screen: ``radius_px`` pixels at the output resolution, or a
fraction of the image height. The shader grows the world radius with depth,
``r_S = r_px * Z / f_y`` (NOTES 1), so its projection is ``r_px`` at every depth; an optional
clamp bounds the world radius (NOTES 6: near the camera a screen-constant radius becomes
large in the world). NOTES n: item n of docs/papers_notes.md.
"""

from __future__ import annotations

from mrcheck.render.ao.base import AOPass

NO_CLAMP = (0.0, 3.4e38)  # world-radius limits that never bite


class VectorAO(AOPass):
    shader = "ao_vector"

    def _set_method_uniforms(self, settings, scale: float) -> None:
        p = self.program
        # radius_px is at the output resolution; a half-resolution pass has half the pixels
        # (its f_y is halved too, so the world radius r_px * Z / f_y stays the same).
        p["u_radius_px"].value = float(settings.radius_px) * scale
        lo = settings.min_world_radius or NO_CLAMP[0]
        hi = settings.max_world_radius or NO_CLAMP[1]
        p["u_radius_clamp"].value = (float(lo), float(hi))
        p["u_falloff"].value = float(settings.falloff)


__all__ = ["VectorAO"]
