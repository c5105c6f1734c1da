"""``mrcheck bench --accumulate``: progressive AO (``--accumulate N``) against one frame.

On one view (the bench: the generated hall's ``aisle``, 5 M triangles, 640x480; ``--quick``
320x240), the vector mode with 16 samples is rendered with N = 1, 2, 4, 8 and 16 frames and
judged three ways, on the pixels the G-buffer covers:

* **noise**: the RMS difference from the same mode converged (128 samples, 32 frames), raw and
  blurred (each against the converged render of the same blur);
* **point reference**: the RMSE against the ray-traced AO (:func:`mrcheck.eval.reference.reference_ao`)
  at the pixel centres of the frame's G-buffer, as ``mrcheck compare`` judges every mode (that
  reference carries the rib moire of the pixel grid itself);
* **footprint reference**: the RMSE against the mean of ray-traced AO from the same sub-pixel
  offsets the accumulation uses (:func:`mrcheck.render.passes.subpixel_offset`), which is what
  the accumulated AO estimates.

Plus the seconds per render (warm, median over the rounds). The G-buffer is single-sampled at
full detail, as ``compare``'s (the references start their rays from its points).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from mrcheck.core.output import check_output_path, write_text
from mrcheck.eval.metrics import covered
from mrcheck.eval.reference import REFERENCE_LOD_PX, reference_ao
from mrcheck.render.passes import jittered, subpixel_offset
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import load_scene

FRAMES = (1, 2, 4, 8, 16)
CONVERGED_SAMPLES, CONVERGED_FRAMES = 128, 32
MODE = "vector"


@dataclass(frozen=True)
class BenchSize:
    """What a run measures at: image size, reference rays per pixel (point reference), the
    footprint reference's offsets and rays per offset, timing rounds."""

    width: int
    height: int
    rays: int
    footprint_offsets: int
    footprint_rays: int
    rounds: int


FULL = BenchSize(640, 480, 128, 16, 32, 3)
QUICK = BenchSize(320, 240, 32, 8, 8, 1)


@dataclass
class AccumulateRow:
    """One frame count's figures (see the module docstring)."""

    frames: int
    seconds: float
    noise_raw: float
    noise_blurred: float
    rmse_point: float
    rmse_footprint: float
    rmse_point_blurred: float
    rmse_footprint_blurred: float


def accumulate_bench(scene_path, view: str, size: BenchSize, frames=FRAMES, json_path=None, progress=None) -> list:
    """Measure ``frames`` on ``view`` of the scene at ``scene_path``; rows of
    :class:`AccumulateRow`; ``json_path``: also written there (the rows and the set-up)."""
    if json_path is not None:
        json_path = check_output_path(json_path, (".json",), "JSON")
    say = progress or (lambda text: None)
    scene = load_scene(scene_path)
    camera = scene.camera(view, size.width, size.height)
    base = RenderSettings(lod_px=REFERENCE_LOD_PX, antialias=False).validated(camera.height)
    renderer = Renderer(scene)
    try:
        say("references")
        point, footprint, mask = _references(scene, renderer, camera, base, size)
        say("converged renders")
        converged = {blur: _ao(renderer, camera, base, CONVERGED_FRAMES, blur, CONVERGED_SAMPLES) for blur in (0, 1)}
        rows = []
        for n in frames:
            say(f"{n} frames")
            rows.append(_row(renderer, camera, base, n, size.rounds, converged, point, footprint, mask))
    finally:
        renderer.release()
    if json_path is not None:
        setup = {"scene": str(Path(scene_path).resolve()), "view": view, **asdict(size), "mode": MODE}
        write_text(json_path, json.dumps({"setup": setup, "rows": [asdict(r) for r in rows]}, indent=1) + "\n")
    return rows


def _ao(renderer, camera, base, frames: int, blur: int, samples: int = 16) -> np.ndarray:
    settings = replace(base, samples=samples, accumulate=frames, blur=bool(blur))
    return renderer.render(camera, [MODE], settings, want_ao=True)[MODE].ao


def _references(scene, renderer, camera, base, size: BenchSize):
    """(point reference, footprint reference, covered mask) of the frame's pixels."""
    frame = renderer.render(camera, ["phong"], base, want_normals=True)
    mask = covered(frame.depth)
    point = _traced(scene, camera, frame, size.rays, base)
    total = np.zeros_like(point)
    for k in range(size.footprint_offsets):
        moved = jittered(camera, subpixel_offset(k))
        shifted = renderer.render(moved, ["phong"], base, want_normals=True)
        traced = _traced(scene, moved, shifted, size.footprint_rays, base, seed=k)
        total += np.where(shifted.depth > 0, traced, 1.0)  # background counts as unoccluded, as accumulated
    return point, total / size.footprint_offsets, mask


def _traced(scene, camera, frame, rays: int, base, seed: int = 0) -> np.ndarray:
    return reference_ao(scene, camera, frame.depth, frame.normals, rays, "screen", base.radius_px, base.falloff, seed)


def _row(renderer, camera, base, n, rounds, converged, point, footprint, mask) -> AccumulateRow:
    aos, seconds = {}, []
    for _ in range(rounds):
        began = time.perf_counter()
        aos[1] = _ao(renderer, camera, base, n, 1)
        seconds.append(time.perf_counter() - began)
    aos[0] = _ao(renderer, camera, base, n, 0)

    def rms(a, b):
        return float(np.sqrt(np.mean((a - b)[mask] ** 2)))

    return AccumulateRow(
        frames=n,
        seconds=float(np.median(seconds)),
        noise_raw=rms(aos[0], converged[0]),
        noise_blurred=rms(aos[1], converged[1]),
        rmse_point=rms(aos[0], point),
        rmse_footprint=rms(aos[0], footprint),
        rmse_point_blurred=rms(aos[1], point),
        rmse_footprint_blurred=rms(aos[1], footprint),
    )


def table_lines(rows: list, label: str) -> list:
    """The rows as a text table, with each figure's ratio to one frame's."""
    first = rows[0]
    lines = [
        f"progressive AO, {label}: vector, 16 samples; noise = RMS to {CONVERGED_SAMPLES} samples x "
        f"{CONVERGED_FRAMES} frames; references ray-traced (point: pixel centres; footprint: the sub-pixel offsets)",
        "frames | s per render | noise raw / blurred | RMSE point ref raw / blurred | RMSE footprint ref raw / blurred",
    ]
    for r in rows:
        lower = (first.noise_raw / max(r.noise_raw, 1e-9), first.noise_blurred / max(r.noise_blurred, 1e-9))
        lines.append(
            f"{r.frames:6d} | {r.seconds:12.2f} | {r.noise_raw:.4f} / {r.noise_blurred:.4f} "
            f"({lower[0]:.1f}x / {lower[1]:.1f}x lower) | {r.rmse_point:.4f} / {r.rmse_point_blurred:.4f} | "
            f"{r.rmse_footprint:.4f} / {r.rmse_footprint_blurred:.4f}"
        )
    return lines


__all__ = ["accumulate_bench", "table_lines", "AccumulateRow", "BenchSize", "FULL", "QUICK", "FRAMES"]
