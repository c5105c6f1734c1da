"""The ``line`` scene's whole frame against the peers (VTK's SSAO, Open3D's renderer with AO),
each peer in a worker process of its own (:mod:`mrcheck.eval.bench.peers`) that renders one frame
per request, so that mrcheck's frame and the peers' are timed in turns."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import moderngl

from mrcheck.core.output import write_image
from mrcheck.eval.bench import peer_client
from mrcheck.eval.bench.figures import (
    FRAME_PASSES,
    FRAME_SETTINGS,
    PEER_SIZE,
    Figure,
    millions,
    paper_frame_ms,
)
from mrcheck.eval.bench.peer_client import failure_reason, write_mesh
from mrcheck.eval.bench.peers import PEERS, ao_off_png
from mrcheck.eval.bench.scenes import flattened_mesh, line_scene_path
from mrcheck.eval.bench.timing import Job, Stage
from mrcheck.render.gl import made_current
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import Scene, load_scene


class PeerStage:
    """A peer's worker process (:mod:`mrcheck.eval.bench.peers`) as a stage of a
    :func:`mrcheck.eval.bench.timing.measure` entry: one frame per turn, timed inside the worker
    (render + read back). A worker that fails mid-run leaves its reason and no figure; it never
    stops the bench."""

    def __init__(self, ctx: moderngl.Context, worker, reasons: dict):
        self.ctx = ctx
        self.worker = worker
        self.reasons = reasons
        self.failed = None

    @property
    def peak_rss_mb(self) -> float | None:
        return self.worker.peak_rss_mb

    def timed(self, work) -> float:
        """The worker's time of one frame (``work``, mrcheck's side of the turn, does nothing)."""
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


def start_peers(ctx, scene: Scene, viewpoint: dict, reasons: dict, workdir: Path) -> list:
    """The peers whose workers start and render (one at a time, so neither set-up competes with
    the other); a peer that cannot gets its one-line reason in ``reasons``."""
    # the mesh is this run's own file (the folder is shared by every run), gone once loaded
    mesh = write_mesh(workdir / f"line_mesh.{os.getpid()}.npz", *flattened_mesh(scene), viewpoint, PEER_SIZE)
    peers = []
    try:
        for name in PEERS:
            if why := peer_client.importable(name):
                reasons[name] = why
                continue
            worker = peer_client.PeerWorker(name, mesh, workdir / f"{name}.png")
            for stale in (worker.png, ao_off_png(worker.png)):  # (the log is rewritten by start)
                stale.unlink(missing_ok=True)  # a previous run's, which a failing peer would leave
            try:
                worker.start().wait_ready()
                peers.append(PeerStage(ctx, worker, reasons))
            except Exception as exc:  # noqa: BLE001 -- whatever a peer does, it is its reason, not ours
                reasons[name] = failure_reason(exc)
                worker.stop()
    finally:
        mesh.unlink(missing_ok=True)  # the workers have loaded it
    return peers


class LineStages:
    """The ``line`` scene at both frame sizes (one renderer) and the peers at PEER_SIZE."""

    def __init__(self, ctx, quick: bool, reasons: dict):
        scene = load_scene(line_scene_path())
        view = next(iter(scene.viewpoints))
        renderer = Renderer(scene, ctx=ctx)
        self.triangles = scene.triangle_count
        label = f"{scene.name}_{millions(self.triangles)}:{view}"  # 1.5M: not the 1 M, said so
        self.stages = [Stage(renderer, scene.camera(view, *size), label) for size, _, _ in FRAME_SETTINGS]
        # the peers' frames and mrcheck's at their setting, kept to look at (see docs/performance.md)
        self.workdir = peer_folder()
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.png = self.workdir / "mrcheck.png"
        self.png.unlink(missing_ok=True)  # written again at the end of this run
        self.last_rgb = None
        with made_current(ctx):  # nothing the workers do touches this process's context, but be sure
            self.peers = start_peers(ctx, scene, scene.viewpoints[view], reasons, self.workdir)
        self.label = label

    def release(self) -> None:
        for peer in self.peers:
            peer.release()
        if self.last_rgb is not None:
            write_image(self.png, self.last_rgb)  # image rows top-down
        self.stages[0].release()  # the renderer the stages share


def frame_scales(size) -> tuple:
    """The AO scales of the line scene's frame at ``size``: at the peers' size half resolution
    too, the paper's option for slow GPUs (its ratios to the peers are reported beside)."""
    return (1.0, 0.5) if tuple(size) == PEER_SIZE else (1.0,)


def frame_jobs(group: LineStages) -> list[list]:
    """mrcheck's whole frame at each setting; at the peers' setting timed in turns with them."""
    entries = []
    for stage, (size, samples, blur) in zip(group.stages, FRAME_SETTINGS):
        entry = []
        for scale in frame_scales(size):  # full-resolution AO: the peers' ratios
            settings = stage.settings(samples, scale, blur)
            keep = size == PEER_SIZE and scale == 1.0

            def frame(stage=stage, settings=settings, keep=keep):
                rgb = stage.frame("vector", settings)
                if keep:
                    group.last_rgb = rgb

            stats = {"blur": blur, "passes": FRAME_PASSES}
            if keep:
                stats["png"] = str(group.png)
            figure = Figure(
                "frame",
                "vector",
                *size,
                samples,
                scale,
                stage.label,
                group.triangles,
                paper_frame_ms("vector", size, samples, scale, blur),
                stats=stats,
            )
            entry.append((stage, Job(figure, lambda: None, frame)))
        if size == PEER_SIZE:  # in turns: mrcheck frame, VTK frame, Open3D frame, ...
            for peer in group.peers:
                info = peer.worker.info
                figure = Figure(
                    "frame",
                    peer.worker.peer,
                    *size,
                    None,
                    None,
                    stage.label,
                    group.triangles,
                    stats={
                        "peer": info["version"],
                        "settings": info["settings"],
                        "png": info["png"],
                        "ao_effect": info["ao_effect"],
                        "setup_ms": info["setup_ms"],
                        "setup_peak_rss_mb": info.get("setup_peak_rss_mb"),
                        "timed": "render + read back RGB(A), inside the peer's worker process",
                    },
                )
                entry.append((peer, Job(figure, lambda: None, lambda: None)))
        entries.append(entry)
    return entries


__all__ = ["PeerStage", "LineStages", "start_peers", "peer_folder", "frame_jobs", "frame_scales"]
