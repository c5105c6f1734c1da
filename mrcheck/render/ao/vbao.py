"""Visibility-bitmask AO, VBAO (Therrien et al. 2023, section 3): GTAO's slices with a 32-sector
bitmask per slice instead of two horizons, and a surface thickness, so thin objects do not hide
what lies behind them. The math and its documented departures (cosine-weighted sectors,
stochastic distance attenuation, thickness relative to the radius) are in ``shaders/ao_vbao.glsl``.

Radius as the vector mode's (:mod:`.screen_radius`); the sample budget is split as gtao's
(:func:`.gtao.slices_and_steps`). ``settings.thickness`` is the thickness over the world
sampling radius r_S (1.0: as thick as the radius).
"""

from __future__ import annotations

from mrcheck.render.ao.gtao import GTAO


class VBAO(GTAO):
    """GTAO's slices, sample budget and radius uniforms; its own shader and the thickness."""

    shader = "ao_vbao"
    mode = "vbao"

    def _set_method_uniforms(self, settings, scale: float) -> None:
        super()._set_method_uniforms(settings, scale)
        self.program["u_thickness"] = float(settings.thickness)


__all__ = ["VBAO"]
