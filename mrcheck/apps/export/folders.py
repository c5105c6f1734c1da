"""The shot folders of OUTDIR: writing a shot (atomically, record.json last), a failed shot's
record, and removing what earlier runs wrote that the job no longer produces.

Only the export's own file names (:func:`mrcheck.apps.names.is_export_name`) are ever removed,
never a file the job reads.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from mrcheck.apps.export.tasks import ShotRecord, ShotTask
from mrcheck.apps.names import RECORD, SHOTS, is_export_name
from mrcheck.core.inputs import real_path
from mrcheck.core.output import write_bytes, write_text


def _write_record(folder: Path, record: ShotRecord) -> None:
    write_text(folder / RECORD, json.dumps(record.to_dict(), indent=2) + "\n")


def store_shot(folder, record: ShotRecord) -> ShotRecord:
    """Write a shot's ``files`` atomically, then its ``record.json`` (last: it marks the shot
    finished). Returns the record without the files, with the write time."""
    folder = Path(folder)
    start = time.perf_counter()
    for name, data in record.files.items():
        write_bytes(folder / name, data)
    record.files = None
    record.timings_s = dict(record.timings_s or {}, write=round(time.perf_counter() - start, 4))
    _write_record(folder, record)
    return record


def store_failure(folder, record: ShotRecord, keep: set = frozenset()) -> None:
    """A failed shot: what earlier runs wrote into its folder no longer matches its inputs and goes
    (only the export's own file names, never a file in ``keep``, what the job reads); a
    record.json saying "failed" marks the folder as the export's, so that a later job without
    the shot recognises and removes it (a failed record is never "finished": reruns redo it)."""
    folder = Path(folder)
    for file in _own_files(folder, keep) if folder.is_dir() else []:
        file.unlink(missing_ok=True)
    record.files = None
    _write_record(folder, record)


def prepare_folder(folder: Path) -> None:
    """Before a shot runs: its old record goes first (the shot is unfinished until it is written
    again) and temp files of a killed run are removed."""
    (folder / RECORD).unlink(missing_ok=True)
    if folder.is_dir():
        for part in folder.glob(".*.part"):
            part.unlink(missing_ok=True)


def _own_files(folder: Path, keep: set) -> list:
    """The files in ``folder`` with the export's own names, except those in ``keep`` (what the
    job reads): the only files the export ever removes."""
    return [f for f in folder.iterdir() if is_export_name(f.name) and f.is_file() and real_path(f) not in keep]


def remove_stale(outdir: Path, tasks: list[ShotTask], keep: set) -> list:
    """Remove what earlier runs wrote and this job no longer produces: in this job's shot folders,
    outputs no longer planned (a dropped alpha, intensity or mode); folders of shots no longer in
    the job, when they hold the export's record.json. Only the export's own file names go, never a
    file in ``keep`` (what the job reads); a folder is removed once empty. Returns the removed
    paths, relative to OUTDIR."""
    planned = {t.folder.name: set(t.own_names()) for t in tasks}
    shots = outdir / SHOTS
    removed = []
    for folder in sorted(shots.iterdir()) if shots.is_dir() else []:
        wanted = planned.get(folder.name)
        if not folder.is_dir() or folder.is_symlink() or (wanted is None and not (folder / RECORD).is_file()):
            continue  # not a folder the export finished a shot in: maybe not ours
        # record.json last: a run killed half-way leaves a folder the next run still recognises
        stale = sorted(
            (f for f in _own_files(folder, keep) if f.name not in (wanted or ())), key=lambda f: f.name == RECORD
        )
        for file in stale:
            file.unlink(missing_ok=True)
            removed.append(file.relative_to(outdir).as_posix())
        if wanted is None:
            try:
                folder.rmdir()
            except OSError:
                pass  # files the export did not write stay, and so does their folder
    return removed


__all__ = ["store_shot", "store_failure", "prepare_folder", "remove_stale"]
