"""Standard SSAO (Filion & McNaughton 2008; thesis section 4.3.2), the paper's D3: a normal-
oriented hemisphere of constant camera-space radius ``radius_world`` in scene units with a
depth-delta range check. The math is in ``shaders/ao_ssao.glsl``.
"""

from __future__ import annotations

from mrcheck.render.ao.base import AOPass


class StandardSSAO(AOPass):
    shader = "ao_ssao"
    mode = "ssao"

    def _set_method_uniforms(self, settings, scale: float) -> None:
        super()._set_method_uniforms(settings, scale)  # the world radius
        self.program["u_falloff"].value = float(settings.falloff)


__all__ = ["StandardSSAO"]
