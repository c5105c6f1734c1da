"""Standard SSAO (Filion & McNaughton 2008; thesis section 4.3.2), the paper's D3: a normal-
oriented hemisphere of constant camera-space radius ``radius_world`` in scene units with a
depth-delta range check. The math is in ``shaders/ao_ssao.glsl``.

Its kernel is the stratified one of the vector mode (evenly spread directions, the thesis's
lengths): the estimator is the thesis's, with less pixel-to-pixel noise than independent random
directions, so that the comparison is not won by a noisier competitor (docs/rendering.md).
"""

from __future__ import annotations

from mrcheck.render.ao.base import AOPass
from mrcheck.render.ao.kernel import stratified_kernel


class StandardSSAO(AOPass):
    shader = "ao_ssao"
    mode = "ssao"
    offsets = staticmethod(stratified_kernel)

    def _set_method_uniforms(self, settings, scale: float) -> None:
        super()._set_method_uniforms(settings, scale)  # the world radius
        self.program["u_falloff"] = float(settings.falloff)


__all__ = ["StandardSSAO"]
