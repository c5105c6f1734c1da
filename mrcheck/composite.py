"""The composite: Blinn-Phong lighting with the AO modulating the ambient term
(``shaders/composite.glsl``). Phong (D1) is the same pass with the AO weight at 0.
"""

from __future__ import annotations

import moderngl
import numpy as np

from .camera import Camera
from .gl import load_program

LIGHTS = ("headlight", "sun")
SUN_DIRECTION = np.array([0.35, -0.25, 0.90])  # world, towards the sun: high, from one side (z up)
BACKGROUND = (0.80, 0.84, 0.88)                # linear RGB behind the scene: a pale hall grey


def light_direction(camera: Camera, light: str) -> np.ndarray:
    """(3,) float unit vector towards the light, in camera space."""
    if light == "headlight":
        # slightly above and left of the camera, so faces facing the camera are not flat-lit
        d = np.array([-0.2, -0.35, -1.0])
    else:
        d = camera.R @ SUN_DIRECTION
    return d / np.linalg.norm(d)


class Composite:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = load_program(ctx, "composite")
        for unit, name in enumerate(("u_depth", "u_normal", "u_albedo", "u_ao")):
            self.program[name].value = unit
        self.program["u_background"].value = BACKGROUND
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, target: moderngl.Framebuffer, gbuffer, ao: moderngl.Texture, camera: Camera,
            use_ao: bool, light: str = "headlight", ao_direct: bool = False) -> None:
        p = self.program
        p["u_intrinsics"].value = (camera.fx, camera.fy, camera.cx, camera.cy)
        p["u_light_dir"].value = tuple(light_direction(camera, light))
        p["u_ao_weight"].value = 1.0 if use_ao else 0.0
        p["u_ao_direct"].value = 1.0 if ao_direct else 0.0
        for unit, texture in enumerate((gbuffer.depth, gbuffer.normal, gbuffer.albedo, ao)):
            texture.use(unit)
        target.use()
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.vao.release()


__all__ = ["Composite", "LIGHTS", "light_direction"]
