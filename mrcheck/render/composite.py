"""The composite: Blinn-Phong lighting with the AO modulating the ambient term
(``shaders/composite.glsl``). Phong (D1) is the same pass with the AO weight at 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.antialias import sample_offsets_glsl
from mrcheck.render.ao.base import set_if_present
from mrcheck.render.gbuffer import GBuffer
from mrcheck.render.gl import GL_FRAMEBUFFER_SRGB, load_program
from mrcheck.render.settings import DEFAULT_LIGHT, DEFAULT_TONE, LIGHTS, TONES

SUN_DIRECTION = np.array([0.35, -0.25, 0.90])  # world, towards the sun: high, from one side (z up)
BACKGROUND = (0.80, 0.84, 0.88)  # linear RGB behind the scene: a pale hall grey
EDGE_PASS_DEPTH = 0.75  # between a surface's 0.5 and an edge pixel's 1 (shaders/gbuffer_resolve.glsl)


@dataclass
class EdgePass:
    """What anti-aliasing's edge pass reads and writes: the multisampled G-buffer, the scene's
    palette of part colours, and the colour target with the resolved depth buffer, whose
    values mark the edge pixels (:mod:`mrcheck.render.antialias`)."""

    multisampled: GBuffer  # packed (GBuffer.create_packed)
    palette: moderngl.Texture
    target: moderngl.Framebuffer


# the Blinn-Phong weights of shaders/composite.glsl: colour = albedo * (AMBIENT * ao + DIFFUSE * max(n . l, 0))
# + specular (the discrepancy detector relights the planned render with them: mrcheck/apps/discrepancies/light.py)
SHADING = {"AMBIENT_VALUE": 0.60, "DIFFUSE_VALUE": 0.45}
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
    """Program variants: AO at full resolution, or at half resolution upsampled in place
    (``shaders/ao_upsample_common.glsl``), which saves a whole full-resolution pass; and
    anti-aliasing's edge pass, which adds the other surfaces of the edge pixels from the
    multisampled G-buffer (:mod:`mrcheck.render.antialias`), made on first use."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.variants: dict[tuple[bool, bool], tuple[moderngl.Program, moderngl.VertexArray]] = {}
        for half in (False, True):
            self._variant(half, False)

    def _variant(self, half: bool, msaa: bool) -> tuple[moderngl.Program, moderngl.VertexArray]:
        if (half, msaa) not in self.variants:
            defines: dict[str, object] = {"AO_HALF": half, "MSAA": msaa, **TONE_CURVE, **SHADING}
            if msaa:
                defines.update(SCREEN_DEPTH=EDGE_PASS_DEPTH, SAMPLE_OFFSETS=sample_offsets_glsl())
            program = load_program(self.ctx, "composite", defines)
            names = ("u_depth", "u_normal", "u_albedo", "u_ao_half" if half else "u_ao", "u_packed", "u_palette")
            for unit, name in enumerate(names):
                set_if_present(program, name, unit)  # each variant reads some of them
            set_if_present(program, "u_background", BACKGROUND)
            self.variants[half, msaa] = (program, self.ctx.vertex_array(program, []))
        return self.variants[half, msaa]

    def run(
        self,
        target: moderngl.Framebuffer,
        gbuffer: GBuffer,
        ao: moderngl.Texture,
        camera: Camera,
        use_ao: bool,
        light: str = DEFAULT_LIGHT,
        ao_direct: bool = False,
        ao_half: bool = False,
        tone: str = DEFAULT_TONE,
        edges: EdgePass | None = None,
    ) -> None:
        """Shade into ``target``; ``ao`` holds (AO, depth) texels, at half resolution when
        ``ao_half``; ``edges``: anti-aliased, then the edge pixels' other surfaces blended on."""
        normal, albedo = gbuffer.normal, gbuffer.albedo
        if normal is None or albedo is None:
            raise ValueError("the composite shades a single-sampled G-buffer (the multisampled one packs its normals)")
        textures = [gbuffer.depth, normal, albedo, ao]
        if edges is not None:
            textures += [edges.multisampled.depth, edges.palette]
        for unit, texture in enumerate(textures):
            texture.use(unit)
        self.ctx.enable_direct(GL_FRAMEBUFFER_SRGB)  # encode into the sRGB target (gl.srgb_texture)
        uniforms: dict[str, object] = {
            "u_intrinsics": (camera.fx, camera.fy, camera.cx, camera.cy),
            "u_light_dir": tuple(light_direction(camera, light)),
            "u_ao_weight": 1.0 if use_ao else 0.0,
            "u_ao_direct": 1.0 if ao_direct else 0.0,
            "u_tone": TONES.index(tone),
        }
        if ao_half:
            uniforms["u_size_half"] = ao.size
        variants: list[tuple[bool, moderngl.Framebuffer]] = [(False, target)] + (
            [(True, edges.target)] if edges is not None else []
        )
        for msaa, fbo in variants:
            p, vao = self._variant(ao_half, msaa)
            for name, value in uniforms.items():
                set_if_present(p, name, value)
            fbo.use()
            if msaa:  # only where the depth buffer marks an edge pixel (shaders/gbuffer_resolve.glsl)
                fbo.depth_mask = False
                self.ctx.enable(moderngl.DEPTH_TEST | moderngl.BLEND)
                self.ctx.depth_func = "<"
                # colour: the other surfaces' share plus the first pass's times its share (alpha);
                # separate colour and alpha factors, which moderngl takes though its stubs allow two
                self.ctx.blend_func = moderngl.ONE, moderngl.SRC_ALPHA, moderngl.ZERO, moderngl.ONE  # type: ignore[assignment]
            vao.render(moderngl.TRIANGLES, vertices=3)
            self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self.ctx.disable_direct(GL_FRAMEBUFFER_SRGB)

    def release(self) -> None:
        for _, vao in self.variants.values():
            vao.release()


__all__ = ["Composite", "EdgePass", "LIGHTS", "light_direction"]
