"""The renderer: one public :meth:`Renderer.render` that runs the passes in order.

geometry (G-buffer; anti-aliased: multisampled, then resolved to one sample per pixel)
-> AO (full or half resolution [-> depth-aware upsampling]) -> bilateral blur (optional)
-> composite (Blinn-Phong, AO on the ambient term; anti-aliased: edge pixels' other surfaces added).

One G-buffer serves every mode of a frame, so ``--mode all`` draws the geometry once. What a
caller needs of a frame comes back in its :class:`Frame` (images, AO, depth, normals); the passes
one at a time, for timing them alone, are :meth:`Renderer.passes`.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.render.antialias import GBufferResolve, uses_antialiasing
from mrcheck.render.ao import AO_METHODS
from mrcheck.render.blur import BilateralBlur
from mrcheck.render.composite import Composite, EdgePass
from mrcheck.render.gbuffer import PALETTE_MAX, DrawOptions, GeometryPass, check_camera_outside
from mrcheck.render.gl import create_context, load_program, made_current, timed_ms
from mrcheck.render.settings import (  # re-exported: the names callers have imported from here
    DEFAULT_BLUR_SIZE,
    DEFAULT_FALLOFF,
    DEFAULT_LIGHT,
    DEFAULT_LOD_PX,
    DEFAULT_RADIUS_FRACTION,
    DEFAULT_RADIUS_WORLD,
    DEFAULT_SAMPLES,
    DEFAULT_TONE,
    MODES,
    STUDY_LABELS,
    RenderSettings,
    check_screen_radius,
)
from mrcheck.render.targets import AOBuffers, RenderTargets
from mrcheck.scene.model import Scene


@dataclass
class RenderResult:
    """Images of one mode. ``image``: (H, W, 3) uint8 sRGB; ``ao``: (H, W) float32 or None."""

    mode: str
    image: np.ndarray
    ao: np.ndarray | None = None
    timings_ms: dict = field(default_factory=dict)


@dataclass(eq=False)
class Frame(Mapping):
    """What :meth:`Renderer.render` returns: the :class:`RenderResult` of each mode by name (a
    read-only mapping, ``frame["vector"]``), and what the modes of the frame share.

    depth : (H, W) float32 linear camera-space depth (scene units, 0 = background).
    normals : (H, W, 3) float32 unit camera-space normals (OpenCV axes, facing the camera; zero
        on the background), or None unless ``want_normals``.
    """

    results: dict
    depth: np.ndarray
    normals: np.ndarray | None = None

    def __getitem__(self, mode: str) -> RenderResult:
        return self.results[mode]

    def __iter__(self):
        return iter(self.results)

    def __len__(self) -> int:
        return len(self.results)


class FramePasses:
    """The passes of one frame of a :class:`Renderer`, one call each, on the renderer's targets of
    the camera's size: what :meth:`Renderer.render` runs, for timing a pass alone (the bench).

    Passes read what the ones before left: :meth:`ao` the G-buffer of :meth:`geometry` (and
    :meth:`resolve`, anti-aliased), :meth:`blur` the raw AO of :meth:`ao` at its scale,
    :meth:`composite` the AO of that scale. ``antialias``: the geometry goes into the
    multisampled G-buffer and the composite adds its edge pixels' other surfaces
    (:mod:`mrcheck.render.antialias`).
    """

    def __init__(self, renderer: "Renderer", camera: Camera, antialias: bool = False):
        self.renderer = renderer
        self.camera = camera
        self.ctx = renderer.ctx
        self.antialias = antialias

    @property
    def targets(self) -> RenderTargets:
        """The renderer's targets of this camera's size (made again if another size came between)."""
        return self.renderer._targets_for((self.camera.width, self.camera.height))

    def timed(self, work) -> float:
        """Milliseconds of the GL work of ``work()`` on this context (:func:`mrcheck.render.gl.timed_ms`)."""
        with made_current(self.ctx):
            return timed_ms(self.ctx, work)

    def geometry(self, options: DrawOptions = DrawOptions()) -> dict:
        """The G-buffer (anti-aliased: the multisampled one, :meth:`resolve` makes the other);
        returns the geometry pass's stats (what was drawn and culled)."""
        with made_current(self.ctx):
            gbuffer = self.targets.multisampled() if self.antialias else self.targets.gbuffer
            return self.renderer.geometry.draw(gbuffer, self.camera, options)

    def resolve(self) -> None:
        """Anti-aliasing: the single-sampled G-buffer from the multisampled one."""
        with made_current(self.ctx):
            self.renderer.gbuffer_resolve.run(
                self.targets.multisampled(), self.targets.gbuffer, self.renderer.geometry.palette.texture
            )

    def ao(self, mode: str, settings: RenderSettings) -> None:
        """AO into the raw buffer of ``settings.ao_scale``: full resolution, or half resolution
        from the full-resolution G-buffer (the paper's 'Half Res.'; upsampled in the composite).
        ``settings`` must be validated for this camera (``radius_px`` resolved)."""
        with made_current(self.ctx):
            half = settings.ao_scale != 1.0
            ao = self.renderer._ao(mode, settings, stride=2 if half else 1)
            gb = self.targets.gbuffer
            intrinsics = (self.camera.fx, self.camera.fy, self.camera.cx, self.camera.cy)
            if half:
                # half-res pixel (i, j) is full-res pixel (2i, 2j): K halves exactly (ao_common.glsl)
                intrinsics = tuple(v / 2.0 for v in intrinsics)
                self.coverage()
            ao.run(
                self.targets.ao_buffers(settings.ao_scale).raw[1],
                gb.depth,
                gb.normal,
                intrinsics,
                settings,
                scale=settings.ao_scale,
            )

    def coverage(self) -> None:
        """The half-resolution coverage depth (shaders/ao_coverage.glsl) of the current G-buffer,
        made once per G-buffer frame for every half-resolution pass of that frame: what a pass
        into a half-resolution AO buffer skips the background by."""
        with made_current(self.ctx):
            targets, gb = self.targets, self.targets.gbuffer
            targets.ao_buffers(0.5)
            if targets.half_coverage_frame != gb.frame:
                self.ctx.enable(moderngl.DEPTH_TEST)
                self.ctx.depth_func = "1"  # always: the coverage pass writes every depth
                self.renderer._screen_pass("ao_coverage", targets.half_coverage_fbo, {"u_depth": gb.depth})
                self.ctx.disable(moderngl.DEPTH_TEST)
                targets.half_coverage_frame = gb.frame

    def blur(self, size: int, scale: float) -> None:
        """The bilateral blur of the raw AO at ``scale`` into its blurred buffer."""
        with made_current(self.ctx):
            ao = self.targets.ao_buffers(scale)
            self.renderer._blur(size).run(ao.raw[0], ao.scratch[1], ao.blurred[1])

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
                    self.targets.multisampled(), self.renderer.geometry.palette.texture, self.targets.color_edges_fbo
                )
                if self.antialias
                else None
            )
            self.renderer.composite.run(
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
        with made_current(self.ctx):
            return self.targets.read_normals()

    def read_ao(self, scale: float, blurred: bool) -> np.ndarray:
        """(H, W) float32 AO at the output resolution; half-resolution AO is upsampled first."""
        with made_current(self.ctx):
            ao = self.targets.ao_buffers(scale)
            texture = ao.blurred[0] if blurred else ao.raw[0]
            if ao.half:
                self.renderer._screen_pass(
                    "ao_upsample",
                    self.targets.full.scratch[1],
                    {"u_ao_half": texture, "u_depth_full": self.targets.gbuffer.depth},
                    u_size_half=texture.size,
                )
                texture = self.targets.full.scratch[0]
            w, h = self.targets.size
            return np.frombuffer(texture.read(), np.float32).reshape(h, w, 2)[..., 0].copy()


class Renderer:
    """Renders one scene from calibrated cameras, headless.

    >>> renderer = Renderer(load_scene("scene.toml"))          # doctest: +SKIP
    >>> frame = renderer.render(camera, ["phong", "vector"])     # doctest: +SKIP
    >>> frame["vector"].image, frame.depth                       # doctest: +SKIP
    """

    def __init__(self, scene: Scene, ctx: moderngl.Context | None = None):
        self._owns_ctx = ctx is None
        self.ctx = ctx or create_context()
        self.scene = scene
        self._targets: RenderTargets | None = None
        self._ao_passes = {}
        self._blurs = {}
        self._screen_vaos = {}
        self._warned_palette = False
        # every public entry point makes this renderer's context current (see made_current)
        with made_current(self.ctx):
            self.geometry = GeometryPass(self.ctx, scene)
            self.composite = Composite(self.ctx)
            self.gbuffer_resolve = GBufferResolve(self.ctx)  # anti-aliasing (mrcheck.render.antialias)
            self.max_size = int(self.ctx.info["GL_MAX_TEXTURE_SIZE"])

    # -- public ----------------------------------------------------------------------------
    def render(
        self,
        camera: Camera,
        modes,
        settings: RenderSettings | None = None,
        want_ao: bool = False,
        want_normals: bool = False,
    ) -> Frame:
        """Render ``modes`` (subset of :data:`MODES`) from ``camera``; geometry drawn once.
        ``want_ao``: each AO mode's AO at the output resolution in its result (phong: ones);
        ``want_normals``: the G-buffer's normals in the frame (its depth is always there)."""
        settings = (settings or RenderSettings()).validated(camera.height)
        unknown = [m for m in modes if m not in MODES]
        if unknown:
            raise MrcheckError(f"unknown mode(s) {', '.join(unknown)} (use {', '.join(MODES)})")
        if max(camera.width, camera.height) > self.max_size:
            raise MrcheckError(f"image size {camera.width}x{camera.height} exceeds this GPU's limit of {self.max_size}")
        antialias = uses_antialiasing(settings) and self._palette_fits()
        with made_current(self.ctx):
            passes = self.passes(camera, antialias)
            timings = {"geometry": passes.timed(lambda: passes.geometry(DrawOptions(lod_px=settings.lod_px)))}
            if antialias:
                timings["resolve"] = passes.timed(passes.resolve)
            check_camera_outside(self.geometry, passes.targets.gbuffer, camera, self.scene.source)
            results = {mode: self._render_mode(passes, mode, settings, want_ao, timings) for mode in modes}
            normals = passes.read_normals() if want_normals else None
            return Frame(results, passes.read_depth(), normals)

    def _palette_fits(self) -> bool:
        """Whether the anti-aliased G-buffer can tell the scene's part colours apart; if not,
        frames are rendered without anti-aliasing, with a warning once per renderer."""
        if not self.geometry.palette.fits and not self._warned_palette:
            warnings.warn(
                f"{self.scene.source}: {len(self.geometry.palette.index)} distinct part colours, more than "
                f"anti-aliasing's {PALETTE_MAX}: rendered without anti-aliasing",
                MrcheckWarning,
                stacklevel=3,
            )
            self._warned_palette = True
        return self.geometry.palette.fits

    def passes(self, camera: Camera, antialias: bool = False) -> FramePasses:
        """The passes of a frame from ``camera``, one at a time (see :class:`FramePasses`)."""
        return FramePasses(self, camera, antialias)

    def release(self) -> None:
        """Free every GL object this renderer made; the context too when it created it. A second
        call does nothing (moderngl skips released objects; the bench's stages share renderers).
        The compiled programs belong to the context's program cache (:func:`mrcheck.render.gl.load_program`),
        shared by every renderer on it, and go with the context."""
        with made_current(self.ctx):
            for obj in [
                *self._ao_passes.values(),
                *self._blurs.values(),
                *self._screen_vaos.values(),
                self.composite,
                self.geometry,
            ]:
                obj.release()
            self._ao_passes.clear()
            self._blurs.clear()
            self._screen_vaos.clear()
            self.gbuffer_resolve.release()
            if self._targets is not None:
                self._targets.release()
                self._targets = None
        if self._owns_ctx:
            self.ctx.release()
            self._owns_ctx = False

    # -- the frame -------------------------------------------------------------------------
    def _render_mode(
        self, passes: FramePasses, mode: str, settings: RenderSettings, want_ao: bool, frame_timings: dict
    ) -> RenderResult:
        timings = dict(frame_timings)  # the G-buffer's passes, shared by the frame's modes
        scale = settings.ao_scale if mode != "phong" else 1.0  # phong's AO buffer is never read
        blurred = settings.blur and mode != "phong"
        if mode != "phong":
            timings["ao"] = passes.timed(lambda: passes.ao(mode, settings))
            if settings.blur:
                timings["blur"] = passes.timed(lambda: passes.blur(settings.blur_size, scale))
        timings["composite"] = passes.timed(
            lambda: passes.composite(
                scale,
                blurred,
                use_ao=mode != "phong",
                light=settings.light,
                ao_direct=settings.ao_direct,
                tone=settings.tone,
            )
        )
        image = passes.read_rgb()
        ao = None
        if want_ao:
            h, w = image.shape[:2]
            ao = np.ones((h, w), np.float32) if mode == "phong" else passes.read_ao(scale, blurred)
        return RenderResult(mode, image, ao, timings)

    # -- what the passes share -------------------------------------------------------------
    def _screen_pass(self, name: str, target, textures: dict, **uniforms) -> None:
        program = load_program(self.ctx, name)
        if name not in self._screen_vaos:
            self._screen_vaos[name] = self.ctx.vertex_array(program, [])
        for unit, (uniform, texture) in enumerate(textures.items()):
            program[uniform].value = unit
            texture.use(unit)
        for key, value in uniforms.items():
            program[key].value = value
        target.use()
        self._screen_vaos[name].render(moderngl.TRIANGLES, vertices=3)

    def _targets_for(self, size) -> RenderTargets:
        if self._targets is None or self._targets.size != tuple(size):
            if self._targets is not None:  # another size: the old targets would stay allocated (a
                self._targets.release()  # review server renders photos of many sizes)
            self._targets = RenderTargets(self.ctx, size)
        return self._targets

    def _ao(self, mode: str, settings: RenderSettings, stride: int = 1):
        key = (mode, settings.samples, settings.seed, stride)
        if key not in self._ao_passes:
            self._ao_passes[key] = AO_METHODS[mode](self.ctx, settings.samples, settings.seed, stride)
        return self._ao_passes[key]

    def _blur(self, size: int) -> BilateralBlur:
        if size not in self._blurs:
            self._blurs[size] = BilateralBlur(self.ctx, size)
        return self._blurs[size]


__all__ = [
    "Renderer",
    "RenderSettings",
    "RenderResult",
    "Frame",
    "FramePasses",
    "AOBuffers",
    "MODES",
    "STUDY_LABELS",
    "check_screen_radius",
    "DEFAULT_SAMPLES",
    "DEFAULT_RADIUS_FRACTION",
    "DEFAULT_RADIUS_WORLD",
    "DEFAULT_FALLOFF",
    "DEFAULT_BLUR_SIZE",
    "DEFAULT_LOD_PX",
]
