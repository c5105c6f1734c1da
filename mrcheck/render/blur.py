"""Depth-aware Gaussian bilateral blur of the AO buffer (paper section 3, [Pet04a]).

Separable: a horizontal and a vertical draw of ``shaders/blur_bilateral.glsl``. The kernel
size is odd (9 and 13 are the paper's, table 2); sigma is a third of the radius so the Gaussian
has fallen to about 1 % at the kernel's edge.
"""

from __future__ import annotations

import moderngl
import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.render.gl import color_texture, load_program, uniform
from mrcheck.render.settings import (  # the rule lives with the settings
    MAX_BLUR_SIZE,
    blur_size_problem,
)


def gaussian_weights(size: int) -> np.ndarray:
    """(size // 2 + 1,) float32 one-sided Gaussian weights, centre first (unnormalised)."""
    radius = size // 2
    sigma = max(radius / 3.0, 0.5)
    return np.exp(-0.5 * (np.arange(radius + 1) / sigma) ** 2).astype(np.float32)


class BilateralBlur:
    """The two-direction blur of one kernel size (its program, weights and vertex array)."""

    def __init__(self, ctx: moderngl.Context, size: int):
        if problem := blur_size_problem(size):
            raise MrcheckError(f"blur kernel size {problem}")
        self.ctx = ctx
        self.size = size
        self.program = load_program(ctx, "blur_bilateral", {"BLUR_RADIUS": size // 2})
        uniform(self.program, "u_weights").write(gaussian_weights(size).tobytes())
        self.program["u_ao_depth"] = 0
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, source: moderngl.Texture, scratch: moderngl.Framebuffer, target: moderngl.Framebuffer) -> None:
        """Blur the AO of ``source`` into ``target`` through ``scratch`` (all RG32F (AO, depth)
        texels of one size; see ``shaders/ao_common.glsl``)."""
        self.program["u_size"] = source.size
        for step, src, dst in (((1, 0), source, scratch), ((0, 1), color_texture(scratch), target)):
            self.program["u_step"] = step
            src.use(0)
            dst.use()
            self.vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vao.release()


__all__ = ["blur_size_problem", "BilateralBlur", "gaussian_weights", "MAX_BLUR_SIZE"]
