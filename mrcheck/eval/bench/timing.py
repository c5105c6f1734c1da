"""Timing: a figure's job, the stage it runs on (a renderer's passes from one camera), the
fetch floor, the peak memory of an entry, and :func:`measure`, which times an entry's jobs in
turns.

Every figure is measured in the run that prints it: one warm-up draw, then ``repeat`` timed
draws through :meth:`Stage.timed` (``ctx.finish()`` before and after, so a figure is the GL work
of that pass, including llvmpipe's rasterisation threads).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Callable

import moderngl
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.eval.bench.figures import RATIO_SAMPLES, TRIANGLE_COUNTS, Figure
from mrcheck.eval.bench.peers import peak_rss_mb, reset_peak_rss
from mrcheck.render.ao.base import draw_covered
from mrcheck.render.ao.kernel import sphere_kernel
from mrcheck.render.gl import load_program, made_current
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.render.settings import DEFAULT_BLUR_SIZE


@dataclass
class Job:
    """A figure to measure: ``setup`` leaves the GL state the pass reads, ``work`` is the pass."""

    figure: Figure
    setup: Callable[[], None]
    work: Callable[[], None]


class FetchFloor:
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
        draw_covered(self.ctx, target, self.vao)  # the background skipped as in the AO passes

    def release(self) -> None:
        self.vao.release()


class Stage:
    """A renderer and camera: every figure of one scene at one image size starts here, through the
    renderer's public passes (:meth:`mrcheck.render.renderer.Renderer.passes`). ``timed`` and
    ``ctx`` are what :func:`measure` needs of a stage (a peer's stage has them too)."""

    def __init__(self, renderer: Renderer, camera: Camera, label: str):
        self.renderer = renderer
        self.camera = camera
        self.label = label
        self.ctx = renderer.ctx
        self.passes = renderer.passes(camera)
        self._floors = {}
        # levels of detail loaded or built before timing, as a long-running program has them (a first
        # render builds only those of parts with many instances; see mrcheck.render.lod)
        with made_current(self.ctx):
            renderer.geometry.prepare_levels()

    def timed(self, work) -> float:
        """Milliseconds of the GL work of ``work()`` (``ctx.finish()`` before and after)."""
        return self.passes.timed(work)

    def settings(
        self, samples: int = RATIO_SAMPLES, scale: float = 1.0, blur: int = DEFAULT_BLUR_SIZE
    ) -> RenderSettings:
        """The CLI's defaults at this sample count, AO scale and blur, resolved for this image."""
        return RenderSettings(samples=samples, ao_scale=scale, blur_size=blur).validated(self.camera.height)

    def draw_geometry(self) -> dict:
        return self.passes.geometry()

    def ao(self, mode: str, settings: RenderSettings) -> None:
        self.passes.ao(mode, settings)

    def blur(self, size: int, scale: float) -> None:
        self.passes.blur(size, scale)

    def composite(self, scale: float) -> None:
        self.passes.composite(scale)

    def read_back(self) -> np.ndarray:
        return self.passes.read_rgb()

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
            self._floors[key] = FetchFloor(self.ctx, samples, settings.radius_px, settings.seed, stride)
        with made_current(self.ctx):
            self._floors[key].run(self.passes.scratch(scale), self.passes.targets.gbuffer.depth)

    def release(self) -> None:
        """Free the fetch floors and the renderer (which stages of one scene may share: a second
        release of it does nothing)."""
        for floor in self._floors.values():
            floor.release()
        self.renderer.release()


class StageGroup:
    """Stages alive together so that their passes can be timed in turns (the height fields, the
    halls), and the triangle budget of each; stages of one scene at two sizes share a renderer."""

    def __init__(self, stages, triangles=TRIANGLE_COUNTS):
        self.stages = stages
        self.triangles = triangles

    def release(self) -> None:
        for stage in self.stages:
            stage.release()


ENTRIES = itertools.count()


class PeakMemory:
    """The bench process's peak resident memory per entry (reset before it, read after) and
    over the whole run. A reset lowers ``ru_maxrss`` too, so the whole run's peak is the largest
    reading, one taken before every reset included (scenes load between entries)."""

    def __init__(self):
        self.whole_mb = peak_rss_mb()
        self.per_entry = True  # False once a reset failed: a figure's peak is then since the start

    def start(self) -> None:
        self.whole_mb = max(self.whole_mb, peak_rss_mb())
        self.per_entry = reset_peak_rss() and self.per_entry

    def stop(self) -> float:
        peak = peak_rss_mb()
        self.whole_mb = max(self.whole_mb, peak)
        return peak

    def report(self) -> dict:
        self.stop()
        how = (
            "the bench process's peak during the figure's entry (VmHWM, reset through /proc/self/clear_refs "
            "before each entry)"
            if self.per_entry
            else "the bench process's peak since it started (never reset: /proc/self/clear_refs could not be written)"
        )
        return {
            "peak_rss_mb": self.whole_mb,
            "peak_rss_per_figure": how + "; a peer's: its worker's peak over its frames, reset before each",
        }


def measure(entry: list, repeat: int, memory: PeakMemory | None = None) -> list[Figure]:
    """Time the jobs of one entry in turns: each job's setup and warm-up, then ``repeat`` rounds
    of one run of every job. A ratio must hold within 10 %, about the drift of this machine over
    a minute; taken in turns, the drift falls on both sides of the ratio alike. The G-buffer
    and AO buffers a job's setup leaves persist because the jobs of one entry on one stage
    write different targets (full/half resolution, AO/floor), or live in different renderers.
    Every figure gets the peak resident memory of the entry (a peer's, its worker's own)."""
    memory = memory or PeakMemory()
    memory.start()
    tag = next(ENTRIES)
    for stage, job in entry:
        job.figure.entry = tag
        with made_current(stage.ctx):
            job.setup()
            stage.timed(job.work)  # warm-up: shader compile/JIT, first touch of buffers
    for _ in range(repeat):
        for stage, job in entry:
            with made_current(stage.ctx):
                job.setup()
                job.figure.times_ms.append(stage.timed(job.work))
    peak = memory.stop()
    for stage, job in entry:
        job.figure.peak_rss_mb = getattr(stage, "peak_rss_mb", peak)  # a peer's worker reports its own
    return [job.figure for stage, job in entry if getattr(stage, "failed", None) is None]  # a failed peer: none


__all__ = ["Job", "FetchFloor", "Stage", "StageGroup", "PeakMemory", "measure"]
