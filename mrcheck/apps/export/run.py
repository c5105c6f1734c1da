"""The export of a whole job (:func:`run_export`): plan the shots, skip the finished ones, run the
others (:mod:`.execute`), write the manifest and the report; what happened is returned
(:class:`ExportResult`) for the command line to print. Progress goes to a callback."""

from __future__ import annotations

import json
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from mrcheck.apps.export.execute import connect, local_workers, run_dask, run_local
from mrcheck.apps.export.folders import (
    prepare_folder,
    remove_stale,
    store_failure,
    store_shot,
)
from mrcheck.apps.export.job import Job, load_job
from mrcheck.apps.export.report import write_report
from mrcheck.apps.export.tasks import ShotRecord, finished_record, make_tasks
from mrcheck.apps.names import MANIFEST, REPORT
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.inputs import real_path
from mrcheck.core.output import check_not_inputs, check_writable_ancestor, write_text
from mrcheck.render.settings import MAX_ACCUMULATE
from mrcheck.scene.manifest import scene_files

STATUSES = ("done", "skipped", "failed")


@dataclass(frozen=True)
class ShotProgress:
    """One step of an export: the start (``name`` None; ``done`` counts the skipped shots), then
    every shot as it finishes."""

    done: int  # shots finished or skipped so far
    total: int  # shots of the job
    name: str | None = None  # the shot that just finished
    status: str | None = None  # its status: "done" or "failed"
    eta_s: float | None = None  # the time the shots still to run will take, at the pace so far
    failed: int = 0  # shots failed so far


@dataclass(frozen=True)
class ExportResult:
    manifest: dict  # as written to OUTDIR/manifest.json
    outdir: Path

    @property
    def failed(self) -> bool:
        return self.manifest["summary"]["failed"] > 0

    def summary(self) -> list:
        """The lines the command prints: the counts, each failure, the shots with registration
        warnings, the files removed, and what was written."""
        shots, counts = self.manifest["shots"], self.manifest["summary"]
        lines = [
            f"export: {counts['shots']} shots: {counts['done']} done, {counts['skipped']} skipped, "
            f"{counts['failed']} failed ({self.manifest['timings_s']['total']:.1f} s)"
        ]
        lines += [f"  failed {e['name']}: {e['error']}" for e in shots if e["status"] == "failed"]
        warned = [e["name"] for e in shots if e["status"] == "done" and (e.get("registration") or {}).get("warnings")]
        if warned:
            lines.append(
                f"  {len(warned)} shot(s) with registration warnings ({', '.join(warned[:5])}"
                f"{', ...' if len(warned) > 5 else ''}): see {REPORT}"
            )
        if removed := self.manifest["removed"]:
            # removed paths are shots/NAME/FILE; a NAME no longer in the job is a dropped shot
            dropped = {p.split("/")[1] for p in removed} - {e["name"] for e in shots}
            of_shots = f", including the outputs of {len(dropped)} shot(s) no longer in the job" if dropped else ""
            lines.append(
                f"removed {len(removed)} file(s) of earlier runs that this job no longer produces{of_shots} "
                f"(listed in {MANIFEST})"
            )
        lines.append(f"wrote {self.outdir / MANIFEST} and {self.outdir / REPORT}")
        return lines


def _make_outdir(outdir: Path) -> None:
    """Create OUTDIR and check that it takes files: one under /proc, below a file or read-only
    fails now, in one line, not after the first shot's render."""
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MrcheckError(f"cannot create or write to the output folder ({exc.strerror or exc})", outdir) from None
    check_writable_ancestor(outdir, "output folder", itself=True)


def _check_options(outdir: Path, workers: int, scheduler: str | None) -> None:
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("output folder is a file", outdir)
    if workers < 1:
        raise MrcheckError(f"workers must be >= 1, got {workers}")
    if scheduler and workers != 1:
        warnings.warn("--workers is ignored with --scheduler (the cluster's workers run the shots)", MrcheckWarning)


def _plan(job: Job, outdir: Path, scheduler: str | None, force: bool):
    """The tasks, the manifest entries of the finished shots (skipped), the tasks to run and
    every file the job reads; refuses a job whose outputs would overwrite one of its inputs."""
    scene_paths = scene_files(job.scene)
    tasks = make_tasks(job, outdir, write=scheduler is None, scene_paths=scene_paths)
    check_not_inputs(
        [outdir / MANIFEST, outdir / REPORT, *(t.folder / name for t in tasks for name in t.own_names())],
        [
            ("the job", job.path),
            ("the scene", scene_paths),
            *((f"an input of shot {t.name}", t.input_files) for t in tasks),
        ],
    )
    entries, to_run = {}, []
    for task in tasks:
        record = None if force else finished_record(task)
        if record is not None:
            entries[task.name] = record.manifest_entry("skipped", outdir, task.folder)
        else:
            to_run.append(task)
    reads = {real_path(f) for f in scene_paths} | {real_path(f) for t in tasks for f in t.input_files}
    return tasks, entries, to_run, reads


