"""``mrcheck bench``: time the AO passes on this machine and print what was measured.

Every figure is measured in the run that prints it, never written down: one warm-up draw, then
``repeat`` timed draws of the renderer's public passes (:meth:`Renderer.passes`, ``ctx.finish()``
before and after, so a figure is the GL work of that pass, including llvmpipe's rasterisation
threads). Reported: min / median / max in milliseconds, and the peak resident memory while the
figure was timed (:class:`mrcheck.eval.bench.timing.PeakMemory`). Ratios are paired: figures
compared are timed in turns, one run of each per round, and a ratio is the median of the
per-round ratios (:func:`mrcheck.eval.bench.report.ratio`).

The modules: :mod:`.figures` (settings, the paper's figures, the targets, ``Figure``),
:mod:`.scenes`, :mod:`.timing` (stages, ``measure``), :mod:`.plan`, :mod:`.line` (the line scene
and the peers' stages), :mod:`.report` (ratios, table), :mod:`.peers` / :mod:`.peer_client`
(the peers' worker processes); this one runs them.

What is timed (Scheer & Keutel, Tables 1 and 2, benchmarked at 1280x1024):

* the AO pass of every mode (``vector`` D2, ``ssao`` D3, and ``crytek``, ``hbao``, ``alchemy``, ``gtao``, ``vbao``)
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

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from mrcheck.core.output import check_output_path, write_text
from mrcheck.eval.bench.figures import (
    DEFAULT_REPEAT,
    EVERY_SAMPLE_COUNT,
    PAPER_AO_MS,
    PEER_TARGETS,
    QUICK_REPEAT,
    RATIO_SAMPLES,
    TARGETS,
    Figure,
)
from mrcheck.eval.bench.plan import plan
from mrcheck.eval.bench.report import floor_ratios, machine, ratios, report_text
from mrcheck.eval.bench.scans import scan_reading
from mrcheck.eval.bench.scenes import HallGenerator, terrain_camera, terrain_scene
from mrcheck.eval.bench.timing import PeakMemory, measure
from mrcheck.render.gl import create_context, made_current

# progress(figures measured, figures planned, the last one's label): the CLI's bar
Progress = Callable[[int, int, str], None]


def _no_progress(done: int, total: int, label: str) -> None:
    pass


def measure_plan(
    quick: bool, repeat: int, hall: HallGenerator, progress: Progress = _no_progress
) -> tuple[list[Figure], dict, dict, dict]:
    """Measure the plan: the figures, the machine, the reasons of the peers that did not run,
    and the peak memory of the whole run (with how the figures' peaks were taken)."""
    ctx = create_context()
    figures, reasons, memory = [], {}, PeakMemory()
    try:
        with made_current(ctx):
            about = machine(ctx)
            sections = plan(ctx, quick, hall, reasons)
            done, total = 0, sum(s.count for s in sections)
            progress(done, total, "")
            for section in sections:
                stage = section.make_stage()
                entries = section.jobs(stage)
                total += sum(map(len, entries)) - section.count  # a peer that did not start: no job
                for entry in entries:
                    measured = measure(entry, repeat, memory)
                    figures.extend(measured)
                    done += len(entry)  # a peer that failed mid-run was still timed up to then
                    progress(done, total, measured[-1].describe())
                if section.release_after:
                    stage.release()
                del stage  # before the next section builds its scene (10 M triangles)
    finally:
        ctx.release()
    return figures, about, reasons, memory.report()


@dataclass
class BenchResult:
    """A bench run: ``report`` (what the JSON holds), ``text`` (what the command prints) and
    ``json_path`` (the JSON written, or None)."""

    report: dict
    text: str
    json_path: Path | None


def bench_command(
    quick: bool, json_path: str | None, repeat: int | None, hall: HallGenerator, progress: Progress = _no_progress
) -> BenchResult:
    """Measure, write the JSON if asked (before anything is printed: a reader that goes away,
    ``mrcheck bench --json X | head``, must not cost the minutes of measurements), and return
    the report with the text to print."""
    if json_path is not None:
        json_path = check_output_path(json_path, (".json",), "JSON output")  # fail before minutes of work
    repeat = repeat or (QUICK_REPEAT if quick else DEFAULT_REPEAT)

    figures, about, reasons, memory = measure_plan(quick, repeat, hall, progress)
    scan_json, scan_lines = scan_reading(quick, repeat)  # each read in a process of its own
    imports = import_figures(quick, hall)  # the issue-19 import figures, None without an IFC writer
    measured = ratios(figures, reasons)
    floor_ratios(figures)
    report = {
        "machine": about,
        "run": {"quick": quick, "repeat": repeat, "warmup": 1},
        "figures": [f.to_json() for f in figures],
        **measured,
        "targets": TARGETS,
        "peer_targets": PEER_TARGETS,
        "target_samples": {
            name: "every" if name in EVERY_SAMPLE_COUNT else RATIO_SAMPLES
            for name in measured["ratios_by_samples"].get(str(RATIO_SAMPLES), {})
        },
        **memory,
        "scan_reading": scan_json,
    }
    if imports is not None:
        report["imports"] = imports.to_json()
    if json_path is not None:  # before the text is made: nothing after the measurements may lose them
        write_text(json_path, json.dumps(report, indent=2))
    lines = [report_text(report, figures), *scan_lines]
    if imports is not None:
        lines += ["", "Imports:", *imports.lines()]
    return BenchResult(report, "\n".join(lines), json_path)


IMPORT_HALL_TRIANGLES = 5_000_000  # the hall; --quick: 1 M, one round
STEP_MODELS = Path(__file__).resolve().parents[3] / "tests" / "data" / "cad" / "step"  # in a checkout


def import_figures(quick: bool, hall: HallGenerator):
    """The import figures (:func:`mrcheck.eval.bench.imports.measure_imports`) of the generated
    hall written as IFC and the STEP test models; None when ``hall`` cannot write IFC."""
    if hall.write_ifc is None:
        return None
    import tempfile

    from mrcheck.eval.bench.imports import measure_imports
    from mrcheck.eval.bench.scenes import hall_ifc_path

    ifc = hall_ifc_path(hall, 1_000_000 if quick else IMPORT_HALL_TRIANGLES)
    steps = sorted(STEP_MODELS.glob("*.st*p")) if STEP_MODELS.is_dir() else []
    with tempfile.TemporaryDirectory(prefix="mrcheck-bench-import-") as work:
        return measure_imports(ifc, steps, Path(work), rounds=1 if quick else 3)


__all__ = [
    "bench_command",
    "measure_plan",
    "BenchResult",
    "HallGenerator",
    "terrain_scene",
    "terrain_camera",
    "Figure",
    "TARGETS",
    "PAPER_AO_MS",
]
