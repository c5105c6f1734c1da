"""What shapes a frame: the render modes, :class:`RenderSettings` and every default.

The one home of the defaults: the command-line options of ``render``, ``overlay``, ``reference``,
``compare`` and the library alike read them from here, so a default is never written twice. This
module imports nothing of the GL side, so the CLI can build its options without moderngl.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from mrcheck.core.errors import MrcheckError

# D1, D2, D3 of the paper's study, then the comparison AO methods (mrcheck.render.ao)
MODES = ("phong", "vector", "ssao", "crytek", "hbao", "alchemy", "gtao", "vbao")
STUDY_LABELS = {
    "phong": "D1 Phong",
    "vector": "D2 vector SSAO",
    "ssao": "D3 standard SSAO",
    "crytek": "Crytek SSAO",
    "hbao": "HBAO",
    "alchemy": "Alchemy AO",
    "gtao": "GTAO",
    "vbao": "VBAO",
}
# the modes whose radius is on screen (radius_px, optional world clamp); every other AO mode reads radius_world
SCREEN_RADIUS_MODES = ("vector", "gtao", "vbao")
LIGHTS = ("headlight", "sun")  # headlight: just above the camera; sun: a fixed world direction
TONES = ("filmic", "clip")  # filmic: a shoulder that keeps light surfaces below white; clip: linear, clipped at 1

DEFAULT_SAMPLES = 16  # AO samples per pixel (the paper: 16, 36, 64, 128)
DEFAULT_RADIUS_FRACTION = 0.02  # vector: sampling radius as a fraction of the image height (15 px at 768)
DEFAULT_RADIUS_WORLD = 0.2  # ssao and the comparison modes: metres; equals the default vector
# radius at ~9 m (1024x768, 60 deg)
DEFAULT_FALLOFF = 1.0  # c of o = cos / (1 + c (|v| / r_S)^2), dimensionless
DEFAULT_INTENSITY = 1.0  # AO strength: 0 none, 1 the paper's average, > 1 stronger
# the default strength of a mode where it is not DEFAULT_INTENSITY: the vector AO at 1 is unbiased
# on simple scenes (tests/test_ao_accuracy.py) but darkens the shipped scenes 0.80x as much as the
# ray-traced reference of the same radius (screen-space misses: thin parts, the image border);
# 1.25 matches it, measured over every view of the sample cell and the cell (docs/rendering.md)
MODE_INTENSITIES = {"vector": 1.25}
DEFAULT_THICKNESS = 1.0  # vbao: assumed thickness of a surface, in units of the world sampling radius
DEFAULT_BLUR_ON = True  # depth-aware bilateral blur of the AO buffer on
DEFAULT_BLUR_SIZE = 9  # bilateral kernel size, pixels, odd (the paper's 9x9 / 13x13, table 2)
DEFAULT_AO_SCALE = 1.0  # AO resolution over the output's: 1.0 full, 0.5 half (the paper's 'Half Res.')
DEFAULT_LIGHT = "headlight"  # one of LIGHTS
DEFAULT_SEED = 0  # seed of the AO kernel and rotation tile (renders are reproducible)
DEFAULT_ANTIALIAS = True  # 4x multisampled G-buffer, edge pixels shaded per surface (mrcheck.render.antialias)
DEFAULT_TONE = "filmic"  # one of TONES (shaders/composite.glsl, tone())
DEFAULT_LOD_PX = 0.5  # allowed error of a level of detail on screen, pixels (mrcheck.render.lod)
MAX_LOD_PX = 4.0  # larger: coarse levels visibly move silhouettes
MAX_ACCUMULATE = 256  # AO frames averaged (--accumulate): 256 x 16 samples is past any visible change
REST_ACCUMULATE = 8  # the review's navigated view at rest: noise 3.7-4.3x below one frame's (docs/rendering.md)
MAX_SAMPLES = 512  # more: llvmpipe compiles the shader for many seconds (ao_unroll.glsl)
AO_SCALES = (1.0, 0.5)  # the AO resolutions there are

# The blur kernel's one-sided weights are a uniform array of size // 2 + 1 floats. OpenGL 4.5 promises
# only 1024 fragment uniform components, and a driver may give each array element a whole vec4:
# 128 elements (size 255) fit even then. llvmpipe links up to 32759 (16384 components); 100001
# failed to link. A blur that wide is far past any use (the paper's are 9 and 13).
MAX_BLUR_SIZE = 255


def blur_size_problem(size: int) -> str | None:
    """What is wrong with a blur kernel size, or None: the one rule of the CLI option,
    RenderSettings (checked before a scene loads) and BilateralBlur."""
    if size < 3 or size % 2 == 0 or size > MAX_BLUR_SIZE:
        return f"must be odd, 3 to {MAX_BLUR_SIZE}, got {size}"
    return None


@dataclass(frozen=True)
class RenderSettings:
    """Everything that shapes a frame, with the CLI's defaults.

    radius_px : screen radius of ``vector`` in pixels at the output resolution; when None,
        ``radius_fraction`` of the image height.
    radius_world : world radius of ``ssao`` in scene units.
    intensity : AO strength (0 none, 1 the paper's average, larger stronger); None: each mode's
        default (:func:`default_intensity`).
    thickness : ``vbao``'s assumed surface thickness as a multiple of the world sampling radius.
    ao_scale : 1.0 full-resolution AO, 0.5 half resolution with depth-aware upsampling.
    lod_px : allowed error of a level of detail on screen, pixels (0: every part at full detail;
        see :mod:`mrcheck.render.lod`).
    antialias : the geometry drawn into a 4x multisampled G-buffer (MSAA), the edge pixels shaded
        once per surface they hold, the AO once per pixel (:mod:`mrcheck.render.antialias`); with
        ``ao_scale`` 0.5 the frame is not anti-aliased.
    tone : how linear light becomes the output's sRGB: ``filmic`` (a shoulder below white) or
        ``clip`` (linear, clipped at 1: no tone curve).
    accumulate : AO frames averaged, each with its own orientation of the sample kernel and its
        own rotation tile (progressive AO: ``samples`` x ``accumulate`` samples per pixel, before
        the blur); 1 is the single-frame render.
    """

    samples: int = DEFAULT_SAMPLES
    radius_px: float | None = None
    radius_fraction: float = DEFAULT_RADIUS_FRACTION
    radius_world: float = DEFAULT_RADIUS_WORLD
    min_world_radius: float | None = None
    max_world_radius: float | None = None
    falloff: float = DEFAULT_FALLOFF
    intensity: float | None = None
    thickness: float = DEFAULT_THICKNESS
    blur: bool = DEFAULT_BLUR_ON
    blur_size: int = DEFAULT_BLUR_SIZE
    ao_scale: float = DEFAULT_AO_SCALE
    ao_direct: bool = False
    light: str = DEFAULT_LIGHT
    seed: int = DEFAULT_SEED
    lod_px: float = DEFAULT_LOD_PX
    antialias: bool = DEFAULT_ANTIALIAS
    tone: str = DEFAULT_TONE
    accumulate: int = 1

    def validated(self, height: int | None) -> "RenderSettings":
        """A copy with ``radius_px`` resolved for an image ``height`` pixels high, checked;
        ``height=None`` checks the options that do not depend on the image (before it is known)."""
        for ok, message in self._checks():
            if not ok:
                raise MrcheckError(message)
        if height is None:
            return self
        radius_px = self.radius_px if self.radius_px is not None else self.radius_fraction * height
        check_screen_radius(radius_px, height, "the vector radius is on screen")
        return replace(self, radius_px=float(radius_px))

    def _checks(self) -> list[tuple[bool, str]]:
        """(holds, the message if not) of every rule, in the order they are reported."""
        blur_problem = blur_size_problem(self.blur_size)
        lo, hi = self.min_world_radius, self.max_world_radius
        return [
            (self.samples >= 1, f"samples must be >= 1, got {self.samples}"),
            (self.samples <= MAX_SAMPLES, f"samples must be <= {MAX_SAMPLES}, got {self.samples}"),
            # comparisons that nan fails: "not >= 0" would let it through; and an infinite radius
            # or falloff makes every pixel 0 (background included)
            (
                self.radius_px is None or 0 < self.radius_px < math.inf,
                f"radius in pixels must be positive and finite, got {self.radius_px}",
            ),
            (0 < self.radius_fraction < 1, f"radius fraction must be in (0, 1), got {self.radius_fraction}"),
            (0 < self.radius_world < math.inf, f"world radius must be positive and finite, got {self.radius_world}"),
            (0 <= self.falloff < math.inf, f"falloff must be >= 0 and finite, got {self.falloff}"),
            (
                self.intensity is None or 0 <= self.intensity < math.inf,
                f"intensity must be >= 0 and finite, got {self.intensity}",
            ),
            (0 < self.thickness < math.inf, f"thickness must be positive and finite, got {self.thickness}"),
            (self.seed >= 0, f"seed must be >= 0, got {self.seed}"),
            (
                1 <= self.accumulate <= MAX_ACCUMULATE,
                f"accumulate must be 1 to {MAX_ACCUMULATE} frames, got {self.accumulate}",
            ),
            (self.ao_scale in AO_SCALES, f"ao scale must be 1.0 or 0.5, got {self.ao_scale}"),
            (blur_problem is None, f"blur size {blur_problem}"),
            (self.light in LIGHTS, f"light must be one of {', '.join(LIGHTS)}, got {self.light!r}"),
            (self.tone in TONES, f"tone must be one of {', '.join(TONES)}, got {self.tone!r}"),
            (lo is None or 0 <= lo < math.inf, f"minimum world radius must be >= 0 and finite, got {lo}"),
            (
                0 <= self.lod_px <= MAX_LOD_PX,
                f"level-of-detail error must be in [0, {MAX_LOD_PX:g}] pixels, got {self.lod_px}",
            ),
            (hi is None or 0 < hi < math.inf, f"maximum world radius must be > 0 and finite, got {hi}"),
            (lo is None or hi is None or lo <= hi, f"minimum world radius {lo} exceeds the maximum {hi}"),
        ]


def default_intensity(mode: str) -> float:
    """The AO strength of ``mode`` when none is given (:data:`MODE_INTENSITIES`)."""
    return MODE_INTENSITIES.get(mode, DEFAULT_INTENSITY)


def intensity_of(settings: RenderSettings, mode: str) -> float:
    """The AO strength ``settings`` give ``mode``: its own, or the mode's default."""
    return default_intensity(mode) if settings.intensity is None else float(settings.intensity)


def check_screen_radius(radius_px: float, height: int, what: str) -> None:
    """A screen radius larger than the image (``what`` says which radius, for the message):
    almost every sample or ray would leave the image, a unit mix-up rather than a radius."""
    if radius_px > height:
        raise MrcheckError(
            f"radius of {radius_px:g} px is larger than the image ({height} px high); "
            f"{what} (default: {DEFAULT_RADIUS_FRACTION * 100:g} % of the height)"
        )


__all__ = [
    "RenderSettings",
    "MAX_ACCUMULATE",
    "REST_ACCUMULATE",
    "MODES",
    "SCREEN_RADIUS_MODES",
    "DEFAULT_THICKNESS",
    "STUDY_LABELS",
    "LIGHTS",
    "TONES",
    "AO_SCALES",
    "MAX_BLUR_SIZE",
    "MAX_SAMPLES",
    "MAX_LOD_PX",
    "blur_size_problem",
    "check_screen_radius",
    "DEFAULT_SAMPLES",
    "DEFAULT_RADIUS_FRACTION",
    "DEFAULT_RADIUS_WORLD",
    "DEFAULT_FALLOFF",
    "DEFAULT_INTENSITY",
    "MODE_INTENSITIES",
    "default_intensity",
    "intensity_of",
    "DEFAULT_BLUR_ON",
    "DEFAULT_BLUR_SIZE",
    "DEFAULT_AO_SCALE",
    "DEFAULT_LIGHT",
    "DEFAULT_SEED",
    "DEFAULT_LOD_PX",
    "DEFAULT_ANTIALIAS",
    "DEFAULT_TONE",
]
