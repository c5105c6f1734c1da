"""What the bench measures and against what: its settings, the paper's figures, the issue's
targets, and :class:`Figure`, one measured figure."""

from __future__ import annotations

from dataclasses import dataclass, field
from statistics import median

PAPER_SIZE = (1280, 1024)  # the paper's benchmark resolution
SIZES = (PAPER_SIZE, (1024, 768))  # 1024x768: the study's camera resolution
QUICK_SAMPLES = (16, 64)
AO_MODES = ("vector", "ssao", "crytek", "hbao", "alchemy", "gtao", "vbao")
SCALES = (1.0, 0.5)  # full and half resolution AO
BLUR_SIZES = (9, 13)  # the paper's kernels (Table 2)
TRIANGLE_COUNTS = (1_000_000, 10_000_000)
DEFAULT_REPEAT, QUICK_REPEAT = 5, 3
SAMPLE_VIEW = "overview"

# Scheer & Keutel timed their own method only (D2, mrcheck's ``vector``), on a GTX 285 at
# 1280x1024 (Sibenik cathedral), so the paper's column is shown beside the vector figures and
# the blurs, never beside another mode. Table 1: the AO pass, ms, by (samples, scale).
PAPER_MODE = "vector"
PAPER_AO_MS = {
    (16, 1.0): 12.4,
    (16, 0.5): 1.6,
    (36, 1.0): 24.6,
    (36, 0.5): 3.5,
    (64, 1.0): 47.0,
    (64, 0.5): 6.1,
    (128, 1.0): 96.9,
    (128, 0.5): 12.4,
}
PAPER_BLUR_MS = {13: 3.6, 9: 2.8}  # Table 2, the blur at full resolution by kernel size, ms
# Table 2, "Application" (the whole frame, full-resolution AO), ms, by (samples, blur size)
PAPER_FRAME_MS = {(16, 13): 19.6, (36, 9): 31.0}

# The targets for the ratios: measured and shown against these, never adjusted to them.
TARGETS = {
    "vector_over_ssao": 1.2,  # vector AO pass / ssao AO pass, 16 samples, full res
    "vector_over_fetch_floor": 3.0,  # vector AO pass / fetch floor, 16 samples
    "half_over_full": 0.3,  # vector AO pass half res / full res, 16 samples
    "ao_10m_over_1m": 1.1,  # vector AO pass at 10 M / 1 M triangles
    # the same floor target on the 1 M height field, which covers every pixel (on the sample
    # cell both the AO passes and the floor skip the background, a third of the image)
    "vector_over_fetch_floor_covered": 3.0,
    "geometry_20m_over_1m": 3.0,  # geometry pass of the generated hall at 20 M / 1 M triangles
}
# Peer ratios: peer frame / mrcheck frame, each peer in a worker process of its own
# (mrcheck.eval.bench.peers), timed in turns with mrcheck's frame; null with a reason when a peer
# cannot run. The targets are minimums: mrcheck at least 2x faster than VTK's SSAO and
# 20x faster than Open3D's renderer with AO.
PEER_RATIOS = {"vtk": "vtk_over_mrcheck_frame", "open3d": "open3d_over_mrcheck_frame"}
PEER_TARGETS = {"vtk_over_mrcheck_frame": 2.0, "open3d_over_mrcheck_frame": 20.0}
RATIO_SAMPLES = 16
# The "vector <= 1.2x ssao" is "at equal samples": judged at every sample count measured.
# Its floor and half/full targets are given at 16 samples only: other counts are shown beside them.
EVERY_SAMPLE_COUNT = ("vector_over_ssao",)
REASON = "_reason"  # a null ratio's key + REASON: why it is null, next to it in the JSON's ratios

# Synthetic height field: a grid of box-shaped blocks on gently rolling ground, TERRAIN_EXTENT
# metres square, viewed from above so it covers the whole image (no background pixels that the
# AO passes would skip). Block edges ramp over BLOCK_RAMP metres, several grid cells even at
# 1 M triangles, so both tessellations draw practically the same G-buffer.
TERRAIN_EXTENT = 48.0  # metres
BLOCK_PITCH = 3.0  # metres between block centres
BLOCK_HALF_WIDTH = 0.6  # metres
BLOCK_RAMP = 0.15  # metres
TERRAIN_EYE, TERRAIN_TARGET, TERRAIN_FOV = (0.0, -10.0, 20.0), (0.0, 0.0, 0.0), 60.0

