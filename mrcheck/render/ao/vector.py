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
from mrcheck.render.ao.kernel import stratified_kernel
from mrcheck.render.ao.screen_radius import set_screen_radius


class VectorAO(AOPass):
    shader = "ao_vector"
    mode = "vector"
    offsets = staticmethod(stratified_kernel)  # evenly spread directions: less variance (kernel.py)

    def _set_method_uniforms(self, settings, scale: float) -> None:
        set_screen_radius(self.program, settings, scale)


__all__ = ["VectorAO"]
