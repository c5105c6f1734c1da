"""Anti-aliasing: the geometry and the composite supersampled 2x2, the AO at the output resolution.

Chosen by measurement (docs/rendering.md, "Anti-aliasing"): against a 4x4 supersampled render,
a 2x G-buffer and composite resolved by an area average in linear light
(``shaders/aa_resolve.glsl``) resolves silhouettes and the sub-pixel wires of mesh fences, which a
morphological post filter cannot (it only smooths edges it can see at one sample per pixel). The
AO runs once per output pixel: it is the half-resolution AO of the supersampled G-buffer
(``ao_scale`` 0.5 of it, :mod:`mrcheck.render.ao.base`), upsampled depth-aware per sample in the
composite, so the AO pass, its blur and its radius in output pixels stay as without
anti-aliasing and only the geometry and composite passes see four times the pixels.

The supersampled grid holds the output's pixel centres (:func:`aa_camera`): sample (2i, 2j)
is output pixel (i, j)'s centre, samples (2i +- 1, 2j +- 1) lie on its edges and corners. The
resolve integrates the pixel's area by the trapezoid rule, weights (1/4, 1/2, 1/4) along each
axis (a tent over the pixel, edge samples shared with the neighbours). So what a frame returns
besides its image -- the AO, depth and normals of sample (2i, 2j) -- is exactly at the pixel
centres, where the ray-traced reference and every consumer of a depth map expect it (a depth
read a quarter pixel off the centre puts a grazing floor's point under the surface).
"""

from __future__ import annotations

from dataclasses import replace

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.gl import GL_FRAMEBUFFER_SRGB, load_program, srgb_texture
from mrcheck.render.settings import RenderSettings

AA_FACTOR = 2   # samples per output pixel along each axis


def supersampled_camera(camera: Camera, factor: int = AA_FACTOR) -> Camera:
    """``camera`` at ``factor`` times its size, each pixel split into ``factor`` x ``factor``
    (the area-averaged reference, :func:`area_average`)."""
    return camera.resized(camera.width * factor, camera.height * factor)


def aa_camera(camera: Camera) -> Camera:
    """The anti-aliasing grid: sample (k, l) at output coordinate (k / 2, l / 2), so even samples
    are the output's pixel centres (OpenCV: centres at integers), odd ones its pixel edges."""
    K = camera.K.copy()
    K[:2] *= AA_FACTOR
    return Camera(camera.width * AA_FACTOR, camera.height * AA_FACTOR, K, camera.R, camera.t, camera.dist)


def aa_settings(settings: RenderSettings) -> RenderSettings:
    """``settings`` (validated, ``radius_px`` resolved) for :func:`aa_camera`: the screen radius
    and the level-of-detail error in its pixels, the AO at half its size (the output's)."""
    return replace(settings, radius_px=settings.radius_px * AA_FACTOR, lod_px=settings.lod_px * AA_FACTOR,
                   ao_scale=0.5, antialias=False)


def uses_supersampling(settings: RenderSettings) -> bool:
    """Whether a frame of ``settings`` is supersampled: anti-aliasing on, and the AO at full
    resolution (half-resolution AO is a speed option; its frame stays at one sample per pixel)."""
    return settings.antialias and settings.ao_scale == 1.0


class Resolve:
    """The resolve pass (``shaders/aa_resolve.glsl``) into an output-size sRGB target of its own."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = load_program(ctx, "aa_resolve")
        self.program["u_color"].value = 0
        self.vao = ctx.vertex_array(self.program, [])
        self.color = self.fbo = None

    def run(self, source: moderngl.Texture) -> None:
        """Resolve ``source`` (the sRGB composite on :func:`aa_camera`'s grid) into the output target."""
        size = (source.size[0] // AA_FACTOR, source.size[1] // AA_FACTOR)
        if self.color is None or self.color.size != size:
            self._release_target()
            self.color = srgb_texture(self.ctx, size)
            self.fbo = self.ctx.framebuffer([self.color])
        source.use(0)
        self.fbo.use()
        self.ctx.enable_direct(GL_FRAMEBUFFER_SRGB)
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.disable_direct(GL_FRAMEBUFFER_SRGB)

    def read_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 sRGB of the last resolve."""
        w, h = self.color.size
        return np.frombuffer(self.color.read(), np.uint8).reshape(h, w, 4)[..., :3].copy()

    def _release_target(self) -> None:
        for obj in (self.fbo, self.color):
            if obj is not None:
                obj.release()
        self.color = self.fbo = None

    def release(self) -> None:
        self._release_target()
        self.vao.release()


def area_average(image: np.ndarray, factor: int) -> np.ndarray:
    """(H, W, 3) uint8 sRGB: the area average in linear light of each ``factor`` x ``factor``
    block of an (H * factor, W * factor, 3) uint8 sRGB image (the supersampled reference)."""
    linear = srgb_to_linear(image)
    h, w = image.shape[0] // factor, image.shape[1] // factor
    mean = linear[:h * factor, :w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
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


__all__ = ["AA_FACTOR", "Resolve", "aa_camera", "aa_settings", "supersampled_camera", "uses_supersampling",
           "area_average", "srgb_to_linear", "linear_to_srgb"]
