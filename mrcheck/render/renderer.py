"""The renderer: one public :meth:`Renderer.render` that runs the passes in order.

geometry (G-buffer; anti-aliased: multisampled, then resolved to one sample per pixel)
-> AO (full or half resolution [-> depth-aware upsampling]) -> bilateral blur (optional)
-> composite (Blinn-Phong, AO on the ambient term; anti-aliased: edge pixels' other surfaces added).

One G-buffer serves every mode of a frame, so ``--mode all`` draws the geometry once. What a
caller needs of a frame comes back in its :class:`Frame` (images, AO, depth, normals); the passes
one at a time, for timing them alone, are :meth:`Renderer.passes` (:mod:`mrcheck.render.passes`).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.render.antialias import GBufferResolve, uses_antialiasing
from mrcheck.render.composite import Composite
from mrcheck.render.gbuffer import PALETTE_MAX, DrawOptions, GeometryPass, check_camera_outside
from mrcheck.render.gl import create_context, made_current
from mrcheck.render.passes import FramePasses, PassCache, RendererPasses
from mrcheck.render.settings import (  # re-exported: the names callers have imported from here
    DEFAULT_BLUR_SIZE,
    DEFAULT_FALLOFF,
    DEFAULT_LOD_PX,
    DEFAULT_RADIUS_FRACTION,
    DEFAULT_RADIUS_WORLD,
    DEFAULT_SAMPLES,
    MODES,
    STUDY_LABELS,
    RenderSettings,
    check_screen_radius,
)
from mrcheck.render.targets import AOBuffers
from mrcheck.scene.model import Scene


@dataclass
class RenderResult:
    """Images of one mode. ``image``: (H, W, 3) uint8 sRGB; ``ao``: (H, W) float32 or None."""

    mode: str
    image: np.ndarray
    ao: np.ndarray | None = None
    timings_ms: dict[str, float] = field(default_factory=dict)


@dataclass(eq=False)
class Frame(Mapping[str, RenderResult]):
    """What :meth:`Renderer.render` returns: the :class:`RenderResult` of each mode by name (a
    read-only mapping, ``frame["vector"]``), and what the modes of the frame share.

    depth : (H, W) float32 linear camera-space depth (scene units, 0 = background).
    normals : (H, W, 3) float32 unit camera-space normals (OpenCV axes, facing the camera; zero
        on the background), or None unless ``want_normals``.
    """

    results: dict[str, RenderResult]
    depth: np.ndarray
    normals: np.ndarray | None = None

    def __getitem__(self, mode: str) -> RenderResult:
        return self.results[mode]

    def __iter__(self) -> Iterator[str]:
        return iter(self.results)

    def __len__(self) -> int:
        return len(self.results)


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
        self._warned_palette = False
        # every public entry point makes this renderer's context current (see made_current)
        with made_current(self.ctx):
            self.geometry = GeometryPass(self.ctx, scene)
            self.composite = Composite(self.ctx)
            self.gbuffer_resolve = GBufferResolve(self.ctx)  # anti-aliasing (mrcheck.render.antialias)
            self.max_size = int(self.ctx.info["GL_MAX_TEXTURE_SIZE"])
        # what every frame's passes run on (FramePasses), the objects they share made on first use
        self.pipeline = RendererPasses(
            self.ctx, self.geometry, self.gbuffer_resolve, self.composite, PassCache(self.ctx)
        )

    # -- public ----------------------------------------------------------------------------
    def render(
        self,
        camera: Camera,
        modes: Sequence[str],
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
        return FramePasses(self.pipeline, camera, antialias)

    def release(self) -> None:
        """Free every GL object this renderer made; the context too when it created it. A second
        call does nothing (moderngl skips released objects; the bench's stages share renderers).
        The compiled programs belong to the context's program cache (:func:`mrcheck.render.gl.load_program`),
        shared by every renderer on it, and go with the context."""
        with made_current(self.ctx):
            self.pipeline.cache.release()
            self.composite.release()
            self.geometry.release()
            self.gbuffer_resolve.release()
        if self._owns_ctx:
            self.ctx.release()
            self._owns_ctx = False

    # -- the frame -------------------------------------------------------------------------
    def _render_mode(
        self,
        passes: FramePasses,
        mode: str,
        settings: RenderSettings,
        want_ao: bool,
        frame_timings: dict[str, float],
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
