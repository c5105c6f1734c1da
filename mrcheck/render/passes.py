"""The passes of one frame, one call each (:class:`FramePasses`), and what they run on: a
renderer's pass objects and the GL objects they share from frame to frame (:class:`PassCache`),
handed over as one record (:class:`RendererPasses`).

:meth:`mrcheck.render.renderer.Renderer.render` runs these passes in order; the bench times them
one at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.render.antialias import GBufferResolve
from mrcheck.render.ao import AO_METHODS, AOPass
from mrcheck.render.blur import BilateralBlur
from mrcheck.render.composite import Composite, EdgePass
from mrcheck.render.gbuffer import DrawOptions, GeometryPass
from mrcheck.render.gl import load_program, made_current, timed_ms
from mrcheck.render.settings import DEFAULT_LIGHT, DEFAULT_TONE, RenderSettings
from mrcheck.render.targets import RenderTargets


class PassCache:
    """The GL objects a renderer's passes share from frame to frame, each made on first use: the
    render targets of the current output size, the AO pass of each (mode, samples, seed,
    stride), the blur of each kernel size and the vertex array of each screen pass."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._targets: RenderTargets | None = None
        self._ao_passes: dict[tuple[str, int, int, int], AOPass] = {}
        self._blurs: dict[int, BilateralBlur] = {}
        self._screen_vaos: dict[str, moderngl.VertexArray] = {}

    def targets(self, size: tuple[int, int]) -> RenderTargets:
        """The render targets of output ``size`` (w, h); those of another size are released
        first, or they would stay allocated (a review server renders photos of many sizes)."""
        if self._targets is None or self._targets.size != tuple(size):
            if self._targets is not None:
                self._targets.release()
            self._targets = RenderTargets(self.ctx, size)
        return self._targets

    def ao(self, mode: str, settings: RenderSettings, stride: int = 1) -> AOPass:
        """The AO pass of ``mode`` compiled for ``settings``' samples and seed at ``stride``
        (2: half resolution)."""
        key = (mode, settings.samples, settings.seed, stride)
        if key not in self._ao_passes:
            self._ao_passes[key] = AO_METHODS[mode](self.ctx, settings.samples, settings.seed, stride)
        return self._ao_passes[key]

    def blur(self, size: int) -> BilateralBlur:
        """The bilateral blur of kernel ``size``."""
        if size not in self._blurs:
            self._blurs[size] = BilateralBlur(self.ctx, size)
        return self._blurs[size]

    def screen_pass(
        self,
        name: str,
        target: moderngl.Framebuffer,
        textures: Mapping[str, moderngl.Texture],
        **uniforms: object,
    ) -> None:
        """Draw the full-screen pass ``shaders/<name>.glsl`` into ``target``, each of ``textures``
        bound to its sampler uniform (units in order), ``uniforms`` set by name."""
        program = load_program(self.ctx, name)
        if name not in self._screen_vaos:
            self._screen_vaos[name] = self.ctx.vertex_array(program, [])
        for unit, (sampler, texture) in enumerate(textures.items()):
            program[sampler] = unit
            texture.use(unit)
        for key, value in uniforms.items():
            program[key] = value
        target.use()
        self._screen_vaos[name].render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        """Free every object made so far; the cache stays usable (it makes them again)."""
        for ao in self._ao_passes.values():
            ao.release()
        for blur in self._blurs.values():
            blur.release()
        for vao in self._screen_vaos.values():
            vao.release()
        self._ao_passes.clear()
        self._blurs.clear()
        self._screen_vaos.clear()
        if self._targets is not None:
            self._targets.release()
            self._targets = None


@dataclass(frozen=True)
class RendererPasses:
    """What the passes of a renderer's frames run on: its context, the geometry pass of its
    scene, anti-aliasing's resolve, the composite and the :class:`PassCache`."""

    ctx: moderngl.Context
    geometry: GeometryPass
    resolve: GBufferResolve
    composite: Composite
    cache: PassCache


