"""The render targets of one output size: the G-buffer, the AO buffers at full and half
resolution, the half-resolution coverage depth and the sRGB colour target, reused frame to frame."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import moderngl
import numpy as np

from mrcheck.render.antialias import MSAA_SAMPLES
from mrcheck.render.gbuffer import GBuffer
from mrcheck.render.gl import float_depth_texture, srgb_texture


@dataclass
class AOBuffers:
    """The AO buffers of one AO resolution: (texture, framebuffer) x 3 -- raw, scratch, blurred --
    of RG32F (AO, depth) texels (``shaders/ao_common.glsl``); ``half``: at half the output size."""

    buffers: list[tuple[moderngl.Texture, moderngl.Framebuffer]]
    half: bool

    @property
    def raw(self) -> tuple[moderngl.Texture, moderngl.Framebuffer]:
        return self.buffers[0]

    @property
    def scratch(self) -> tuple[moderngl.Texture, moderngl.Framebuffer]:
        return self.buffers[1]

    @property
    def blurred(self) -> tuple[moderngl.Texture, moderngl.Framebuffer]:
        return self.buffers[2]


def _ao_target(
    ctx: moderngl.Context, size: tuple[int, int], zbuffer: moderngl.Texture | None = None
) -> tuple[moderngl.Texture, moderngl.Framebuffer]:
    """RG32F (AO, depth) texels: what the AO passes and the blur write (ao_common.glsl)."""
    texture = ctx.texture(size, 2, dtype="f4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    texture.repeat_x = texture.repeat_y = False  # gathers at the border clamp, not wrap
    return texture, ctx.framebuffer([texture], zbuffer)


@dataclass
class _HalfResolution:
    """The half-resolution AO buffers and their depth buffer, the coverage depth."""

    ao: AOBuffers
    coverage: moderngl.Texture
    coverage_fbo: moderngl.Framebuffer


class RenderTargets:
    """Render targets of one output size. The full-resolution AO buffers carry the G-buffer's
    depth buffer, so that the AO passes skip the background (mrcheck.render.ao.base.draw_covered;
    the blur and composite never depth-test); the half-resolution ones, made on first use,
    carry the half-resolution coverage (shaders/ao_coverage.glsl), which plays that part there."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]):
        w, h = size
        self.ctx = ctx
        self.size = (w, h)
        self.half_size = ((w + 1) // 2, (h + 1) // 2)
        self.gbuffer = GBuffer.create(ctx, self.size)
        self.full = AOBuffers([_ao_target(ctx, self.size, self.gbuffer.zbuffer) for _ in range(3)], False)
        self.color = srgb_texture(ctx, self.size)
        self.color_fbo = ctx.framebuffer([self.color])
        # anti-aliasing's edge pass: the colour target, depth-tested against the resolved G-buffer's
        # depth buffer, which marks the edge pixels (shaders/gbuffer_resolve.glsl)
        self.color_edges_fbo = ctx.framebuffer([self.color], self.gbuffer.zbuffer)
        self._half: _HalfResolution | None = None
        self._multisampled: GBuffer | None = None
        self.half_coverage_frame = -1  # the G-buffer frame the coverage was made from

    def ao_buffers(self, scale: float) -> AOBuffers:
        """The AO buffers (raw, scratch, blurred) of the AO resolution ``scale`` (1.0 or 0.5)."""
        return self.full if scale == 1.0 else self._half_resolution().ao

    def half_coverage_target(self) -> moderngl.Framebuffer:
        """The framebuffer of the half-resolution coverage depth (shaders/ao_coverage.glsl)."""
        return self._half_resolution().coverage_fbo

    def _half_resolution(self) -> _HalfResolution:
        if self._half is None:
            coverage = float_depth_texture(self.ctx, self.half_size)
            coverage_fbo = self.ctx.framebuffer([], coverage)
            ao = AOBuffers([_ao_target(self.ctx, self.half_size, coverage) for _ in range(3)], True)
            self._half = _HalfResolution(ao, coverage, coverage_fbo)
        return self._half

    def multisampled(self) -> GBuffer:
        """The multisampled G-buffer of anti-aliased frames (:mod:`mrcheck.render.antialias`), made on first use."""
        if self._multisampled is None:
            self._multisampled = GBuffer.create_packed(self.ctx, self.size, MSAA_SAMPLES)
        return self._multisampled

    def read_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 sRGB of the colour target."""
        w, h = self.size
        rgba = np.frombuffer(self.color.read(), np.uint8).reshape(h, w, 4)
        return rgba[..., :3].copy()

    def read_normals(self) -> np.ndarray:
        """(H, W, 3) float32 unit camera-space normals of the G-buffer (OpenCV axes, facing the
        camera; zero on the background)."""
        w, h = self.size
        _, normal_texture, _ = self.gbuffer.single_sampled()
        normal = np.frombuffer(normal_texture.read(), np.float16).reshape(h, w * 4)
        # OpenCV's half-to-float conversion and channel drop (SIMD): 0.2 ms at 640x480, where
        # numpy's astype of the strided view took 2.4 ms (a video frame has one or two renders)
        return cv2.cvtColor(cv2.multiply(normal, 1.0, dtype=cv2.CV_32F).reshape(h, w, 4), cv2.COLOR_RGBA2RGB)

    def release(self) -> None:
        self.gbuffer.release()
        if self._multisampled is not None:
            self._multisampled.release()
        ao = self.full.buffers + (self._half.ao.buffers if self._half is not None else [])
        objects: list[moderngl.Framebuffer | moderngl.Texture] = [fbo for _, fbo in ao]
        objects += [texture for texture, _ in ao]
        if self._half is not None:
            objects += [self._half.coverage_fbo, self._half.coverage]
        for obj in [*objects, self.color_edges_fbo, self.color_fbo, self.color]:
            obj.release()


__all__ = ["RenderTargets", "AOBuffers"]