def _run_shots(runner, tasks, to_run, entries: dict, outdir: Path, reads: set, progress) -> None:
    """Run the shots, store what a cluster returns and every failure, and report each one."""
    total, skipped = len(tasks), len(tasks) - len(to_run)
    progress(ShotProgress(skipped, total))
    run_start, finished = time.perf_counter(), 0
    for task, record in runner:
        if record.status == "done" and record.files is not None:  # from a cluster: written here
            record = store_shot(task.folder, record)
        elif record.status == "failed":
            store_failure(task.folder, record, reads)
        entries[task.name] = record.manifest_entry(record.status, outdir, task.folder)
        finished += 1
        eta = (time.perf_counter() - run_start) / finished * (len(to_run) - finished)
        progress(
            ShotProgress(
                skipped + finished,
                total,
                task.name,
                record.status,
                eta,
                sum(e["status"] == "failed" for e in entries.values()),
            )
        )


def _manifest(job: Job, outdir: Path, shots: list, removed: list, executor: str, elapsed: float) -> dict:
    counts = {s: sum(e["status"] == s for e in shots) for s in STATUSES}
    ran = [e for e in shots if e["status"] != "skipped"]
    return {
        "format": 1,
        "job": str(job.path.resolve()),
        "outdir": str(outdir),
        "settings": job.settings.to_dict(),
        "executor": executor,
        "summary": {"shots": len(shots), **counts},
        "timings_s": {
            "total": round(elapsed, 3),
            "shots_per_minute": round(60.0 * len(ran) / elapsed, 2) if ran and elapsed > 0 else None,
        },
        "shots": shots,
        "removed": removed,
    }


def run_export(
    job,
    outdir,
    workers: int = 1,
    scheduler: str | None = None,
    force: bool = False,
    progress: Callable[[ShotProgress], None] | None = None,
    antialias: bool | None = None,
    accumulate: int | None = None,
) -> ExportResult:
    """``mrcheck export``: every shot of the job file ``job`` into ``outdir``, then its
    manifest.json and report.html. A bad job, option or OUTDIR is a :class:`MrcheckError` before
    anything is written; a bad shot fails alone (``ExportResult.failed``). ``antialias`` and
    ``accumulate``: override the job's keys (part of the shots' fingerprints: a change redoes them)."""
    started = time.perf_counter()
    progress = progress or (lambda step: None)
    job = load_job(job)
    if antialias is not None:
        job = replace(job, settings=replace(job.settings, antialias=antialias))
    if accumulate is not None:
        if not 1 <= accumulate <= MAX_ACCUMULATE:
            raise MrcheckError(f"--accumulate must be 1 to {MAX_ACCUMULATE} frames, got {accumulate}")
        job = replace(job, settings=replace(job.settings, accumulate=accumulate))
    outdir = real_path(outdir)
    _check_options(outdir, workers, scheduler)
    tasks, entries, to_run, reads = _plan(job, outdir, scheduler, force)
    # connected before OUTDIR is made: a bad or unreachable scheduler leaves no empty OUTDIR behind
    client = connect(scheduler) if scheduler else None
    try:
        _make_outdir(outdir)
        removed = remove_stale(outdir, tasks, reads)
        for task in to_run:
            prepare_folder(task.folder)
        runner = run_dask(to_run, client) if client is not None else run_local(to_run, workers, job.loaded)
        _run_shots(runner, tasks, to_run, entries, outdir, reads, progress)
    finally:
        if client is not None:
            client.close()
    # the processes that ran: never more than the shots to run, and one (this one) for one shot
    executor = f"dask {scheduler}" if scheduler else f"local, {local_workers(workers, len(to_run))} worker(s)"
    manifest = _manifest(
        job, outdir, [entries[t.name] for t in tasks], removed, executor, time.perf_counter() - started
    )
    write_text(outdir / MANIFEST, json.dumps(manifest, indent=2) + "\n")
    write_report(manifest, outdir)
    return ExportResult(manifest, outdir)


__all__ = ["run_export", "ExportResult", "ShotProgress", "ShotRecord"]
