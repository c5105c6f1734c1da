"""Anti-aliasing: a 4x multisampled G-buffer; where a pixel holds an edge, each surface in it is shaded.

Chosen by measurement (docs/rendering.md, "Anti-aliasing"), on llvmpipe: the geometry pass draws
into a 4x multisampled G-buffer (MSAA: the fragment shader runs once per pixel, at its centre,
and its values go to every sample the triangle covers; coverage and depth are per sample). The
samples sit on the standard 4x pattern, one per row and column of a 4x4 grid, which resolves
edges near the image axes -- columns, racks, the wires of mesh fences -- to a quarter pixel.

* :class:`GBufferResolve` (``shaders/gbuffer_resolve.glsl``) makes the single-sampled G-buffer
  from it: per pixel the triangle that covers most samples. The AO passes, the blur, the depth
  and normals a frame returns and the picking read that one, so the AO stays at one sample per
  pixel and costs what it costs without anti-aliasing.
* The composite shades every pixel once, as without anti-aliasing, with the resolved surface;
  its edge pass (``shaders/composite.glsl``, ``MSAA``) then adds, in the pixels whose samples are
  not all one surface, each other surface once (its own triangle's values, the AO read
  depth-aware at its first sample's position) weighted by the samples it covers, blended in
  linear light into the sRGB output: the mean of the four samples' colours.

Why not supersampling: the geometry and the composite on a 2x grid (4x the composite's pixels and a
resolve pass) cost 1.6-2.35x the frame, against 1.2-1.5x for this (docs/rendering.md).
The yardstick is :mod:`mrcheck.eval.aa_reference` (the view rendered at 4x4 the pixels, area-averaged);
its helpers live here because the reference is made of the renderer's own frames.
"""

from __future__ import annotations

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.gbuffer import GBuffer
from mrcheck.render.gl import load_program
from mrcheck.render.settings import RenderSettings

MSAA_SAMPLES = 4  # samples per pixel of the anti-aliased G-buffer (llvmpipe's maximum)
# the samples' offsets from the pixel centre (x right, y down the image): GL's standard 4x pattern,
# one sample per row and column of a 4x4 grid, as llvmpipe places them (tests/test_antialias.py
# measures them); the composite reads the AO at these positions
SAMPLE_OFFSETS = ((-0.125, -0.375), (0.375, -0.125), (-0.375, 0.125), (0.125, 0.375))


def sample_offsets_glsl() -> str:
    """:data:`SAMPLE_OFFSETS` as a GLSL ``vec2[4]`` initialiser (the composite's define)."""
    return "vec2[4](" + ", ".join(f"vec2({x!r}, {y!r})" for x, y in SAMPLE_OFFSETS) + ")"


def uses_antialiasing(settings: RenderSettings) -> bool:
    """Whether a frame of ``settings`` is anti-aliased: anti-aliasing on, and the AO at full
    resolution (half-resolution AO is a speed option; its frame stays at one sample per pixel)."""
    return settings.antialias and settings.ao_scale == 1.0


class GBufferResolve:
    """The single-sampled G-buffer from the multisampled one (``shaders/gbuffer_resolve.glsl``)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = load_program(ctx, "gbuffer_resolve", {"MSAA": MSAA_SAMPLES})
        for unit, name in enumerate(("u_packed", "u_palette")):
            self.program[name] = unit
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, multisampled: GBuffer, target: GBuffer, palette: moderngl.Texture) -> None:
        """Write ``target`` (single-sampled, with its depth buffer) from ``multisampled``, the
        packed G-buffer (:meth:`mrcheck.render.gbuffer.GBuffer.create_packed`) with the scene's
        ``palette`` of part colours."""
        for unit, texture in enumerate((multisampled.depth, palette)):
            texture.use(unit)
        target.fbo.use()
        target.frame += 1
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.depth_func = "1"  # always: every pixel's depth is written, the background's 0
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable(moderngl.DEPTH_TEST)

    def release(self) -> None:
        self.vao.release()


def supersampled_camera(camera: Camera, factor: int) -> Camera:
    """``camera`` at ``factor`` times its size, each pixel split into ``factor`` x ``factor``
    (the area-averaged reference, :func:`area_average`)."""
    return camera.resized(camera.width * factor, camera.height * factor)


def area_average(image: np.ndarray, factor: int) -> np.ndarray:
    """(H, W, 3) uint8 sRGB: the area average in linear light of each ``factor`` x ``factor``
    block of an (H * factor, W * factor, 3) uint8 sRGB image (the supersampled reference)."""
    linear = srgb_to_linear(image)
    h, w = image.shape[0] // factor, image.shape[1] // factor
    mean = linear[: h * factor, : w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    return linear_to_srgb(mean)


def srgb_to_linear(image: np.ndarray) -> np.ndarray:
    """float32 linear light of uint8 sRGB (IEC 61966-2-1)."""
    c = np.asarray(image, np.float32) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(linear: np.ndarray) -> np.ndarray:
    """uint8 sRGB of float linear light in [0, 1]."""
    c = np.clip(linear, 0.0, 1.0)
    s = np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


__all__ = [
    "MSAA_SAMPLES",
    "SAMPLE_OFFSETS",
    "sample_offsets_glsl",
    "GBufferResolve",
    "supersampled_camera",
    "uses_antialiasing",
    "area_average",
    "srgb_to_linear",
    "linear_to_srgb",
]
