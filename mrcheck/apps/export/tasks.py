"""The shots of a job as tasks for the workers (:class:`ShotTask`), what a worker hands back
(:class:`ShotRecord`, the content of a shot's record.json), and when a shot is finished.

Both cross process boundaries (spawned workers, a Dask cluster): plain, picklable dataclasses.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from mrcheck.apps.export.job import SHEET_ALPHA, Job, JobSettings, ShotInputs
from mrcheck.apps.names import (
    RECORD,
    SHEET,
    SHOT_FILE,
    overlay_name,
    render_name,
    shot_folder,
)
from mrcheck.core.camerafiles import load_shot
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import MAX_PIXELS, max_pixels
from mrcheck.core.inputs import real_path
from mrcheck.mr.overlay import STUDY_ORDER
from mrcheck.scene.manifest import files_stamp


@dataclass(frozen=True)
class ShotTask:
    """One shot to make: everything a worker needs, nothing it must look up in the job."""

    name: str
    inputs: ShotInputs
    settings: JobSettings
    fingerprint: str  # of the settings, the inputs and their files' sizes and mtimes
    scene_stamp: str  # files_stamp of the scene's files (a worker's Renderer is kept per stamp)
    input_files: list  # the files the shot reads besides the scene
    folder: Path  # OUTDIR/shots/NAME
    write: bool  # the worker writes the files itself (local); else it returns them (a cluster)
    max_pixels: int = MAX_PIXELS  # mrcheck --max-pixels: a spawned or remote worker has its own process

    def own_names(self) -> list:
        """The names of every file the export writes into this shot's folder."""
        return [*(o["file"] for o in plan_outputs(self.settings)), SHOT_FILE, RECORD]


@dataclass
class ShotRecord:
    """A shot's record.json: its status ("done" or "failed" with ``error``), outputs, registration
    and timings. ``files`` ({name: bytes}) travel with it from a worker that does not write them."""

    name: str
    status: str
    fingerprint: str
    inputs: dict
    error: str | None = None
    registration: dict | None = None  # the registration summary (shot.registration_summary)
    outputs: list | None = None  # done: [{"file", "kind", "mode", "intensity", "alpha"}]
    size: list | None = None  # done: [width, height] of the outputs
    photo: str | None = None  # done: the photo's path
    registration_error_px: float | None = None
    timings_s: dict = field(default_factory=dict)
    files: dict | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """The JSON of record.json (without ``files``), in its keys' order."""
        d = {
            "name": self.name,
            "status": self.status,
            "error": self.error,
            "fingerprint": self.fingerprint,
            "inputs": self.inputs,
            "registration": self.registration,
        }
        if self.outputs is not None:
            d.update(outputs=self.outputs, size=self.size, photo=self.photo)
        d.update(registration_error_px=self.registration_error_px, timings_s=self.timings_s)
        return d

    @classmethod
    def from_dict(cls, data: dict) -> "ShotRecord":
        keys = (
            "name",
            "status",
            "fingerprint",
            "inputs",
            "error",
            "registration",
            "outputs",
            "size",
            "photo",
            "registration_error_px",
            "timings_s",
        )
        return cls(**{k: data[k] for k in keys if k in data})

    def manifest_entry(self, status: str, outdir: Path, folder: Path) -> dict:
        """The shot's entry in manifest.json: ``status`` (done, skipped, failed), its folder and
        outputs relative to OUTDIR (none unless done)."""
        rel = folder.relative_to(outdir).as_posix()
        entry = {k: v for k, v in self.to_dict().items() if k not in ("outputs", "fingerprint")}
        entry["status"] = status
        entry["folder"] = rel
        entry["outputs"] = (
            [dict(o, path=f"{rel}/{o['file']}") for o in self.outputs or []] if self.status == "done" else []
        )
        return entry


def lost(task: ShotTask, exc: BaseException) -> ShotRecord:
    """The record of a shot whose worker died or could not take it."""
    return ShotRecord(
        task.name,
        "failed",
        task.fingerprint,
        task.inputs.to_dict(),
        error=f"worker failed: {type(exc).__name__}: {exc}",
    )


def plan_outputs(settings: JobSettings) -> list:
    """The image outputs of one shot: ``[{"file", "kind", "mode", "intensity", "alpha"}]``."""
    modes, default = settings.modes, settings.overlay_intensity
    outputs = []
    for mode in modes:
        intensities = [None] if mode == "phong" else settings.intensities
        outputs += [
            {"file": render_name(mode, i), "kind": "render", "mode": mode, "intensity": i, "alpha": 0.0}
            for i in intensities
        ]
    for mode in modes:
        intensity = None if mode == "phong" else default
        outputs += [
            {
                "file": overlay_name(mode, intensity, alpha),
                "kind": "overlay",
                "mode": mode,
                "intensity": intensity,
                "alpha": alpha,
            }
            for alpha in settings.alphas
        ]
    outputs.append(
        {"file": SHEET, "kind": "sheet", "mode": list(STUDY_ORDER), "intensity": default, "alpha": SHEET_ALPHA}
    )
    return outputs


def input_files(inputs: ShotInputs) -> list:
    """The files one shot reads besides the scene: its inputs and, for a given SHOT.json, its photo."""
    files = list(inputs.to_dict().values())
    if inputs.shot is not None:
        try:
            files.append(str(real_path(load_shot(inputs.shot)[1])))
        except MrcheckError:
            pass  # the shot fails when it runs, and a failed shot is always run again
    return files


def make_tasks(job: Job, outdir: Path, write: bool, scene_paths: list) -> list:
    """A :class:`ShotTask` per shot of ``job``, in the job's order."""
    settings = job.settings.to_dict()
    # the inputs' paths are not enough: a moved part, a replaced photo or an edited marker map must
    # redo the shots that read them, so their sizes and mtimes go into the fingerprint too
    scene_stamp = files_stamp(scene_paths)  # scene_files(job.scene): once per job, it reads every OBJ
    tasks = []
    for shot in job.shots:
        inputs = shot.inputs.to_dict()
        files = input_files(shot.inputs)
        stamps = {"scene": scene_stamp, "inputs": files_stamp(files)}
        fingerprint = hashlib.sha256(
            json.dumps({"settings": settings, "inputs": inputs, "stamps": stamps}, sort_keys=True).encode()
        ).hexdigest()[:16]
        tasks.append(
            ShotTask(
                shot.name,
                shot.inputs,
                job.settings,
                fingerprint,
                scene_stamp,
                files,
                shot_folder(outdir, shot.name),
                write,
                max_pixels(),
            )
        )
    return tasks


def finished_record(task: ShotTask) -> ShotRecord | None:
    """The shot's record when it is finished (record present, same fingerprint, every output there)."""
    try:
        record = json.loads((task.folder / RECORD).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("fingerprint") != task.fingerprint or record.get("status") != "done":
        return None
    files = [o.get("file") for o in record.get("outputs", []) if isinstance(o, dict)]
    if not files or not all(isinstance(f, str) and (task.folder / f).is_file() for f in files):
        return None
    try:
        return ShotRecord.from_dict(record)
    except TypeError:  # a record.json without a field every record has: not one this export wrote
        return None


__all__ = ["ShotTask", "ShotRecord", "plan_outputs", "input_files", "make_tasks", "finished_record", "lost"]
