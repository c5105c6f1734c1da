"""``mrcheck bench``: time the AO passes on this machine and print what was measured.

Every figure is measured in the run that prints it, never written down: one warm-up draw, then
``repeat`` timed draws through :meth:`Renderer._timed` (``ctx.finish()`` before and after, so a
figure is the GL work of that pass, including llvmpipe's rasterisation threads). Reported:
min / median / max in milliseconds, and the peak resident memory while the figure was timed
(:class:`_PeakMemory`). Ratios are paired: figures compared are timed in turns, one
run of each per round, and a ratio is the median of the per-round ratios (:func:`_ratio`).

What is timed (Scheer & Keutel, Tables 1 and 2, benchmarked at 1280x1024):

* the AO pass of every mode (``vector`` D2, ``ssao`` D3, and ``crytek``, ``hbao``, ``alchemy``)
  per sample count, at full resolution and at half resolution (``ao_scale=0.5``: the G-buffer
  downsample plus the half-size AO draw; the depth-aware upsampling is fused into the
  composite, so it shows up in the half-res composite);
* the *fetch floor* (``shaders/ao_fetch_floor.glsl``): the same number of depth fetches per pixel
  inside the same pixel radius, with no arithmetic; an AO pass over its floor is the price of
  the arithmetic on top of the memory traffic;
* the bilateral blur (9x9 and 13x13) and the composite, each at both AO resolutions;
* the whole frame of every AO mode at every size, sample count and AO resolution of the AO
  passes (geometry, AO, the CLI's default 9x9 blur, composite, reading the image back);
* the geometry pass and the vector AO pass of a synthetic height field of ~1 M and ~10 M
  triangles seen by the same camera: screen-space AO should not care about triangle count;
* the geometry pass of the generated hall at 1, 10 and 20 M triangles from its ``aisle``
  viewpoint at both sizes, with its culling and level-of-detail statistics (levels prepared
  before timing);
* the whole frame on the ``line`` scene (full- and, at the peers' size, half-resolution AO). It
  has 1.5 M triangles where the issue names a 1 M-triangle line scene: it is the line scene the
  project ships, labelled with its own count (``line_1.5M``).

Peers (``vtk_over_mrcheck_frame``, ``open3d_over_mrcheck_frame``): mrcheck's whole frame on the
``line`` scene at 1024x768 against VTK's SSAO through pyvista and Open3D's Filament renderer with
AO on the same flattened mesh and viewpoint, each peer in a worker process of its own
(:mod:`mrcheck.eval.bench.peers`) that renders one frame per request, so the three frames are timed in
turns. A peer that is not installed or fails gives a null ratio and a one-line reason.

Scene for the first four: the embedded sample cell from its ``overview`` viewpoint (a synthetic
height field stands in when the sample cell is missing, and the output says so).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import platform
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from statistics import median
from typing import Callable

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.output import check_output_path, write_image, write_text
from mrcheck.core.resources import factory_scenes_dir, sample_scene_path
from mrcheck.eval.bench.peers import PEERS, peak_rss_mb, reset_peak_rss
from mrcheck.render.ao.base import draw_covered
from mrcheck.render.ao.kernel import PAPER_SAMPLE_COUNTS, sphere_kernel
from mrcheck.render.gl import create_context, load_program, made_current
from mrcheck.render.renderer import DEFAULT_BLUR, Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene, make_part

PAPER_SIZE = (1280, 1024)             # the paper's benchmark resolution
SIZES = (PAPER_SIZE, (1024, 768))     # 1024x768: the study's camera resolution
QUICK_SAMPLES = (16, 64)
AO_MODES = ("vector", "ssao", "crytek", "hbao", "alchemy")
SCALES = (1.0, 0.5)                   # full and half resolution AO
BLUR_SIZES = (9, 13)                  # the paper's kernels (Table 2)
TRIANGLE_COUNTS = (1_000_000, 10_000_000)
DEFAULT_REPEAT, QUICK_REPEAT = 5, 3
SAMPLE_VIEW = "overview"

# Scheer & Keutel timed their own method only (D2, mrcheck's ``vector``), on a GTX 285 at
# 1280x1024 (Sibenik cathedral), so the paper's column is shown beside the vector figures and
# the blurs, never beside another mode. Table 1: the AO pass, ms, by (samples, scale).
PAPER_MODE = "vector"
PAPER_AO_MS = {(16, 1.0): 12.4, (16, 0.5): 1.6, (36, 1.0): 24.6, (36, 0.5): 3.5,
               (64, 1.0): 47.0, (64, 0.5): 6.1, (128, 1.0): 96.9, (128, 0.5): 12.4}
PAPER_BLUR_MS = {13: 3.6, 9: 2.8}     # Table 2, the blur at full resolution by kernel size, ms
# Table 2, "Application" (the whole frame, full-resolution AO), ms, by (samples, blur size)
PAPER_FRAME_MS = {(16, 13): 19.6, (36, 9): 31.0}

# The targets for the ratios: measured and shown against these, never adjusted to them.
TARGETS = {
    "vector_over_ssao": 1.2,          # vector AO pass / ssao AO pass, 16 samples, full res
    "vector_over_fetch_floor": 3.0,   # vector AO pass / fetch floor, 16 samples
    "half_over_full": 0.3,            # vector AO pass half res / full res, 16 samples
    "ao_10m_over_1m": 1.1,            # vector AO pass at 10 M / 1 M triangles
    # the same floor target on the 1 M height field, which covers every pixel (on the sample
    # cell both the AO passes and the floor skip the background, a third of the image)
    "vector_over_fetch_floor_covered": 3.0,
    "geometry_20m_over_1m": 3.0,      # geometry pass of the generated hall at 20 M / 1 M triangles
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
REASON = "_reason"   # a null ratio's key + REASON: why it is null, next to it in the JSON's ratios

# Synthetic height field: a grid of box-shaped blocks on gently rolling ground, TERRAIN_EXTENT
# metres square, viewed from above so it covers the whole image (no background pixels that the
# AO passes would skip). Block edges ramp over BLOCK_RAMP metres, several grid cells even at
# 1 M triangles, so both tessellations draw practically the same G-buffer.
TERRAIN_EXTENT = 48.0       # metres
BLOCK_PITCH = 3.0           # metres between block centres
BLOCK_HALF_WIDTH = 0.6      # metres
BLOCK_RAMP = 0.15           # metres
TERRAIN_EYE, TERRAIN_TARGET, TERRAIN_FOV = (0.0, -10.0, 20.0), (0.0, 0.0, 0.0), 60.0

# Generated hall (factory_scenes.generator, preset "hall"): the geometry pass from its ``aisle``
# viewpoint at these triangle budgets (triangles as rendered, instances counted). Scenes are
# generated once per (budget, seed) into a cache under the temporary directory.
HALL_TRIANGLES = (1_000_000, 10_000_000, 20_000_000)
QUICK_HALL_TRIANGLES = (1_000_000, 20_000_000)
HALL_SEED, HALL_VIEW = 0, "aisle"
# Whole frame (geometry + vector AO + blur + composite, full-resolution AO) on the ``line`` scene
# from its first viewpoint: (size, samples, blur) -- the README's setting and the peers' setting.
LINE_SCENE = ("line", "scene.toml")            # under the factory_scenes package
PEER_SIZE, PEER_SAMPLES, PEER_BLUR = (1024, 768), 32, 9
FRAME_SETTINGS = ((PAPER_SIZE, 16, 13), (PEER_SIZE, PEER_SAMPLES, PEER_BLUR))
FRAME_PASSES = "geometry + ao + blur + composite + read back RGB"


def _millions(triangles: int) -> str:
    """A triangle count as a label: 1M, 1.5M (not 2M: the line scene's 1,500,897), 20M."""
    return f"{triangles / 1e6:.1f}".removesuffix(".0") + "M"


def _paper_frame_ms(mode: str, size, samples: int, scale: float, blur: int) -> float | None:
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
    stats: dict = field(default_factory=dict)   # e.g. triangles drawn, blur size, what a peer timed
    entry: int | None = None   # figures of one entry were timed in turns: run i of each in round i
    over_fetch_floor: float | None = None   # an AO pass over the floor of its size, samples and scale
    peak_rss_mb: float | None = None   # peak resident memory while its entry was timed, MiB

    def describe(self) -> str:
        """A short label, e.g. ``ao vector 1280x1024 16 samples half``."""
        parts = [self.name, self.mode, f"{self.width}x{self.height}", self.samples and f"{self.samples} samples",
                 self.scale and ("full" if self.scale == 1.0 else "half"),
                 self.triangles and f"{_millions(self.triangles)} triangles"]
        return " ".join(str(p) for p in parts if p)

    @property
    def median_ms(self) -> float:
        return median(self.times_ms)

    def to_json(self) -> dict:
        return {"name": self.name, "mode": self.mode, "width": self.width, "height": self.height,
                "samples": self.samples, "scale": self.scale, "scene": self.scene, "triangles": self.triangles,
                "min_ms": min(self.times_ms), "median_ms": self.median_ms, "max_ms": max(self.times_ms),
                "runs_ms": self.times_ms, "paper_gtx285_ms": self.paper_ms, "stats": self.stats, "unit": "ms",
                "timed_in_turns_with": self.entry, "over_fetch_floor": self.over_fetch_floor,
                "peak_rss_mb": self.peak_rss_mb}


@dataclass
class _Job:
    """A figure to measure: ``setup`` leaves the GL state the pass reads, ``work`` is the pass."""

    figure: Figure
    setup: Callable[[], None]
    work: Callable[[], None]


class _FetchFloor:
    """``ao_fetch_floor.glsl`` with ``samples`` fixed pixel offsets inside ``radius_px``.

    The offsets are the xy of the AO kernel times the vector pass's pixel radius, so the fetches
    spread over the same neighbourhood; unlike the AO passes they are not rotated per pixel, which
    if anything makes the floor a little kinder to the texture cache (a floor, not an estimate).
    """

    def __init__(self, ctx: moderngl.Context, samples: int, radius_px: float, seed: int, stride: int = 1):
        self.program = load_program(ctx, "ao_fetch_floor", {"AO_SAMPLES": samples, "AO_STRIDE": stride})
        # radius_px at the output resolution; a half-resolution pass's pixels are twice as large
        offsets = np.rint(sphere_kernel(samples, seed)[:, :2] * radius_px / stride).astype(np.int32)
        self.program["u_offsets"].write(offsets.tobytes())
        self.program["u_depth"].value = 0
        self.ctx = ctx
        self.vao = ctx.vertex_array(self.program, [])

    def run(self, target: moderngl.Framebuffer, depth: moderngl.Texture) -> None:
        self.program["u_size"].value = target.size
        depth.use(0)
        draw_covered(self.ctx, target, self.vao)   # the background skipped as in the AO passes

    def release(self) -> None:
        self.vao.release()


class _Stage:
    """A renderer and camera: every figure of one scene at one image size starts here.

    The only place that reaches into :class:`Renderer`'s passes (``_targets_for``, ``_ao_pass``,
    ``_blur``, ``_timed``), so a change there is mended here once.
    """

    def __init__(self, renderer: Renderer, camera: Camera, label: str):
        self.renderer = renderer
        self.camera = camera
        self.label = label
        self.ctx = renderer.ctx
        self._floors = {}
        # levels of detail loaded or built before timing, as a long session has them (a first
        # render builds only those of parts with many instances; see mrcheck.render.lod)
        with made_current(self.ctx):
            renderer.geometry.prepare_levels()

    @property
    def targets(self):
        return self.renderer._targets_for((self.camera.width, self.camera.height))

    def settings(self, samples: int = RATIO_SAMPLES, scale: float = 1.0, blur: int = DEFAULT_BLUR) -> RenderSettings:
        """The CLI's defaults at this sample count, AO scale and blur, resolved for this image."""
        return RenderSettings(samples=samples, ao_scale=scale, blur_size=blur).validated(self.camera.height)

    def draw_geometry(self) -> None:
        self.renderer.geometry.draw(self.targets.gbuffer, self.camera)

    def ao(self, mode: str, settings: RenderSettings) -> None:
        self.renderer._ao_pass(mode, self.camera, settings, self.targets)

    def blur(self, size: int, scale: float) -> None:
        ao = self.targets.ao_buffers(self.ctx, scale)
        self.renderer._blur(size).run(ao.raw[0], ao.scratch[1], ao.blurred[1])

    def composite(self, scale: float) -> None:
        ao = self.targets.ao_buffers(self.ctx, scale)
        self.renderer.composite.run(self.targets.color_fbo, self.targets.gbuffer, ao.blurred[0], self.camera,
                                    use_ao=True, ao_half=ao.half)

    def read_back(self) -> np.ndarray:
        return self.renderer._read_rgb(self.targets)

    def frame(self, mode: str, settings: RenderSettings) -> np.ndarray:
        """The whole frame as ``mrcheck render`` draws it, ending with reading the image back
        like the peers' frames: geometry, AO, blur, composite."""
        self.draw_geometry()
        self.ao(mode, settings)
        self.blur(settings.blur_size, settings.ao_scale)
        self.composite(settings.ao_scale)
        return self.read_back()

    def fetch_floor(self, samples: int, scale: float = 1.0) -> None:
        """The floor of the AO pass at ``scale``, into the scratch buffer of that resolution (the
        AO passes write the raw one); at half resolution with the coverage pass the AO pass pays."""
        settings = self.settings(samples)
        stride = 1 if scale == 1.0 else 2
        key = (samples, settings.radius_px, settings.seed, stride)
        if key not in self._floors:
            self._floors[key] = _FetchFloor(self.ctx, samples, settings.radius_px, settings.seed, stride)
        if stride == 1:
            target = self.targets.ao[1][1]
        else:
            target = self.targets.half_targets(self.ctx)[1][1]
            self.renderer._half_coverage(self.targets)
        self._floors[key].run(target, self.targets.gbuffer.depth)

    def release(self) -> None:
        """Free the fetch floors and the renderer (which stages of one scene may share: a second
        release of it does nothing)."""
        for floor in self._floors.values():
            floor.release()
        self.renderer.release()


# -- scenes --------------------------------------------------------------------------------------
def _terrain_heights(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Heights (metres) of the synthetic field: blocks of hashed height on rolling ground."""
    ix, iy = np.floor(x / BLOCK_PITCH), np.floor(y / BLOCK_PITCH)
    dx, dy = np.abs(x - (ix + 0.5) * BLOCK_PITCH), np.abs(y - (iy + 0.5) * BLOCK_PITCH)
    block = 0.5 + 2.0 * ((np.sin(ix * 12.9898 + iy * 78.233) * 43758.5453) % 1.0)  # 0.5..2.5 m per cell
    inside = np.clip((BLOCK_HALF_WIDTH - np.maximum(dx, dy)) / BLOCK_RAMP + 0.5, 0.0, 1.0)
    return block * inside + 0.3 * np.sin(0.35 * x) * np.cos(0.27 * y)


def terrain_scene(triangles: int) -> Scene:
    """A height field of about ``triangles`` triangles (a square grid, two per cell), in memory."""
    n = max(1, int(round(np.sqrt(triangles / 2.0))))
    t = np.linspace(-TERRAIN_EXTENT / 2.0, TERRAIN_EXTENT / 2.0, n + 1)
    x, y = np.meshgrid(t, t)
    vertices = np.column_stack([x.ravel(), y.ravel(), _terrain_heights(x, y).ravel()])
    del x, y
    i = np.arange(n, dtype=np.uint32)
    a = (i[None, :] + i[:, None] * np.uint32(n + 1)).ravel()  # lower-left corner of every cell
    faces = np.empty((2 * n * n, 3), np.uint32)
    faces[0::2, 0], faces[0::2, 1], faces[0::2, 2] = a, a + 1, a + n + 2
    faces[1::2, 0], faces[1::2, 1], faces[1::2, 2] = a, a + n + 2, a + n + 1
    name = f"terrain_{_millions(len(faces))}"
    part = make_part(name, "<synthetic>", vertices, faces, np.eye(4), color=(0.7, 0.7, 0.7), units="m")
    return Scene(name, "<synthetic>", [part])


def terrain_camera(size) -> Camera:
    return Camera.from_look_at(TERRAIN_EYE, TERRAIN_TARGET, (0.0, 0.0, 1.0), TERRAIN_FOV, *size)


def _sample_scene() -> tuple[Scene, Callable[[tuple], Camera], str]:
    """The sample cell and its overview camera, or the 1 M height field if the cell is missing."""
    path = sample_scene_path()
    if path.exists():
        scene = load_scene(path)
        return scene, lambda size: scene.camera(SAMPLE_VIEW, *size), f"{scene.name}:{SAMPLE_VIEW}"
    print(f"warning: {path} not found; timing a synthetic height field instead of the sample cell", file=sys.stderr)
    scene = terrain_scene(TRIANGLE_COUNTS[0])
    # not the height-field section's label: figures (the floors) are matched by their scene
    return scene, terrain_camera, f"{scene.name}:stand-in"


def _generator_digest() -> str:
    """A hash of the hall generator's source and of the robots module whose arms it places: the
    halls are cached by it, so that a changed generator is benchmarked on halls it made."""
    import factory_scenes.generator as generator
    from mrcheck.scene import robots

    digest = hashlib.sha256()
    for path in sorted(Path(generator.__file__).parent.glob("*.py")) + [Path(robots.__file__)]:
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:12]


def hall_scene_path(triangles: int, seed: int = HALL_SEED) -> Path:
    """scene.toml of the generated hall at ``triangles``, generated once per (budget, seed,
    generator source) into ``<tmp>/mrcheck-bench/`` (a finished scene is moved into place whole,
    so a crash leaves none)."""
    from factory_scenes.generator import generate

    cache = Path(tempfile.gettempdir()) / "mrcheck-bench"
    final = cache / f"hall_{triangles}_seed{seed}_{_generator_digest()}"
    if not (final / "scene.toml").exists():
        cache.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=final.name + ".", dir=cache))
        generate("hall", work / "scene", seed=seed, target_triangles=triangles, progress=False)
        try:
            os.replace(work / "scene", final)
        except OSError:  # another run finished first
            if not (final / "scene.toml").exists():
                raise
        shutil.rmtree(work, ignore_errors=True)
    return final / "scene.toml"


def line_scene_path() -> Path:
    return factory_scenes_dir().joinpath(*LINE_SCENE)


def flattened_mesh(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Every instance of every part in world space, as one (V, 3) float32 / (F, 3) int32 mesh."""
    vertices, faces, offset = [], [], 0
    for part in scene.parts:
        local = np.asarray(part.vertices, np.float64)
        for T in part.transforms:
            vertices.append((local @ T[:3, :3].T + T[:3, 3]).astype(np.float32))
            faces.append(np.asarray(part.faces, np.int64) + offset)
            offset += len(local)
    return np.concatenate(vertices), np.concatenate(faces).astype(np.int32)


# -- peers ---------------------------------------------------------------------------------------
class _PeerStage:
    """A peer's worker process (:mod:`mrcheck.eval.bench.peers`) in a :func:`_measure` entry: one frame
    per turn, timed inside the worker (render + read back). A worker that fails mid-run leaves
    its reason and no figure; it never stops the bench."""

    def __init__(self, ctx: moderngl.Context, worker, reasons: dict):
        self.ctx = ctx
        self.worker = worker
        self.reasons = reasons
        self.failed = None
        self.renderer = self

    @property
    def peak_rss_mb(self) -> float | None:
        return self.worker.peak_rss_mb

    def _timed(self, work) -> float:
        from mrcheck.eval.bench.peers import failure_reason

        if self.failed is None:
            try:
                return self.worker.frame()
            except Exception as exc:  # noqa: BLE001 -- whatever a peer does, it is its reason, not ours
                self.failed = self.reasons[self.worker.peer] = failure_reason(exc)
                self.worker.stop()
        return float("nan")

    def release(self) -> None:
        self.worker.stop()


def peer_folder() -> Path:
    """Where the peers' frames, their AO-off frames and logs and mrcheck's frame go: one folder
    under the temporary directory, its files replaced by each run (not a new folder per run)."""
    return Path(tempfile.gettempdir()) / "mrcheck-bench-peers"


def _start_peers(ctx, scene: Scene, viewpoint: dict, reasons: dict, workdir: Path) -> list:
    """The peers whose workers start and render (one at a time, so neither set-up competes with
    the other); a peer that cannot gets its one-line reason in ``reasons``."""
    from mrcheck.eval.bench.peers import (
        PeerWorker,
        ao_off_png,
        failure_reason,
        importable,
        write_mesh,
    )

    # the mesh is this run's own file (the folder is shared by every run), gone once loaded
    mesh = write_mesh(workdir / f"line_mesh.{os.getpid()}.npz", *flattened_mesh(scene), viewpoint, PEER_SIZE)
    peers = []
    try:
        for name in PEERS:
            if why := importable(name):
                reasons[name] = why
                continue
            worker = PeerWorker(name, mesh, workdir / f"{name}.png")
            for stale in (worker.png, ao_off_png(worker.png)):   # (the log is rewritten by start)
                stale.unlink(missing_ok=True)  # a previous run's, which a failing peer would leave
            try:
                worker.start().wait_ready()
                peers.append(_PeerStage(ctx, worker, reasons))
            except Exception as exc:  # noqa: BLE001 -- whatever a peer does, it is its reason, not ours
                reasons[name] = failure_reason(exc)
                worker.stop()
    finally:
        mesh.unlink(missing_ok=True)  # the workers have loaded it
    return peers


class _LineStages:
    """The ``line`` scene at both frame sizes (one renderer) and the peers at PEER_SIZE."""

    def __init__(self, ctx, quick: bool, reasons: dict):
        scene = load_scene(line_scene_path())
        view = next(iter(scene.viewpoints))
        renderer = Renderer(scene, ctx=ctx)
        self.triangles = scene.triangle_count
        label = f"{scene.name}_{_millions(self.triangles)}:{view}"  # 1.5M: not the 1 M, said so
        self.stages = [_Stage(renderer, scene.camera(view, *size), label) for size, _, _ in FRAME_SETTINGS]
        # the peers' frames and mrcheck's at their setting, kept to look at (see the README)
        self.workdir = peer_folder()
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.png = self.workdir / "mrcheck.png"
        self.png.unlink(missing_ok=True)  # written again at the end of this run
        self.last_rgb = None
        with made_current(ctx):  # nothing the workers do touches this process's context, but be sure
            self.peers = _start_peers(ctx, scene, scene.viewpoints[view], reasons, self.workdir)
        self.label = label

    def release(self) -> None:
        for peer in self.peers:
            peer.release()
        if self.last_rgb is not None:
            write_image(self.png, self.last_rgb)  # image rows top-down
        self.stages[0].release()  # the renderer the stages share


def _frame_scales(size) -> tuple:
    """The AO scales of the line scene's frame at ``size``: at the peers' size half resolution
    too, the paper's option for slow GPUs (its ratios to the peers are reported beside)."""
    return (1.0, 0.5) if tuple(size) == PEER_SIZE else (1.0,)


def _frame_jobs(group: _LineStages) -> list[list]:
    """mrcheck's whole frame at each setting; at the peers' setting timed in turns with them."""
    entries = []
    for stage, (size, samples, blur) in zip(group.stages, FRAME_SETTINGS):
        entry = []
        for scale in _frame_scales(size):  # full-resolution AO: the peers' ratios
            settings = stage.settings(samples, scale, blur)
            keep = size == PEER_SIZE and scale == 1.0

            def frame(stage=stage, settings=settings, keep=keep):
                rgb = stage.frame("vector", settings)
                if keep:
                    group.last_rgb = rgb

            stats = {"blur": blur, "passes": FRAME_PASSES}
            if keep:
                stats["png"] = str(group.png)
            figure = Figure("frame", "vector", *size, samples, scale, stage.label, group.triangles,
                            _paper_frame_ms("vector", size, samples, scale, blur), stats=stats)
            entry.append((stage, _Job(figure, lambda: None, frame)))
        if size == PEER_SIZE:  # in turns: mrcheck frame, VTK frame, Open3D frame, ...
            for peer in group.peers:
                info = peer.worker.info
                figure = Figure("frame", peer.worker.peer, *size, None, None, stage.label, group.triangles,
                                stats={"peer": info["version"], "settings": info["settings"], "png": info["png"],
                                       "ao_effect": info["ao_effect"], "setup_ms": info["setup_ms"],
                                       "setup_peak_rss_mb": info.get("setup_peak_rss_mb"),
                                       "timed": "render + read back RGB(A), inside the peer's worker process"})
                entry.append((peer, _Job(figure, lambda: None, lambda: None)))
        entries.append(entry)
    return entries


def _hall_jobs(group: "_StageGroup") -> list[list]:
    """The geometry pass of every hall, timed in turns, at each image size; the figure keeps the
    drawn triangles."""
    entries = {}
    for stage, triangles in zip(group.stages, group.triangles):
        w, h = stage.camera.width, stage.camera.height
        figure = Figure("geometry", None, w, h, None, None, stage.label, triangles,
                        stats={"generated": "hall", "seed": HALL_SEED,
                               "scene_triangles": stage.renderer.scene.triangle_count})

        def draw(stage=stage, figure=figure):
            figure.stats.update(stage.renderer.geometry.draw(stage.targets.gbuffer, stage.camera))

        entries.setdefault((w, h), []).append((stage, _Job(figure, lambda: None, draw)))
    return list(entries.values())


# -- the plan ------------------------------------------------------------------------------------
def _pass_jobs(stage: _Stage, samples_list) -> list[list]:
    """AO passes, fetch floors, whole frames, blurs and composites of one stage (items 1-3 of the issue)."""
    w, h = stage.camera.width, stage.camera.height
    paper = (w, h) == PAPER_SIZE

    def fig(name, mode=None, samples=None, scale=None, paper_ms=None):
        return Figure(name, mode, w, h, samples, scale, stage.label, paper_ms=paper_ms if paper else None)

    entries = []
    for samples in samples_list:
        # everything a ratio compares at this sample count is timed in turns (see _measure)
        # the whole frame of every mode at these settings, with the CLI's default blur: in an
        # entry of its own, so that the AO passes' rounds stay as short as before
        group, frames = [], []
        for mode in AO_MODES:
            for scale in SCALES:
                s = stage.settings(samples, scale)
                paper_ms = PAPER_AO_MS.get((samples, scale)) if mode == PAPER_MODE else None
                group.append((stage, _Job(fig("ao", mode, samples, scale, paper_ms),
                                          stage.draw_geometry, lambda m=mode, s=s: stage.ao(m, s))))
                figure = fig("frame", mode, samples, scale, _paper_frame_ms(mode, (w, h), samples, scale, s.blur_size))
                figure.stats = {"blur": s.blur_size, "passes": FRAME_PASSES}
                frames.append((stage, _Job(figure, lambda: None, lambda m=mode, s=s: stage.frame(m, s))))
        for scale in SCALES:
            group.append((stage, _Job(fig("fetch_floor", None, samples, scale), stage.draw_geometry,
                                      lambda n=samples, sc=scale: stage.fetch_floor(n, sc))))
        entries += [group, frames]

    for scale in SCALES:
        def with_ao(scale=scale):
            stage.draw_geometry()
            stage.ao("vector", stage.settings(RATIO_SAMPLES, scale))

        for size in BLUR_SIZES:
            paper_ms = PAPER_BLUR_MS.get(size) if scale == 1.0 else None
            entries.append([(stage, _Job(fig(f"blur_{size}x{size}", None, None, scale, paper_ms), with_ao,
                                         lambda n=size, sc=scale: stage.blur(n, sc)))])

        def with_blur(scale=scale, with_ao=with_ao):
            with_ao()
            stage.blur(BLUR_SIZES[0], scale)

        entries.append([(stage, _Job(fig("composite", None, None, scale), with_blur,
                                     lambda sc=scale: stage.composite(sc)))])
    return entries


def _triangle_jobs(group: "_StageGroup") -> list[list]:
    """Per height field the geometry pass; then the 16-sample vector AO pass of each, timed in
    turns, with the fetch floor on the first (it covers every pixel)."""
    entries, compared = [], []
    for stage, triangles in zip(group.stages, TRIANGLE_COUNTS):
        w, h = stage.camera.width, stage.camera.height
        entries.append([(stage, _Job(Figure("geometry", None, w, h, None, None, stage.label, triangles),
                                     lambda: None, stage.draw_geometry))])
        settings = stage.settings()
        compared.append((stage, _Job(Figure("ao", "vector", w, h, RATIO_SAMPLES, 1.0, stage.label, triangles),
                                     stage.draw_geometry, lambda st=stage, s=settings: st.ao("vector", s))))
    first, (w, h) = group.stages[0], PAPER_SIZE
    compared.append((first, _Job(Figure("fetch_floor", None, w, h, RATIO_SAMPLES, 1.0, first.label,
                                        TRIANGLE_COUNTS[0]), first.draw_geometry,
                                 lambda: first.fetch_floor(RATIO_SAMPLES))))
    return entries + [compared]


_ENTRIES = itertools.count()


class _PeakMemory:
    """The bench process's peak resident memory per entry (reset before it, read after) and
    over the whole run. A reset lowers ``ru_maxrss`` too, so the whole run's peak is the largest
    reading, one taken before every reset included (scenes load between entries)."""

    def __init__(self):
        self.whole_mb = peak_rss_mb()
        self.per_entry = True   # False once a reset failed: a figure's peak is then since the start

    def start(self) -> None:
        self.whole_mb = max(self.whole_mb, peak_rss_mb())
        self.per_entry = reset_peak_rss() and self.per_entry

    def stop(self) -> float:
        peak = peak_rss_mb()
        self.whole_mb = max(self.whole_mb, peak)
        return peak

    def report(self) -> dict:
        self.stop()
        how = ("the bench process's peak during the figure's entry (VmHWM, reset through /proc/self/clear_refs "
               "before each entry)" if self.per_entry else
               "the bench process's peak since it started (never reset: /proc/self/clear_refs could not be written)")
        return {"peak_rss_mb": self.whole_mb,
                "peak_rss_per_figure": how + "; a peer's: its worker's peak over its frames, reset before each"}


def _measure(entry: list, repeat: int, memory: _PeakMemory | None = None) -> list[Figure]:
    """Time the jobs of one entry in turns: each job's setup and warm-up, then ``repeat`` rounds
    of one run of every job. A ratio must hold within 10 %, about the drift of this machine over
    a minute; taken in turns, the drift falls on both sides of the ratio alike. The G-buffer
    and AO buffers a job's setup leaves persist because the jobs of one entry on one stage
    write different targets (full/half resolution, AO/floor), or live in different renderers.
    Every figure gets the peak resident memory of the entry (a peer's, its worker's own)."""
    memory = memory or _PeakMemory()
    memory.start()
    tag = next(_ENTRIES)
    for stage, job in entry:
        job.figure.entry = tag
        with made_current(stage.ctx):
            job.setup()
            stage.renderer._timed(job.work)  # warm-up: shader compile/JIT, first touch of buffers
    for _ in range(repeat):
        for stage, job in entry:
            with made_current(stage.ctx):
                job.setup()
                job.figure.times_ms.append(stage.renderer._timed(job.work))
    peak = memory.stop()
    for stage, job in entry:
        job.figure.peak_rss_mb = getattr(stage, "peak_rss_mb", peak)  # a peer's worker reports its own
    return [job.figure for stage, job in entry if getattr(stage, "failed", None) is None]  # a failed peer: none


class _StageGroup:
    """Stages alive together so that their passes can be timed in turns (the height fields, the
    halls), and the triangle budget of each; stages of one scene at two sizes share a renderer."""

    def __init__(self, stages, triangles=TRIANGLE_COUNTS):
        self.stages = stages
        self.triangles = triangles

    def release(self) -> None:
        for stage in self.stages:
            stage.release()


@dataclass
class _Section:
    """Entries sharing one stage (or group of stages); it is built when the section starts and
    freed after it, so each scene is in memory only while its figures are measured."""

    make_stage: Callable[[], _Stage]
    jobs: Callable[[object], list]   # -> entries: lists of (stage, job) measured in turns
    count: int                       # figures, for the progress bar
    release_after: bool = True   # False while a later section reuses the stage's renderer


def _plan(ctx: moderngl.Context, quick: bool, reasons: dict | None = None) -> list[_Section]:
    sizes = SIZES[:1] if quick else SIZES
    samples_list = QUICK_SAMPLES if quick else PAPER_SAMPLE_COUNTS
    sections = []
    sample = {}

    def sample_stage(size):
        if not sample:  # one renderer (one upload) for every size of the sample scene
            scene, camera_for, label = _sample_scene()
            sample.update(renderer=Renderer(scene, ctx=ctx), camera_for=camera_for, label=label)
        return _Stage(sample["renderer"], sample["camera_for"](size), sample["label"])

    # per sample count: AO passes, floors and frames; per scale: blurs and composite
    per_size = len(samples_list) * (2 * len(AO_MODES) + 1) * len(SCALES) + len(SCALES) * (len(BLUR_SIZES) + 1)
    for size in sizes:
        sections.append(_Section(lambda size=size: sample_stage(size), lambda st: _pass_jobs(st, samples_list),
                                 per_size, release_after=size == sizes[-1]))

    def terrain_stages():
        stages = []
        for triangles in TRIANGLE_COUNTS:
            scene = terrain_scene(triangles)
            stages.append(_Stage(Renderer(scene, ctx=ctx), terrain_camera(PAPER_SIZE), scene.name))
        return _StageGroup(stages)

    sections.append(_Section(terrain_stages, _triangle_jobs, 2 * len(TRIANGLE_COUNTS) + 1))

    hall_triangles = QUICK_HALL_TRIANGLES if quick else HALL_TRIANGLES

    def hall_stages():  # at both sizes in a quick run too: a few geometry passes, seconds
        stages, budgets = [], []
        for triangles in hall_triangles:
            scene = load_scene(hall_scene_path(triangles))
            renderer, label = Renderer(scene, ctx=ctx), f"{scene.name}_{_millions(triangles)}:{HALL_VIEW}"
            for size in SIZES:
                stages.append(_Stage(renderer, scene.camera(HALL_VIEW, *size), label))
                budgets.append(triangles)
        return _StageGroup(stages, budgets)

    sections.append(_Section(hall_stages, _hall_jobs, len(hall_triangles) * len(SIZES)))
    reasons = {} if reasons is None else reasons
    sections.append(_Section(lambda: _LineStages(ctx, quick, reasons), _frame_jobs,
                             sum(len(_frame_scales(size)) for size, _, _ in FRAME_SETTINGS) + len(PEERS)))
    return sections


# -- results -------------------------------------------------------------------------------------
def _find(figures, **match) -> Figure:
    hits = [f for f in figures if all(getattr(f, k) == v for k, v in match.items())]
    if len(hits) != 1:
        raise LookupError(f"expected one figure for {match}, found {len(hits)}")
    return hits[0]


def _rounds(a: Figure, b: Figure) -> list[float] | None:
    """The per-round ratios a / b of two figures timed in turns (one entry), in round order;
    None for figures timed apart."""
    if a.entry is not None and a.entry == b.entry and len(a.times_ms) == len(b.times_ms):
        return [x / y for x, y in zip(a.times_ms, b.times_ms)]
    return None


def _paired(a: Figure, b: Figure) -> tuple[float, list[float] | None]:
    """(a / b, its per-round ratios). For figures timed in turns (one entry), the median of the
    per-round ratios: a paired estimate, so that the machine speeding up or slowing down during
    the entry (seen: 10-20 % within one entry) cannot tilt it, as it can a ratio of two medians
    taken from different rounds. Otherwise the ratio of the medians (and no rounds)."""
    rounds = _rounds(a, b)
    return (float(median(rounds)) if rounds else a.median_ms / b.median_ms), rounds


def _ratio(a: Figure, b: Figure) -> float:
    return _paired(a, b)[0]


def _floor_ratios(figures) -> None:
    """Every AO figure over the fetch floor of the same scene, size, sample count and scale,
    timed in turns with it (:func:`_ratio`); None where no such floor was measured."""
    floors = {(f.scene, f.width, f.height, f.samples, f.scale): f for f in figures if f.name == "fetch_floor"}
    for f in figures:
        floor = floors.get((f.scene, f.width, f.height, f.samples, f.scale)) if f.name == "ao" else None
        f.over_fetch_floor = None if floor is None else _ratio(f, floor)


def _ratios(figures, reasons: dict | None = None) -> dict:
    """The issue's ratios (paired within one run, see :func:`_ratio`), and the first three at
    every sample count, as the report's ``ratios`` and ``ratios_by_samples``; beside each, its
    per-round ratios (``ratios_rounds``, ``ratios_by_samples_rounds``: how far one round can
    stray from the median). A peer ratio that could not be measured is None, with the peer's
    reason (``reasons``, by peer) beside it as ``<key>_reason``."""
    w, h = PAPER_SIZE

    def ao(mode, samples, scale=1.0, **extra):
        return _find(figures, name="ao", mode=mode, samples=samples, scale=scale, width=w, height=h, **extra)

    def floor(samples, triangles):
        return _find(figures, name="fetch_floor", samples=samples, scale=1.0, width=w, height=h, triangles=triangles)

    def at(samples):
        vector = ao("vector", samples, triangles=None)
        return {"vector_over_ssao": (vector, ao("ssao", samples, triangles=None)),
                "vector_over_fetch_floor": (vector, floor(samples, None)),
                "half_over_full": (ao("vector", samples, 0.5, triangles=None), vector)}

    samples_list = sorted({f.samples for f in figures if f.name == "fetch_floor" and (f.width, f.height) == PAPER_SIZE
                           and f.scale == 1.0 and f.triangles is None})
    by_samples = {str(n): at(n) for n in samples_list}
    pairs = dict(by_samples[str(RATIO_SAMPLES)])
    few, many = TRIANGLE_COUNTS
    pairs["ao_10m_over_1m"] = (ao("vector", RATIO_SAMPLES, triangles=many), ao("vector", RATIO_SAMPLES, triangles=few))
    pairs["vector_over_fetch_floor_covered"] = (ao("vector", RATIO_SAMPLES, triangles=few), floor(RATIO_SAMPLES, few))

    halls = {f.triangles: f for f in figures if f.name == "geometry" and f.stats.get("generated") == "hall"
             and (f.width, f.height) == PAPER_SIZE}
    pairs["geometry_20m_over_1m"] = (halls[20_000_000], halls[1_000_000])

    pw, ph = PEER_SIZE
    ours = _find(figures, name="frame", mode="vector", width=pw, height=ph, samples=PEER_SAMPLES, scale=1.0)
    ours_half = _find(figures, name="frame", mode="vector", width=pw, height=ph, samples=PEER_SAMPLES, scale=0.5)
    why = {}
    for peer, key in PEER_RATIOS.items():
        hits = [f for f in figures if f.name == "frame" and f.mode == peer]
        for name, mrcheck_frame in ((key, ours), (key + "_half_res_ao", ours_half)):
            pairs[name] = (hits[0], mrcheck_frame) if hits else None
            if not hits:
                why[name] = (reasons or {}).get(peer, f"no {peer} frame was measured")

    ratios, rounds = {}, {}
    for name, pair in pairs.items():
        ratios[name], rounds[name] = (None, None) if pair is None else _paired(*pair)
        if name in why:
            ratios[name + REASON] = why[name]
    paired = {n: {k: _paired(*p) for k, p in r.items()} for n, r in by_samples.items()}
    return {"ratios": ratios, "ratios_rounds": rounds,
            "ratios_by_samples": {n: {k: v[0] for k, v in r.items()} for n, r in paired.items()},
            "ratios_by_samples_rounds": {n: {k: v[1] for k, v in r.items()} for n, r in paired.items()},
            "reasons": why}


def _machine(ctx: moderngl.Context) -> dict:
    info = ctx.info
    cpu_model = None
    try:
        with open("/proc/cpuinfo") as cpuinfo:  # Linux only; None elsewhere
            models = [line.split(":", 1)[1].strip() for line in cpuinfo if line.startswith("model name")]
        cpu_model = models[0] if models else None
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"gl_renderer": info["GL_RENDERER"], "gl_vendor": info["GL_VENDOR"], "gl_version": info["GL_VERSION"],
            "cpu_count": os.cpu_count(), "cpus_usable": usable, "cpu_model": cpu_model,
            "lp_num_threads": os.environ.get("LP_NUM_THREADS"), "python": platform.python_version(),
            "platform": platform.platform(), "numpy": np.__version__, "moderngl": moderngl.__version__}


def _format_table(figures) -> str:
    header = ("figure", "mode", "scene", "size", "samples", "scale", "min ms", "median ms", "max ms", "/ floor",
              "GTX285 ms", "peak MB")
    rows = [header]
    for f in figures:
        rows.append((f.name, f.mode or "", f.scene, f"{f.width}x{f.height}", str(f.samples or ""),
                     "" if f.scale is None else ("full" if f.scale == 1.0 else "half"),
                     f"{min(f.times_ms):.1f}", f"{f.median_ms:.1f}", f"{max(f.times_ms):.1f}",
                     "" if f.over_fetch_floor is None else f"{f.over_fetch_floor:.2f}",
                     "" if f.paper_ms is None else f"{f.paper_ms:.1f}",
                     "" if f.peak_rss_mb is None else f"{f.peak_rss_mb:.0f}"))
    widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
    numeric = range(4, len(header))
    lines = ["  ".join(c.rjust(wd) if i in numeric else c.ljust(wd) for i, (c, wd) in enumerate(zip(r, widths)))
             .rstrip() for r in rows]
    lines.insert(1, "-" * len(lines[0]))
    return "\n".join(lines)


def _spread(rounds: list | None) -> str:
    """How far the rounds of a paired ratio strayed, e.g. ``(rounds 1.18-2.24)``."""
    if not rounds:
        return ""
    if len(rounds) == 1:
        return "(1 round)"
    return f"(rounds {min(rounds):.2f}-{max(rounds):.2f})"


def _format_ratios(measured: dict, run: dict) -> str:
    """The ratios against their targets, each with its per-round spread, then by sample count."""
    ratios, rounds = measured["ratios"], measured["ratios_rounds"]
    by_samples, by_samples_rounds = measured["ratios_by_samples"], measured["ratios_by_samples_rounds"]
    width = max(len(name) for name in ratios if not name.endswith(REASON))

    def shown(value, spread):
        return f"{'null' if value is None else format(value, '.3f'):>6} {spread:<21}"

    lines = [f"ratios (median of per-round ratios, this run; {RATIO_SAMPLES} samples, {PAPER_SIZE[0]}x{PAPER_SIZE[1]}):"]
    if run["quick"]:
        rounds_run = f"{run['repeat']} round" + ("s" if run["repeat"] != 1 else "")
        lines.append(f"  --quick: verdicts from {rounds_run} are indicative; targets are judged on full runs")
    for name, value in ratios.items():
        if name.endswith(REASON):
            continue  # printed on its ratio's line
        why = ratios.get(name + REASON)
        head = f"  {name:<{width}}  {shown(value, _spread(rounds.get(name)))}"
        if name in PEER_TARGETS:  # a minimum: mrcheck's frame must be that many times faster
            verdict = f"(not run: {why})" if value is None else ("meets" if value >= PEER_TARGETS[name] else "MISSES")
            lines.append(f"{head}  target >= {PEER_TARGETS[name]:.2f}  {verdict}  "
                         f"(peer frame / mrcheck frame, {PEER_SIZE[0]}x{PEER_SIZE[1]}, {PEER_SAMPLES} samples, "
                         f"blur {PEER_BLUR})")
        elif name not in TARGETS:  # measured for information, no target (e.g. the peers at half-resolution AO)
            lines.append(f"{head}  (no target" + (f"; not run: {why})" if value is None else ")"))
        else:
            verdict = "meets" if value <= TARGETS[name] else "MISSES"
            if name in EVERY_SAMPLE_COUNT and len(by_samples) > 1:  # the verdict over every count
                meets = [n for n, r in by_samples.items() if r[name] <= TARGETS[name]]
                misses = [n for n in by_samples if n not in meets]
                verdict = ("meets at every sample count measured" if not misses else
                           "; ".join(([f"meets at {', '.join(meets)}"] if meets else [])
                                     + [f"MISSES at {', '.join(misses)}"]) + " samples")
            lines.append(f"{head}  target <= {TARGETS[name]:.2f}  {verdict}")
    lines.append(f"by samples, sample scene at {PAPER_SIZE[0]}x{PAPER_SIZE[1]}:")
    for name in next(iter(by_samples.values()), {}):
        for n, r in by_samples.items():
            if name in EVERY_SAMPLE_COUNT or n == str(RATIO_SAMPLES):
                verdict = "meets" if r[name] <= TARGETS[name] else "MISSES"
            else:
                verdict = f"(target at {RATIO_SAMPLES} only)"
            lines.append(f"  {name:<{width}}  {n:>3}  {shown(r[name], _spread(by_samples_rounds[n][name]))}"
                         f"  target <= {TARGETS[name]:.2f}  {verdict}")
    return "\n".join(line.rstrip() for line in lines)


# -- the command ---------------------------------------------------------------------------------
def _run(quick: bool, repeat: int) -> tuple[list[Figure], dict, dict, dict]:
    """Measure the plan: the figures, the machine, the reasons of the peers that did not run,
    and the peak memory of the whole run (with how the figures' peaks were taken)."""
    from tqdm import tqdm

    ctx = create_context()
    figures, reasons, memory = [], {}, _PeakMemory()
    try:
        with made_current(ctx):
            machine = _machine(ctx)
            sections = _plan(ctx, quick, reasons)
            with tqdm(total=sum(s.count for s in sections), desc="bench", unit="figure", file=sys.stderr) as bar:
                for section in sections:
                    stage = section.make_stage()
                    entries = section.jobs(stage)
                    bar.total += sum(map(len, entries)) - section.count  # a peer that did not start: no job
                    bar.refresh()
                    for entry in entries:
                        measured = _measure(entry, repeat, memory)
                        figures.extend(measured)
                        bar.set_postfix_str(measured[-1].describe())
                        bar.update(len(entry))  # a peer that failed mid-run was still timed up to then
                    if section.release_after:
                        stage.release()
                    del stage  # before the next section builds its scene (10 M triangles)
    finally:
        ctx.release()
    return figures, machine, reasons, memory.report()


def _print_report(report: dict, figures: list[Figure]) -> None:
    machine = report["machine"]
    print(_format_table(figures))
    print()
    print(_format_ratios(report, report["run"]))
    print()
    print(f"machine: {machine['gl_renderer']}, {machine['cpus_usable']} of {machine['cpu_count']} CPUs usable, "
          f"Python {machine['python']}; {report['run']['repeat']} timed runs per figure after 1 warm-up; "
          f"peak RSS {report['peak_rss_mb']:.0f} MB over the whole run")
    for f in figures:
        if f.name == "frame" and "png" in f.stats:  # the frames the peer ratios compare, to look at
            print(f"frame {f.mode}: {f.stats['png']}" + (f" ({f.stats['peer']})" if "peer" in f.stats else ""))
    for scene, triangles in {f.scene: f.triangles for f in figures if f.name == "frame" and f.triangles}.items():
        print(f"{scene}: the line scene the project ships, {triangles:,} triangles (the issue names a 1 M-triangle "
              "line scene)")
    print("/ floor: an AO pass over the fetch floor of its size, samples and resolution (same depth fetches, "
          "trivial arithmetic), timed in turns with it.")
    print(f"peak MB: {report['peak_rss_per_figure']}.")
    print("GTX285 ms: Scheer & Keutel's own method (vector) on a GTX 285 at 1280x1024, Table 1 (AO pass) and "
          "Table 2 (blur; whole frame at 16 samples with 13x13, 36 with 9x9), on their scene, for comparison.")


def bench_command(quick: bool, json_path: str | None, repeat: int | None) -> dict:
    """Measure, write the JSON if asked, then print the table and ratios; returns the report."""
    if json_path is not None:
        json_path = check_output_path(json_path, (".json",), "JSON output")  # fail before minutes of work
    repeat = repeat or (QUICK_REPEAT if quick else DEFAULT_REPEAT)

    figures, machine, reasons, memory = _run(quick, repeat)
    measured = _ratios(figures, reasons)
    _floor_ratios(figures)
    report = {"machine": machine, "run": {"quick": quick, "repeat": repeat, "warmup": 1},
              "figures": [f.to_json() for f in figures], **measured, "targets": TARGETS, "peer_targets": PEER_TARGETS,
              "target_samples": {name: "every" if name in EVERY_SAMPLE_COUNT else RATIO_SAMPLES
                                 for name in measured["ratios_by_samples"].get(str(RATIO_SAMPLES), {})},
              **memory}
    if json_path is not None:
        # before printing: a reader that goes away (`mrcheck bench --json X | head`) breaks the
        # prints, and must not cost the minutes of measurements
        write_text(json_path, json.dumps(report, indent=2))
    _print_report(report, figures)
    if json_path is not None:
        print(json_path)
    return report


__all__ = ["bench_command", "terrain_scene", "terrain_camera", "Figure", "TARGETS", "PAPER_AO_MS"]