class FramePasses:
    """The passes of one frame, one call each, on the targets of the camera's size: what
    :meth:`mrcheck.render.renderer.Renderer.render` runs, for timing a pass alone (the bench).

    Passes read what the ones before left: :meth:`ao` the G-buffer of :meth:`geometry` (and
    :meth:`resolve`, anti-aliased), :meth:`blur` the raw AO of :meth:`ao` at its scale,
    :meth:`composite` the AO of that scale. ``antialias``: the geometry goes into the
    multisampled G-buffer and the composite adds its edge pixels' other surfaces
    (:mod:`mrcheck.render.antialias`).
    """

    def __init__(self, passes: RendererPasses, camera: Camera, antialias: bool = False):
        self.passes = passes
        self.camera = camera
        self.ctx = passes.ctx
        self.antialias = antialias

    @property
    def targets(self) -> RenderTargets:
        """The targets of this camera's size (made again if another size came between)."""
        return self.passes.cache.targets((self.camera.width, self.camera.height))

    def timed(self, work: Callable[[], object]) -> float:
        """Milliseconds of the GL work of ``work()`` on this context (:func:`mrcheck.render.gl.timed_ms`)."""
        with made_current(self.ctx):
            return timed_ms(self.ctx, work)

    def geometry(self, options: DrawOptions = DrawOptions()) -> dict:
        """The G-buffer (anti-aliased: the multisampled one, :meth:`resolve` makes the other);
        returns the geometry pass's stats (what was drawn and culled)."""
        with made_current(self.ctx):
            gbuffer = self.targets.multisampled() if self.antialias else self.targets.gbuffer
            return self.passes.geometry.draw(gbuffer, self.camera, options)

    def resolve(self) -> None:
        """Anti-aliasing: the single-sampled G-buffer from the multisampled one."""
        with made_current(self.ctx):
            self.passes.resolve.run(
                self.targets.multisampled(), self.targets.gbuffer, self.passes.geometry.palette.texture
            )

    def ao(self, mode: str, settings: RenderSettings) -> None:
        """AO into the raw buffer of ``settings.ao_scale``: full resolution, or half resolution
        from the full-resolution G-buffer (the paper's 'Half Res.'; upsampled in the composite).
        ``settings`` must be validated for this camera (``radius_px`` resolved).

        Progressive AO (``settings.accumulate`` frames > 1): the mean of that many AO frames, each
        with its own kernel orientation and rotation tile, and each but frame 0 from a G-buffer
        drawn a sub-pixel off (:func:`subpixel_offset`): the kernel alone averages the sampling
        noise, but not the aliasing of detail finer than a pixel (a corrugated roof deck's
        crests and valleys, which each pixel centre hits by chance, an AO moire no sample count
        removes). Frame 0 is drawn last, so that the composite shades its G-buffer."""
        with made_current(self.ctx):
            buffers = self.targets.ao_buffers(settings.ao_scale)
            frames = settings.accumulate
            if frames == 1:
                self._ao_pass(mode, settings, self.camera, 0, buffers.raw[1])
                return
            stride = 1 if settings.ao_scale == 1.0 else 2
            for done, frame in enumerate([*range(1, frames), 0]):
                camera = self.camera if frame == 0 else jittered(self.camera, subpixel_offset(frame, stride))
                self._draw_gbuffer(camera, settings.lod_px, restore=frame == 0)
                self._ao_pass(mode, settings, camera, frame, buffers.raw[1])
                self._accumulate(buffers.raw[0], buffers.scratch[1], 1.0 / frames, depth=frame == 0, add=done > 0)
            # the mean back into the raw buffer, which the blur and the composite read
            self._accumulate(buffers.scratch[0], buffers.raw[1], 1.0, depth=True, add=False)

    def _draw_gbuffer(self, camera: Camera, lod_px: float, restore: bool) -> None:
        """The single-sampled G-buffer the AO reads, from ``camera``; ``restore``: the frame's own
        again (anti-aliased: resolved once more from the multisampled G-buffer, which the
        sub-pixel frames leave alone)."""
        if restore and self.antialias:
            self.resolve()
        else:
            self.passes.geometry.draw(self.targets.gbuffer, camera, DrawOptions(lod_px=lod_px))

    def _ao_pass(self, mode: str, settings: RenderSettings, camera: Camera, frame: int, target) -> None:
        """One AO pass of accumulation frame ``frame`` on the G-buffer drawn from ``camera``."""
        half = settings.ao_scale != 1.0
        ao = self.passes.cache.ao(mode, settings, stride=2 if half else 1)
        ao.use_frame(frame)
        depth, normal, _ = self.targets.gbuffer.single_sampled()
        intrinsics: tuple[float, ...] = (camera.fx, camera.fy, camera.cx, camera.cy)
        if half:
            # half-res pixel (i, j) is full-res pixel (2i, 2j): K halves exactly (ao_common.glsl)
            intrinsics = tuple(v / 2.0 for v in intrinsics)
            self.coverage()
        ao.run(target, depth, normal, intrinsics, settings, scale=settings.ao_scale)

    def _accumulate(self, source, target, weight: float, depth: bool, add: bool) -> None:
        """``weight`` times ``source``'s AO written (or, ``add``, added) into ``target``
        (shaders/ao_accumulate.glsl), with ``source``'s depth when ``depth`` (frame 0's: added to
        the zeros of the frames before, it stays exact), else none. Every texel, background
        included (its AO is 1 in every frame, so the mean is too); the G-buffer depth ``target``
        carries is neither tested nor written."""
        target.depth_mask = False
        if add:
            self.ctx.enable(moderngl.BLEND)
            self.ctx.blend_func = moderngl.ONE, moderngl.ONE
        try:
            self.passes.cache.screen_pass(
                "ao_accumulate", target, {"u_ao_depth": source}, u_weight=weight, u_depth_weight=1.0 if depth else 0.0
            )
        finally:
            self.ctx.disable(moderngl.BLEND)

    def coverage(self) -> None:
        """The half-resolution coverage depth (shaders/ao_coverage.glsl) of the current G-buffer,
        made once per G-buffer frame for every half-resolution pass of that frame: what a pass
        into a half-resolution AO buffer skips the background by."""
        with made_current(self.ctx):
            targets, gb = self.targets, self.targets.gbuffer
            coverage_fbo = targets.half_coverage_target()
            if targets.half_coverage_frame != gb.frame:
                self.ctx.enable(moderngl.DEPTH_TEST)
                self.ctx.depth_func = "1"  # always: the coverage pass writes every depth
                self.passes.cache.screen_pass("ao_coverage", coverage_fbo, {"u_depth": gb.depth})
                self.ctx.disable(moderngl.DEPTH_TEST)
                targets.half_coverage_frame = gb.frame

    def blur(self, size: int, scale: float) -> None:
        """The bilateral blur of the raw AO at ``scale`` into its blurred buffer."""
        with made_current(self.ctx):
            ao = self.targets.ao_buffers(scale)
            self.passes.cache.blur(size).run(ao.raw[0], ao.scratch[1], ao.blurred[1])

    def composite(
        self,
        scale: float,
        blurred: bool = True,
        use_ao: bool = True,
        light: str = DEFAULT_LIGHT,
        ao_direct: bool = False,
        tone: str = DEFAULT_TONE,
    ) -> None:
        """Shade into the colour target with the AO at ``scale`` (its blurred or raw buffer)."""
        with made_current(self.ctx):
            ao = self.targets.ao_buffers(scale)
            texture = ao.blurred[0] if blurred else ao.raw[0]
            edges = (
                EdgePass(
                    self.targets.multisampled(), self.passes.geometry.palette.texture, self.targets.color_edges_fbo
                )
                if self.antialias
                else None
            )
            self.passes.composite.run(
                self.targets.color_fbo,
                self.targets.gbuffer,
                texture,
                self.camera,
                use_ao=use_ao,
                light=light,
                ao_direct=ao_direct,
                ao_half=ao.half,
                tone=tone,
                edges=edges,
            )

    def scratch(self, scale: float) -> moderngl.Framebuffer:
        """The scratch AO buffer at ``scale``, with the depth buffer that skips the background (at
        half resolution the coverage of the current G-buffer is made first): where a pass of the
        caller's own (the bench's fetch floor) may draw without touching the AO of a frame."""
        if scale != 1.0:
            self.coverage()
        return self.targets.ao_buffers(scale).scratch[1]

    def read_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 sRGB of the last composite."""
        with made_current(self.ctx):
            return self.targets.read_rgb()

    def read_depth(self) -> np.ndarray:
        """(H, W) float32 linear depth of the G-buffer (scene units, 0 = background)."""
        with made_current(self.ctx):
            return self.targets.gbuffer.read_depth().copy()

    def read_normals(self) -> np.ndarray:
        """(H, W, 3) float32 unit camera-space normals of the G-buffer (OpenCV axes, facing the
        camera; zero on the background)."""
        with made_current(self.ctx):
            return self.targets.read_normals()

    def read_ao(self, scale: float, blurred: bool) -> np.ndarray:
        """(H, W) float32 AO at the output resolution; half-resolution AO is upsampled first."""
        with made_current(self.ctx):
            ao = self.targets.ao_buffers(scale)
            texture = ao.blurred[0] if blurred else ao.raw[0]
            if ao.half:
                self.passes.cache.screen_pass(
                    "ao_upsample",
                    self.targets.full.scratch[1],
                    {"u_ao_half": texture, "u_depth_full": self.targets.gbuffer.depth},
                    u_size_half=texture.size,
                )
                texture = self.targets.full.scratch[0]
            w, h = self.targets.size
            return np.frombuffer(texture.read(), np.float32).reshape(h, w, 2)[..., 0].copy()


def subpixel_offset(frame: int, stride: int = 1) -> tuple[float, float]:
    """Accumulation frame ``frame``'s offset of the image, pixels: the Halton (2, 3) sequence
    centred on the pixel (frame 0 none), spread over the AO texel's footprint (``stride`` full
    pixels: half-resolution AO reads one full pixel of each 2x2)."""
    if frame == 0:
        return 0.0, 0.0
    return stride * (_halton(frame, 2) - 0.5), stride * (_halton(frame, 3) - 0.5)


def _halton(index: int, base: int) -> float:
    result, scale = 0.0, 1.0
    while index:
        scale /= base
        index, digit = divmod(index, base)
        result += digit * scale
    return result


def jittered(camera: Camera, offset: tuple[float, float]) -> Camera:
    """``camera`` with its image moved by ``offset`` pixels (the principal point shifted)."""
    K = camera.K.copy()
    K[0, 2] += offset[0]
    K[1, 2] += offset[1]
    return replace(camera, K=K)


__all__ = ["FramePasses", "PassCache", "RendererPasses", "subpixel_offset", "jittered"]
