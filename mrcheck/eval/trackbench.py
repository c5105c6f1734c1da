"""``mrcheck bench --track``: the speed and drift of ``mrcheck track`` on walk videos made here.

Walks (:mod:`mrcheck.eval.walks`: Open3D photos of a camera walked along a path, at 640x480):
the generated cell from its ``robot_cell`` and ``overview`` viewpoints, each ``side``,
``forward`` and ``left``, and the crate scene (lens distortion) ``side``; 24 frames each
(``--quick``: ``robot_cell`` side and the crates, 12 frames). Every walk is tracked by
:func:`mrcheck.apps.track.track_command` (what ``mrcheck track`` runs: the inputs checked, the
scene loaded from its files, the video read, the snaps, the overlay video and ``poses.jsonl``
written) in a process of its own, as a user's command runs (in one long process every run after
the first would find the modules imported, the shaders compiled and the memory warm),
``rounds`` times, the walks interleaved (the machine's speed drifts between minutes: measured
20-30 % on this 2-core machine). Per walk the figures are the frames per second of the whole run
(``TrackResult.seconds``: from the video opened to the files written; the start-up and the
first frame's full snap from the rough pose included, the Python start and the scene's loading
not) and after the first frame, the first frame's seconds, and the median and worst
reprojection error of the frames' poses on the scene points against the true path.

It lives in ``apps`` (not ``eval``) because what it times is the app.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from mrcheck.apps.track import TrackResult, track_command
from mrcheck.core.camerafiles import write_camera
from mrcheck.core.output import check_output_path, write_text
from mrcheck.eval.edgephotos import reprojection_error
from mrcheck.eval.walks import Walk, make_walk

TARGET_FPS = 5.0  # issue 20's speed target at 640x480
FRAMES, QUICK_FRAMES = 24, 12
ROUNDS, QUICK_ROUNDS = 3, 1


@dataclass
class TrackRun:
    """One tracked run of one walk (see the module docstring); ``times_s`` the run's seconds per
    stage (:attr:`mrcheck.apps.track.TrackResult.times_s`)."""

    walk: str
    frames: int
    seconds: float
    fps: float
    fps_after_first: float
    first_s: float
    error_median_px: float
    error_max_px: float
    lost: int
    times_s: dict = field(default_factory=dict)


def run_walk(walk: Walk, manifest: Path, folder: Path, outline: bool = False) -> TrackRun:
    """Track ``walk`` over the scene of ``manifest`` once, in a fresh process (outputs into
    ``folder``, removed after), and measure it; ``outline``: ``track --outline``."""
    folder = Path(folder)
    camera, rough = folder / f"{walk.name}.cam.json", folder / f"{walk.name}.rough.json"
    write_camera(camera, walk.camera, pose=False)
    write_camera(rough, walk.rough)
    output = folder / f"{walk.name}-overlay.mp4"
    poses = output.with_suffix(".poses.jsonl")
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
            result = pool.submit(_track, walk.video, manifest, camera, rough, output, outline).result()
    finally:
        for path in (output, poses, camera, rough):
            path.unlink(missing_ok=True)
    errors = [
        float(np.median(reprojection_error(truth, frame.camera, walk.points)))
        for truth, frame in zip(walk.truths, result.frames)
    ]
    return TrackRun(
        walk.name,
        len(result.frames),
        result.seconds,
        result.fps,
        result.fps_after_first,
        result.first_s,
        float(np.median(errors)),
        float(np.max(errors)),
        len(result.lost),
        dict(result.times_s),
    )


def _track(video, manifest, camera, rough, output, outline) -> TrackResult:
    """The child process's work: the command's own function."""
    return track_command(video, manifest, camera, rough, output, outline=outline)


@dataclass
class WalkPlan:
    """A walk to make: ``motion`` (:data:`mrcheck.eval.walks.MOTIONS`) of ``frames`` frames from
    ``camera`` over ``scene`` (photographed), tracked over the scene of ``manifest`` (its files);
    ``key``: the bytes the scene depends on (its files' contents)."""

    name: str
    scene: object
    manifest: Path
    camera: object
    motion: str
    frames: int
    key: bytes = b""


def bench_plan(quick: bool, folder: Path) -> list[WalkPlan]:
    """The walks of the module docstring (the crate scene written as files into ``folder``)."""
    from mrcheck.core.resources import shipped_scene
    from mrcheck.eval.edgescenes import crate_camera, crate_scene, write_crate_scene
    from mrcheck.scene.manifest import scene_files
    from mrcheck.scene.model import load_scene

    frames = QUICK_FRAMES if quick else FRAMES
    manifest = shipped_scene("cell")
    cell = load_scene(manifest)
    key = b"".join(path.read_bytes() for path in scene_files(manifest))
    views = ("robot_cell",) if quick else ("robot_cell", "overview")
    motions = ("side",) if quick else ("side", "forward", "left")
    plan = [
        WalkPlan(f"cell-{view}-{motion}", cell, manifest, cell.camera(view, 640), motion, frames, key)
        for view in views
        for motion in motions
    ]
    crates = write_crate_scene(Path(folder) / "crates-scene")
    return plan + [WalkPlan("crates-side", crate_scene(), crates, crate_camera(640, 480), "side", frames)]


def track_bench(
    quick: bool = False, rounds: int | None = None, json_path=None, progress=None, folder=None, outline=False
) -> tuple:
    """``(runs, lines)``: every :class:`TrackRun` and the table of :func:`summary_lines`;
    ``outline``: the walks tracked with ``track --outline`` (the title says so);
    ``json_path``: the runs written there as JSON too (checked before the work, written before
    the table is made); ``progress(done, total, label)`` in frames (each photo made, a walk found
    made at once, and each frame tracked). The walks are kept in ``folder`` (default
    ``<tmp>/mrcheck-bench/walks/``), made again when their digest changes."""
    if json_path is not None:
        json_path = check_output_path(json_path, (".json",), "JSON output")
    rounds = rounds or (QUICK_ROUNDS if quick else ROUNDS)
    folder = Path(folder) if folder is not None else Path(tempfile.gettempdir()) / "mrcheck-bench" / "walks"
    plan = bench_plan(quick, folder)
    total, done = sum(p.frames for p in plan) * (1 + rounds), 0

    def step(count: int, label: str) -> None:
        nonlocal done
        done += count
        if progress:
            progress(done, total, label)

    walks = []
    for entry in plan:
        made = done
        walk = make_walk(
            entry.scene,
            entry.camera,
            entry.motion,
            entry.frames,
            folder,
            entry.name,
            key=entry.key,
            progress=lambda k, n, name=entry.name: step(1, f"{name}: photo {k} of {n}"),
        )
        step(entry.frames - (done - made), f"{entry.name} ready")
        walks.append((walk, entry.manifest))
    runs = []
    with tempfile.TemporaryDirectory(prefix="mrcheck-trackbench-") as out:
        for round_ in range(rounds):
            for walk, manifest in walks:
                run = run_walk(walk, manifest, Path(out), outline)
                runs.append(run)
                step(run.frames, f"round {round_ + 1}, {walk.name}: {run.fps:.2f} frames/s")
    if json_path is not None:
        write_text(
            json_path,
            json.dumps(
                {
                    "quick": quick,
                    "rounds": rounds,
                    "outline": outline,
                    "target_fps": TARGET_FPS,
                    "runs": [asdict(run) for run in runs],
                },
                indent=2,
            ),
        )
    first = walks[0][0]
    title = (
        f"{len(walks)} walks of {len(first.truths)} frames at {first.camera.width}x{first.camera.height}, "
        f"{rounds} round{'s' if rounds > 1 else ''}{', --outline' if outline else ''}"
    )
    return runs, summary_lines(runs, title)


def summary_lines(runs: list, title: str) -> list[str]:
    """Per walk: frames/s (median and range over the rounds), after the first frame, the first
    frame's seconds, the errors and lost frames; then how many runs reached :data:`TARGET_FPS`
    and the stage times summed over all runs."""
    lines = [
        f"== mrcheck track: {title} ==",
        f"{'walk':<24} {'frames/s':>19} {'after 1st':>19} {'1st s':>5} {'err px':>6} {'max px':>6} {'lost':>4}",
    ]
    by_walk = {}
    for run in runs:
        by_walk.setdefault(run.walk, []).append(run)
    for name, mine in by_walk.items():
        whole, after = _spread([r.fps for r in mine]), _spread([r.fps_after_first for r in mine])
        lines.append(
            f"{name:<24} {whole:>19} {after:>19} "
            f"{np.median([r.first_s for r in mine]):5.2f} {np.median([r.error_median_px for r in mine]):6.2f} "
            f"{max(r.error_max_px for r in mine):6.2f} {max(r.lost for r in mine):4d}"
        )
    whole = sum(r.fps >= TARGET_FPS for r in runs)
    after = sum(r.fps_after_first >= TARGET_FPS for r in runs)
    lines.append(
        f"runs at {TARGET_FPS:g} frames/s or more: {whole} of {len(runs)} (whole run), {after} of {len(runs)} "
        f"(after the first frame); frames/s {min(r.fps for r in runs):.2f}-{max(r.fps for r in runs):.2f}"
    )
    stages, frames = {}, max(sum(r.frames for r in runs), 1)
    for run in runs:
        for stage, seconds in run.times_s.items():
            stages[stage] = stages.get(stage, 0.0) + seconds / frames
    largest = sorted(stages.items(), key=lambda kv: -kv[1])
    lines.append("ms per frame: " + ", ".join(f"{k} {1000 * v:.0f}" for k, v in largest if v >= 0.0005))
    return lines


def _spread(values: list) -> str:
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "-"
    if len(finite) == 1:
        return f"{finite[0]:.2f}"
    return f"{np.median(finite):.2f} ({min(finite):.2f}-{max(finite):.2f})"


__all__ = ["TrackRun", "WalkPlan", "run_walk", "bench_plan", "track_bench", "summary_lines", "TARGET_FPS"]