# Generated hall (factory_scenes.generator, preset "hall"): the geometry pass from its ``aisle``
# viewpoint at these triangle budgets (triangles as rendered, instances counted). Scenes are
# generated once per (budget, seed) into a cache under the temporary directory.
HALL_TRIANGLES = (1_000_000, 10_000_000, 20_000_000)
QUICK_HALL_TRIANGLES = (1_000_000, 20_000_000)
HALL_SEED, HALL_VIEW = 0, "aisle"
# Whole frame (geometry + vector AO + blur + composite, full-resolution AO) on the ``line`` scene
# from its first viewpoint: (size, samples, blur) -- the setting of docs/performance.md and the peers' setting.
LINE_SCENE = "line"  # a shipped scene (mrcheck.core.resources.shipped_scene)
PEER_SIZE, PEER_SAMPLES, PEER_BLUR = (1024, 768), 32, 9
FRAME_SETTINGS = ((PAPER_SIZE, 16, 13), (PEER_SIZE, PEER_SAMPLES, PEER_BLUR))
FRAME_PASSES = "geometry + ao + blur + composite + read back RGB"


def millions(triangles: int) -> str:
    """A triangle count as a label: 1M, 1.5M (not 2M: the line scene's 1,500,897), 20M."""
    return f"{triangles / 1e6:.1f}".removesuffix(".0") + "M"


def paper_frame_ms(mode: str, size, samples: int, scale: float, blur: int) -> float | None:
    """The paper's whole frame at these settings (Table 2), where it timed one."""
    if mode == PAPER_MODE and tuple(size) == PAPER_SIZE and scale == 1.0:
        return PAPER_FRAME_MS.get((samples, blur))
    return None


# -- figures -------------------------------------------------------------------------------------
@dataclass
class Figure:
    """One measured figure: what was timed, and its timed runs in milliseconds."""

    name: str
    mode: str | None
    width: int
    height: int
    samples: int | None
    scale: float | None
    scene: str
    triangles: int | None = None
    paper_ms: float | None = None
    times_ms: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)  # e.g. triangles drawn, blur size, what a peer timed
    entry: int | None = None  # figures of one entry were timed in turns: run i of each in round i
    over_fetch_floor: float | None = None  # an AO pass over the floor of its size, samples and scale
    peak_rss_mb: float | None = None  # peak resident memory while its entry was timed, MiB

    def describe(self) -> str:
        """A short label, e.g. ``ao vector 1280x1024 16 samples half``."""
        parts = [
            self.name,
            self.mode,
            f"{self.width}x{self.height}",
            self.samples and f"{self.samples} samples",
            self.scale and ("full" if self.scale == 1.0 else "half"),
            self.triangles and f"{millions(self.triangles)} triangles",
        ]
        return " ".join(str(p) for p in parts if p)

    @property
    def median_ms(self) -> float:
        return median(self.times_ms)

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "mode": self.mode,
            "width": self.width,
            "height": self.height,
            "samples": self.samples,
            "scale": self.scale,
            "scene": self.scene,
            "triangles": self.triangles,
            "min_ms": min(self.times_ms),
            "median_ms": self.median_ms,
            "max_ms": max(self.times_ms),
            "runs_ms": self.times_ms,
            "paper_gtx285_ms": self.paper_ms,
            "stats": self.stats,
            "unit": "ms",
            "timed_in_turns_with": self.entry,
            "over_fetch_floor": self.over_fetch_floor,
            "peak_rss_mb": self.peak_rss_mb,
        }


__all__ = [
    "Figure",
    "millions",
    "paper_frame_ms",
    "TARGETS",
    "PEER_TARGETS",
    "PAPER_AO_MS",
    "PAPER_BLUR_MS",
    "PAPER_FRAME_MS",
    "PAPER_SIZE",
    "PEER_SIZE",
    "PEER_SAMPLES",
    "PEER_BLUR",
    "RATIO_SAMPLES",
]
