"""Ground-truth-based AO, GTAO (Jimenez et al. 2016, section 4): horizon-based, cosine-weighted,
with the paper's closed-form slice integral (eq. 10). The math is in ``shaders/ao_gtao.glsl`` and
``shaders/ao_slices.glsl`` (shared with :mod:`.vbao`).

The radius is the vector mode's (:mod:`.screen_radius`): ``radius_px`` on screen, optional world
clamp, so ``mrcheck compare`` judges it against the same screen-radius reference.

``samples`` is the depth-fetch budget, split by :func:`slices_and_steps` into slices (directions
in [0, pi), each sampled on both sides of the pixel) and steps per side:
16 -> 2 x 2 x 4, 36 -> 3 x 2 x 6, 64 -> 4 x 2 x 8, 128 -> 8 x 2 x 8.
"""

from __future__ import annotations

from mrcheck.render.ao.base import AOPass
from mrcheck.render.ao.screen_radius import set_screen_radius


def slices_and_steps(samples: int) -> tuple[int, int]:
    """(slices, steps per side) for a budget of ``samples`` depth fetches (2 * slices * steps <=
    samples; at least one of each): the one place that splits it for gtao and vbao."""
    slices = 2 if samples < 32 else 3 if samples < 64 else 4 if samples < 128 else 8
    slices = max(1, min(slices, samples // 2))
    return slices, max(1, samples // (2 * slices))


class GTAO(AOPass):
    shader = "ao_gtao"
    mode = "gtao"

    def method_defines(self, samples: int) -> dict:
        slices, steps = slices_and_steps(samples)
        return {"SLICES": slices, "SLICE_STEPS": steps}

    def _set_method_uniforms(self, settings, scale: float) -> None:
        set_screen_radius(self.program, settings, scale)


__all__ = ["GTAO", "slices_and_steps"]
