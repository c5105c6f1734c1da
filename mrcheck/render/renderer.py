"""The renderer: one public :meth:`Renderer.render` that runs the passes in order.

geometry (G-buffer) -> AO (full or half resolution [-> depth-aware upsampling])
-> bilateral blur (optional) -> composite (Blinn-Phong, AO on the ambient term).

One G-buffer serves every mode of a frame, so ``--mode all`` draws the geometry once.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.render.ao import AO_METHODS
from mrcheck.render.blur import BilateralBlur, blur_size_problem
from mrcheck.render.composite import LIGHTS, Composite
from mrcheck.render.gbuffer import GBuffer, GeometryPass, check_camera_outside
from mrcheck.render.gl import (
    create_context,
    float_depth_texture,
    load_program,
    made_current,
    srgb_texture,
)
from mrcheck.render.lod import LOD_PIXELS
from mrcheck.scene.model import Scene

MODES = ("phong", "vector", "ssao", "crytek", "hbao", "alchemy")  # D1, D2, D3 of the paper's study, then more AO
STUDY_LABELS = {"phong": "D1 Phong", "vector": "D2 vector SSAO", "ssao": "D3 standard SSAO", "crytek": "Crytek SSAO", "hbao": "HBAO", "alchemy": "Alchemy AO"}

DEFAULT_SAMPLES = 16
DEFAULT_RADIUS_FRACTION = 0.02  # vector: sampling radius as a fraction of the image height (15 px at 768)
DEFAULT_RADIUS_WORLD = 0.2      # ssao: metres; equals the default vector radius at ~9 m (1024x768, 60 deg)
DEFAULT_FALLOFF = 1.0           # c of o = cos / (1 + c (|v| / r_S)^2)
DEFAULT_BLUR = 9                # bilateral kernel size (the paper's 9x9 / 13x13, table 2)


@dataclass(frozen=True)
class RenderSettings:
    """Everything that shapes a frame, with the CLI's defaults.

    radius_px : screen radius of ``vector`` in pixels at the output resolution; when None,
        ``radius_fraction`` of the image height.
    radius_world : world radius of ``ssao`` in scene units.
    intensity : AO strength (0 none, 1 default, larger stronger).
    ao_scale : 1.0 full-resolution AO, 0.5 half resolution with depth-aware upsampling.
    lod_px : allowed error of a level of detail on screen, pixels (0: every part at full detail;
        see :mod:`mrcheck.render.lod`).
    """

    samples: int = DEFAULT_SAMPLES
    radius_px: float | None = None
    radius_fraction: float = DEFAULT_RADIUS_FRACTION
    radius_world: float = DEFAULT_RADIUS_WORLD
    min_world_radius: float | None = None
    max_world_radius: float | None = None
    falloff: float = DEFAULT_FALLOFF
    intensity: float = 1.0
    blur: bool = True
    blur_size: int = DEFAULT_BLUR
    ao_scale: float = 1.0
    ao_direct: bool = False
    light: str = "headlight"
    seed: int = 0
    lod_px: float = LOD_PIXELS

    def validated(self, height: int | None) -> "RenderSettings":
        """A copy with ``radius_px`` resolved for an image ``height`` pixels high, checked;
        ``height=None`` checks the options that do not depend on the image (before it is known)."""
        blur_problem = blur_size_problem(self.blur_size)
        checks = [
            (self.samples >= 1, f"samples must be >= 1, got {self.samples}"),
            (self.samples <= 512, f"samples must be <= 512, got {self.samples}"),
            # comparisons that nan fails: "not >= 0" would let it through; and an infinite radius
            # or falloff makes every pixel 0 (background included)
            (self.radius_px is None or 0 < self.radius_px < math.inf,
             f"radius in pixels must be positive and finite, got {self.radius_px}"),
            (0 < self.radius_fraction < 1, f"radius fraction must be in (0, 1), got {self.radius_fraction}"),
            (0 < self.radius_world < math.inf, f"world radius must be positive and finite, got {self.radius_world}"),
            (0 <= self.falloff < math.inf, f"falloff must be >= 0 and finite, got {self.falloff}"),
            (0 <= self.intensity < math.inf, f"intensity must be >= 0 and finite, got {self.intensity}"),
            (self.seed >= 0, f"seed must be >= 0, got {self.seed}"),
            (self.ao_scale in (0.5, 1.0), f"ao scale must be 1.0 or 0.5, got {self.ao_scale}"),
            (blur_problem is None, f"blur size {blur_problem}"),
            (self.light in LIGHTS, f"light must be one of {', '.join(LIGHTS)}, got {self.light!r}"),
            (self.min_world_radius is None or 0 <= self.min_world_radius < math.inf,
             f"minimum world radius must be >= 0 and finite, got {self.min_world_radius}"),
            (0 <= self.lod_px <= 4, f"level-of-detail error must be in [0, 4] pixels, got {self.lod_px}"),
            (self.max_world_radius is None or 0 < self.max_world_radius < math.inf,
             f"maximum world radius must be > 0 and finite, got {self.max_world_radius}"),
            (None in (self.min_world_radius, self.max_world_radius) or self.min_world_radius <= self.max_world_radius,
             f"minimum world radius {self.min_world_radius} exceeds the maximum {self.max_world_radius}"),
        ]
        for ok, message in checks:
            if not ok:
                raise MrcheckError(message)
        if height is None:
            return self
        radius_px = self.radius_px if self.radius_px is not None else self.radius_fraction * height
        check_screen_radius(radius_px, height, "the vector radius is on screen")
        return replace(self, radius_px=float(radius_px))


def check_screen_radius(radius_px: float, height: int, what: str) -> None:
    """A screen radius larger than the image (``what`` says which radius, for the message):
    almost every sample or ray would leave the image, a unit mix-up rather than a radius."""
    if radius_px > height:
        raise MrcheckError(f"radius of {radius_px:g} px is larger than the image ({height} px high); "
                           f"{what} (default: 2 % of the height)")


@dataclass
class RenderResult:
    """Images of one mode. ``image``: (H, W, 3) uint8 sRGB; ``ao``: (H, W) float32 or None."""

    mode: str
    image: np.ndarray
    ao: np.ndarray | None = None
    timings_ms: dict = field(default_factory=dict)


@dataclass
class _AOBuffers:
    buffers: list          # [(texture, fbo)] x 3: raw, scratch, blurred; RG32F (AO, depth) texels
    half: bool             # at half the output resolution

    @property
    def raw(self):
        return self.buffers[0]

    @property
    def scratch(self):
        return self.buffers[1]

    @property
    def blurred(self):
        return self.buffers[2]


class _Targets:
    """Render targets of one output size, reused frame to frame."""

    def __init__(self, ctx: moderngl.Context, size):
        w, h = size
        self.size = (w, h)
        self.half_size = ((w + 1) // 2, (h + 1) // 2)
        self.gbuffer = GBuffer.create(ctx, self.size)
        # raw, scratch, blurred; with the G-buffer's depth buffer, so that the AO passes skip the
        # background (mrcheck.render.ao.base.draw_covered; the blur and composite never depth-test)
        self.ao = [self._ao_target(ctx, self.size, self.gbuffer.zbuffer) for _ in range(3)]
        self.color = srgb_texture(ctx, self.size)
        self.color_fbo = ctx.framebuffer([self.color])
        self.half = None  # created on first half-resolution use

    @staticmethod
    def _ao_target(ctx, size, zbuffer=None):
        """RG32F (AO, depth) texels: what the AO passes and the blur write (ao_common.glsl)."""
        texture = ctx.texture(size, 2, dtype="f4")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texture.repeat_x = texture.repeat_y = False  # gathers at the border clamp, not wrap
        return texture, ctx.framebuffer([texture], zbuffer)

    def half_targets(self, ctx) -> list:
        if self.half is None:
            # the half-resolution coverage (shaders/ao_coverage.glsl) plays the G-buffer depth's part
            self.half_coverage = float_depth_texture(ctx, self.half_size)
            self.half_coverage_fbo = ctx.framebuffer([], self.half_coverage)
            self.half_coverage_frame = -1    # the G-buffer frame it was made from
            self.half = [self._ao_target(ctx, self.half_size, self.half_coverage) for _ in range(3)]
        return self.half

    def release(self) -> None:
        self.gbuffer.release()
        ao = self.ao + (self.half or [])
        half = [self.half_coverage_fbo, self.half_coverage] if self.half is not None else []
        for obj in [fbo for _, fbo in ao] + [texture for texture, _ in ao] + half + [self.color_fbo, self.color]:
            obj.release()

    def ao_buffers(self, ctx, scale: float) -> "_AOBuffers":
        """The AO buffers (raw, scratch, blurred) of the AO resolution."""
        if scale == 1.0:
            return _AOBuffers(self.ao, False)
        return _AOBuffers(self.half_targets(ctx), True)


class Renderer:
    """Renders one scene from calibrated cameras, headless.

    >>> renderer = Renderer(load_scene("scene.toml"))          # doctest: +SKIP
    >>> results = renderer.render(camera, ["phong", "vector"])   # doctest: +SKIP
    """

    def __init__(self, scene: Scene, ctx: moderngl.Context | None = None):
        self._owns_ctx = ctx is None
        self.ctx = ctx or create_context()
        self.scene = scene
        self._targets: _Targets | None = None
        self._ao_passes = {}
        self._blurs = {}
        self._screen_programs = {}
        # every public entry point makes this renderer's context current (see made_current)
        with made_current(self.ctx):
            self.geometry = GeometryPass(self.ctx, scene)
            self.composite = Composite(self.ctx)
            self.max_size = int(self.ctx.info["GL_MAX_TEXTURE_SIZE"])

    # -- public ----------------------------------------------------------------------------
    def render(self, camera: Camera, modes, settings: RenderSettings | None = None,
               want_ao: bool = False) -> dict[str, RenderResult]:
        """Render ``modes`` (subset of :data:`MODES`) from ``camera``; geometry drawn once."""
        with made_current(self.ctx):
            return self._render(camera, modes, settings, want_ao)

    def _render(self, camera, modes, settings, want_ao) -> dict[str, RenderResult]:
        settings = (settings or RenderSettings()).validated(camera.height)
        unknown = [m for m in modes if m not in MODES]
        if unknown:
            raise MrcheckError(f"unknown mode(s) {', '.join(unknown)} (use {', '.join(MODES)})")
        if max(camera.width, camera.height) > self.max_size:
            raise MrcheckError(f"image size {camera.width}x{camera.height} exceeds this GPU's limit of {self.max_size}")
        targets = self._targets_for((camera.width, camera.height))

        self.geometry.lod_px = settings.lod_px
        t_geometry = self._timed(lambda: self.geometry.draw(targets.gbuffer, camera))
        check_camera_outside(self.geometry, targets.gbuffer, camera, self.scene.source)

        results = {}
        for mode in modes:
            timings = {"geometry": t_geometry}
            ao = _AOBuffers(targets.ao, False)  # phong: never read
            if mode != "phong":
                timings["ao"] = self._timed(lambda: self._ao_pass(mode, camera, settings, targets))
                ao = targets.ao_buffers(self.ctx, settings.ao_scale)
                if settings.blur:
                    blur = self._blur(settings.blur_size)
                    timings["blur"] = self._timed(lambda: blur.run(ao.raw[0], ao.scratch[1], ao.blurred[1]))
            ao_texture = ao.blurred[0] if settings.blur and mode != "phong" else ao.raw[0]
            timings["composite"] = self._timed(lambda: self.composite.run(
                targets.color_fbo, targets.gbuffer, ao_texture, camera, use_ao=mode != "phong",
                light=settings.light, ao_direct=settings.ao_direct, ao_half=ao.half))
            image = self._read_rgb(targets)
            ao_array = None
            if want_ao:
                ao_array = np.ones((camera.height, camera.width), np.float32) if mode == "phong" else \
                    self._read_ao_full(ao_texture, ao, targets)
            results[mode] = RenderResult(mode, image, ao_array, timings)
        return results

    def last_depth(self) -> np.ndarray:
        """(H, W) float32 linear depth of the last frame (scene units, 0 = background)."""
        if self._targets is None:
            raise MrcheckError("nothing rendered yet")
        with made_current(self.ctx):
            return self._targets.gbuffer.read_depth().copy()

    def last_normals(self) -> np.ndarray:
        """(H, W, 3) float32 unit camera-space normals of the last frame (OpenCV axes, facing
        the camera; zero on the background)."""
        if self._targets is None:
            raise MrcheckError("nothing rendered yet")
        with made_current(self.ctx):
            w, h = self._targets.size
            normal = np.frombuffer(self._targets.gbuffer.normal.read(), np.float16).reshape(h, w, 4)
        return normal[..., :3].astype(np.float32)

    def release(self) -> None:
        """Free the GPU resources; the context too when this renderer created it. A second call
        does nothing (moderngl skips released objects; the bench's stages share renderers)."""
        with made_current(self.ctx):
            for p in self._ao_passes.values():
                p.release()
            self._ao_passes.clear()
            self.geometry.release()
            if self._targets is not None:
                self._targets.release()
                self._targets = None
        if self._owns_ctx:
            self.ctx.release()
            self._owns_ctx = False

    # -- Rendering passes ------------------------------------------------------------------
    def _ao_pass(self, mode: str, camera: Camera, settings: RenderSettings, targets: _Targets) -> None:
        """AO into ``targets.ao_buffers(scale).raw``: full resolution, or half resolution from a
        half-resolution G-buffer (the paper's 'Half Res.'; upsampled later, in the composite)."""
        ao = self._ao(mode, settings, stride=1 if settings.ao_scale == 1.0 else 2)
        gb = targets.gbuffer
        intrinsics = (camera.fx, camera.fy, camera.cx, camera.cy)
        if settings.ao_scale == 1.0:
            ao.run(targets.ao[0][1], gb.depth, gb.normal, intrinsics, settings)
            return
        # half-res pixel (i, j) is full-res pixel (2i, 2j): K halves exactly (ao_common.glsl)
        half_intrinsics = tuple(v / 2.0 for v in intrinsics)
        raw = targets.half_targets(self.ctx)[0][1]
        self._half_coverage(targets)
        ao.run(raw, gb.depth, gb.normal, half_intrinsics, settings, scale=0.5)

    def _half_coverage(self, targets: _Targets) -> None:
        """The half-resolution coverage depth (shaders/ao_coverage.glsl) of the current G-buffer,
        made once per G-buffer frame for every half-resolution pass of that frame."""
        gb = targets.gbuffer
        targets.half_targets(self.ctx)
        if targets.half_coverage_frame != gb.frame:
            self.ctx.enable(moderngl.DEPTH_TEST)
            self.ctx.depth_func = "1"    # always: the coverage pass writes every depth
            self._screen_pass("ao_coverage", targets.half_coverage_fbo, {"u_depth": gb.depth})
            self.ctx.disable(moderngl.DEPTH_TEST)
            targets.half_coverage_frame = gb.frame

    def _read_ao_full(self, ao_texture, ao: "_AOBuffers", targets: _Targets) -> np.ndarray:
        """(H, W) float32 AO at the output resolution; half-resolution AO is upsampled first."""
        if ao.half:
            self._screen_pass("ao_upsample", targets.ao[1][1],
                              {"u_ao_half": ao_texture, "u_depth_full": targets.gbuffer.depth},
                              u_size_half=ao_texture.size)
            ao_texture = targets.ao[1][0]
        w, h = targets.size
        return np.frombuffer(ao_texture.read(), np.float32).reshape(h, w, 2)[..., 0].copy()

    def _screen_pass(self, name: str, target, textures: dict, **uniforms) -> None:
        program, vao = self._screen_programs.get(name) or self._make_screen_program(name)
        for unit, (uniform, texture) in enumerate(textures.items()):
            program[uniform].value = unit
            texture.use(unit)
        for key, value in uniforms.items():
            program[key].value = value
        target.use()
        vao.render(moderngl.TRIANGLES, vertices=3)

    def _make_screen_program(self, name):
        program = load_program(self.ctx, name)
        self._screen_programs[name] = (program, self.ctx.vertex_array(program, []))
        return self._screen_programs[name]

    # -- helpers ---------------------------------------------------------------------------
    def _targets_for(self, size) -> _Targets:
        if self._targets is None or self._targets.size != tuple(size):
            if self._targets is not None:   # another size: the old targets would stay allocated (a
                self._targets.release()     # review server renders photos of many sizes)
            self._targets = _Targets(self.ctx, size)
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

    def _timed(self, work) -> float:
        """Milliseconds of GL work, measured with the pipeline drained before and after."""
        self.ctx.finish()
        start = time.perf_counter()
        work()
        self.ctx.finish()
        return (time.perf_counter() - start) * 1000.0

    @staticmethod
    def _read_rgb(targets: _Targets) -> np.ndarray:
        w, h = targets.size
        rgba = np.frombuffer(targets.color.read(), np.uint8).reshape(h, w, 4)
        return rgba[..., :3].copy()


__all__ = ["Renderer", "RenderSettings", "RenderResult", "MODES", "STUDY_LABELS", "check_screen_radius"]
