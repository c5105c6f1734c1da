"""Work in progress that a killed run leaves behind, and folders checked whole before use.

A command writes into a hidden *partial* (a folder or file beside its output) and renames it into
place when done; killed (SIGKILL, a power cut) it leaves the partial, which must not block or
confuse the next run. A partial's name carries its writer's process id
(:func:`partial_prefix`): one whose writer is gone is *stale* and removed by the next run
(:func:`remove_stale_partials`); one whose writer is alive (a concurrent run) is left alone. A
process id reused by an unrelated process only keeps the partial until that process ends.

A folder that is read later without its writer (the import cache's entries) is *sealed*: a
record of every file's size and SHA-256 is written last (:func:`seal_folder`), and
:func:`seal_problem` says what differs (a file truncated by a full disk, one edited or deleted),
so that a damaged entry is made again rather than read.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

SEAL = ".mrcheck-files.json"  # the record of a sealed folder: {relative path: [size, sha256]}


def partial_prefix(prefix: str) -> str:
    """``prefix`` with this process's id, for ``tempfile.mkdtemp``/``mkstemp``: ``.track-1234-``."""
    return f"{prefix}{os.getpid()}-"


def _writer_gone(name: str, prefix: str) -> bool:
    """The partial ``name`` (of :func:`partial_prefix` ``prefix``) was written by a process that
    no longer runs. A name without a process id (another program's file) is not ours: kept."""
    pid = name[len(prefix) :].split("-", 1)[0]
    if not pid.isdigit() or int(pid) == os.getpid():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except OSError:  # alive, another user's
        return False
    return False


def remove_stale_partials(folder, prefix: str) -> list[Path]:
    """Remove the entries of ``folder`` named by :func:`partial_prefix` ``prefix`` whose writer is
    gone (files, or folders with everything in them); the paths removed. A folder that does not
    exist or cannot be listed has none."""
    try:
        names = [name for name in os.listdir(folder) if name.startswith(prefix)]
    except OSError:
        return []
    removed = []
    for name in names:
        path = Path(folder) / name
        if not _writer_gone(name, prefix):
            continue
        try:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path)
            else:
                path.unlink()
        except FileNotFoundError:  # another run removed it first
            pass
        except OSError:  # not ours to remove (permissions): left as it is
            continue
        removed.append(path)
    return removed


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.name != SEAL)


def _digest(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def seal_folder(folder) -> None:
    """Write the record of every file in ``folder`` (its size and SHA-256), last."""
    folder = Path(folder)
    record = {p.relative_to(folder).as_posix(): [p.stat().st_size, _digest(p)] for p in _files(folder)}
    (folder / SEAL).write_text(json.dumps(record, indent=0, sort_keys=True), encoding="utf-8")


def seal_problem(folder) -> str | None:
    """What differs in ``folder`` from its seal (:func:`seal_folder`), or None when every file
    is there with its size and content."""
    folder = Path(folder)
    try:
        record = json.loads((folder / SEAL).read_text(encoding="utf-8"))
        if not isinstance(record, dict):
            raise ValueError("not an object")
    except (OSError, ValueError) as exc:
        return f"no intact record of its files ({exc.__class__.__name__})"
    for name, entry in record.items():
        path = folder / name
        try:
            size, digest = entry
            if path.stat().st_size != size:
                return f"{name} is {path.stat().st_size} bytes, written as {size}"
            if _digest(path) != digest:
                return f"{name} changed since it was written"
        except (OSError, TypeError, ValueError):
            return f"{name} is missing or unreadable"
    return None


__all__ = ["partial_prefix", "remove_stale_partials", "seal_folder", "seal_problem", "SEAL"]
