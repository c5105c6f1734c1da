"""``scene import`` and the import cache that lets every command take an .ifc/.step file itself.

The cache holds imported scenes (the same folders ``scene import`` writes) under
``imports/`` of mrcheck's cache folder (``$MRCHECK_CACHE_DIR``, else ``$XDG_CACHE_HOME/mrcheck`` or
``~/.cache/mrcheck``, as the levels of detail),
one folder per key: the SHA-256 of the file's *content* (a renamed or touched file is still a
hit, an edited one a miss), the settings that change the result (:meth:`ImportSettings.key`)
and :data:`IMPORTER_VERSION`. A second load of an unchanged file hashes it and reads the GLB
scene: a small fraction of parsing and tessellating it again. Entries are written to a hidden
folder and renamed into place, so a crash or a concurrent import never leaves half an entry;
the folder may be deleted at any time.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import time
from pathlib import Path

from mrcheck.core.errors import MrcheckError, warn
from mrcheck.core.progress import Progress, no_progress
from mrcheck.scene.importers import read_model
from mrcheck.scene.importers.records import ImportResult, ImportSettings, default_settings
from mrcheck.scene.importers.sniff import file_digest
from mrcheck.scene.importers.writer import write_scene

IMPORTER_VERSION = "3"  # bump when the importers' output changes: old entries are then misses
PARTIAL = ".partial-"  # an entry being written, renamed into place when complete


def cache_root() -> Path:
    """Where imported scenes are cached: ``imports/`` in $MRCHECK_CACHE_DIR, else in the XDG
    cache folder's ``mrcheck/``."""
    if os.environ.get("MRCHECK_CACHE_DIR"):
        return Path(os.environ["MRCHECK_CACHE_DIR"]) / "imports"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mrcheck" / "imports"


def cache_key(path, settings: ImportSettings) -> str:
    """The cache entry's name: content hash, settings and importer version."""
    text = f"{file_digest(path)};{settings.key()};v{IMPORTER_VERSION}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _header(path: Path, settings: ImportSettings) -> str:
    return (
        f"from {path.name} (coordinates {settings.coordinates}, STEP tolerance {settings.tolerance_px:g} px at "
        f"{settings.distance_m:g} m)"
    )


def _result(manifest: Path, model, seconds: float, cached: bool) -> ImportResult:
    return ImportResult(
        manifest=manifest,
        model_name=model.name,
        kind=model.kind,
        schema=model.schema,
        parts=len(model.parts),
        elements=model.element_count,
        triangles=model.triangle_count,
        failed=list(model.failed),
        seconds=seconds,
        cached=cached,
        origin=tuple(float(v) for v in model.origin),
        crs=model.crs,
        notes=list(model.notes),
    )


def import_scene(
    path, outdir, settings: ImportSettings | None = None, progress: Progress = no_progress
) -> ImportResult:
    """Import an .ifc/.step file into the scene folder ``outdir`` (``mrcheck scene import``).

    Nothing is written when the import fails; an existing folder is replaced only when it holds
    an earlier import (its other files stay)."""
    from mrcheck.scene.importers.writer import check_import_dir

    path, settings = Path(path), settings or ImportSettings()
    check_import_dir(Path(outdir))  # before the work, not after it
    start = time.perf_counter()
    model = read_model(path, settings, progress)
    manifest = write_scene(model, Path(outdir), _header(path, settings))
    _warn_left_out(path, model)
    return _result(manifest, model, time.perf_counter() - start, cached=False)


def cached_manifest(path, settings: ImportSettings | None = None, progress: Progress = no_progress) -> ImportResult:
    """The manifest of the cached import of ``path``, importing it first on a miss."""
    path, settings = Path(path), settings or default_settings()
    start = time.perf_counter()
    from mrcheck.scene.importers.sniff import sniff

    sniff(path)  # wrong extension, truncation, ...: the same errors as an import
    root = cache_root()
    entry = root / cache_key(path, settings)
    manifest = entry / "scene.toml"
    if manifest.is_file() and _intact(entry, path):
        return ImportResult(
            manifest=manifest,
            model_name=path.stem,
            kind="",
            schema="",
            parts=0,
            elements=0,
            triangles=0,
            failed=[],
            seconds=time.perf_counter() - start,
            cached=True,
        )
    model = read_model(path, settings, progress)
    from mrcheck.core.partials import partial_prefix, remove_stale_partials, seal_folder

    try:
        root.mkdir(parents=True, exist_ok=True)
        remove_stale_partials(root, PARTIAL)  # a killed import's
        work = Path(tempfile.mkdtemp(prefix=partial_prefix(PARTIAL), dir=root))
    except OSError as exc:
        raise MrcheckError(
            f"cannot write the import cache ({exc.strerror or exc}; set MRCHECK_CACHE_DIR to a writable folder)", root
        ) from None
    try:
        write_scene(model, work / "scene", _header(path, settings))
        seal_folder(work / "scene")
        try:
            os.rename(work / "scene", entry)
        except OSError:
            if not manifest.is_file():  # not another process's entry that landed first
                raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    _warn_left_out(path, model)
    return _result(manifest, model, time.perf_counter() - start, cached=False)


def _intact(entry: Path, path: Path) -> bool:
    """The cache ``entry`` holds every file as it was written (:func:`mrcheck.core.partials.seal_problem`);
    a damaged one (a GLB truncated by a full disk, a file deleted) is removed, with a warning, to
    be imported again."""
    from mrcheck.core.partials import SEAL, partial_prefix, seal_problem

    problem = seal_problem(entry)
    if problem is None:
        return True
    if (entry / SEAL).exists():  # without a seal: written before entries were sealed, not damaged
        warn(f"the cached import is damaged ({problem}): importing it again", path)
    try:  # renamed aside first: a concurrent reader sees the entry whole or not at all
        aside = Path(tempfile.mkdtemp(prefix=partial_prefix(PARTIAL), dir=entry.parent))
        os.rename(entry, aside / "scene")
        shutil.rmtree(aside, ignore_errors=True)
    except OSError:  # another process replaced it first
        pass
    return False


SHOWN_FAILURES = 5


def failed_summary(failed) -> str:
    """One line naming the elements left out (the first few; the scene's README lists all)."""
    names = ", ".join(f"{f.label()} ({f.reason})" for f in failed[:SHOWN_FAILURES])
    more = f" and {len(failed) - SHOWN_FAILURES} more" if len(failed) > SHOWN_FAILURES else ""
    return f"{len(failed)} element(s) without geometry left out: {names}{more}"


def _warn_left_out(path: Path, model) -> None:
    """The elements an import left out and its notes, as warnings (the CLI shows them)."""
    if model.failed:
        warn(failed_summary(model.failed), path)
    for note in model.notes:
        warn(note, path)


__all__ = [
    "import_scene",
    "cached_manifest",
    "failed_summary",
    "cache_root",
    "cache_key",
    "IMPORTER_VERSION",
]
