"""The composite: Blinn-Phong lighting with the AO modulating the ambient term
(``shaders/composite.glsl``). Phong (D1) is the same pass with the AO weight at 0.
"""

from __future__ import annotations

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.gl import GL_FRAMEBUFFER_SRGB, load_program
from mrcheck.render.settings import DEFAULT_LIGHT, DEFAULT_TONE, LIGHTS, TONES

SUN_DIRECTION = np.array([0.35, -0.25, 0.90])  # world, towards the sun: high, from one side (z up)
BACKGROUND = (0.80, 0.84, 0.88)                # linear RGB behind the scene: a pale hall grey
# the filmic tone curve of shaders/composite.glsl (tone()): exposure, knee and asymptote in linear light
TONE_CURVE = {"EXPOSURE_VALUE": 0.8, "KNEE_VALUE": 0.40, "WHITE_VALUE": 0.85}


def light_direction(camera: Camera, light: str) -> np.ndarray:
    """(3,) float unit vector towards the light, in camera space."""
    if light == "headlight":
        # slightly above and left of the camera, so faces facing the camera are not flat-lit
        d = np.array([-0.2, -0.35, -1.0])
    else:
        d = camera.R @ SUN_DIRECTION
    return d / np.linalg.norm(d)


class Composite:
    """Two program variants: AO at full resolution, or at half resolution upsampled in place
    (``shaders/ao_upsample_common.glsl``), which saves a whole full-resolution pass."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.variants = {}
        for half in (False, True):
            program = load_program(ctx, "composite", {"AO_HALF": half, **TONE_CURVE})
            names = ("u_depth", "u_normal", "u_albedo", "u_ao_half" if half else "u_ao")
            for unit, name in enumerate(names):
                program[name].value = unit
            program["u_background"].value = BACKGROUND
            self.variants[half] = (program, ctx.vertex_array(program, []))

    def run(self, target: moderngl.Framebuffer, gbuffer, ao: moderngl.Texture, camera: Camera,
            use_ao: bool, light: str = DEFAULT_LIGHT, ao_direct: bool = False,
            ao_half: bool = False, tone: str = DEFAULT_TONE) -> None:
        """Shade into ``target``; ``ao`` holds (AO, depth) texels, at half resolution when
        ``ao_half``."""
        p, vao = self.variants[ao_half]
        p["u_intrinsics"].value = (camera.fx, camera.fy, camera.cx, camera.cy)
        p["u_light_dir"].value = tuple(light_direction(camera, light))
        p["u_ao_weight"].value = 1.0 if use_ao else 0.0
        p["u_ao_direct"].value = 1.0 if ao_direct else 0.0
        p["u_tone"].value = TONES.index(tone)
        textures = [gbuffer.depth, gbuffer.normal, gbuffer.albedo, ao]
        if ao_half:
            p["u_size_half"].value = ao.size
        for unit, texture in enumerate(textures):
            texture.use(unit)
        target.use()
        self.ctx.enable_direct(GL_FRAMEBUFFER_SRGB)   # encode into the sRGB target (gl.srgb_texture)
        vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable_direct(GL_FRAMEBUFFER_SRGB)

    def release(self) -> None:
        for _, vao in self.variants.values():
            vao.release()


__all__ = ["Composite", "LIGHTS", "light_direction"]
