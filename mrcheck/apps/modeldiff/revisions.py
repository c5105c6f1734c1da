"""Reading OLD and NEW: a glTF file by its nodes (:mod:`mrcheck.apps.modeldiff.glb`), anything
else as every command reads a scene (a manifest, or an IFC or STEP model through the import
cache).

Two model files not yet in the import cache are imported side by side: NEW in a second process
(which only fills the cache) while this one imports OLD, then NEW is read from the cache. Most
of an IFC import is single-threaded Python (placements, mapped items), so on two cores the pair
takes little more than one import (the 5 M-triangle hall: :doc:`docs/regress-diff.md`). The
helper's warnings (elements left out) are passed on; if it fails, NEW is imported here again,
which raises the error as one line.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from mrcheck.apps.modeldiff.glb import GLTF_SUFFIXES, glb_scene
from mrcheck.scene.model import Scene


def load_revision(path: Path) -> Scene:
    """One revision (module docstring), its loading shown."""
    from mrcheck.core.inputs import check_input
    from mrcheck.scene.model import load_scene

    path = Path(path)
    if path.suffix.lower() in GLTF_SUFFIXES and not path.is_dir():
        check_input(path, "model file")
        return glb_scene(path)
    return load_scene(path, progress=True)


def _uncached_model(path: Path) -> bool:
    """Whether ``path`` is an IFC/STEP file the import cache does not hold yet."""
    from mrcheck.scene.importers.cache import cache_key, cache_root
    from mrcheck.scene.importers.records import default_settings
    from mrcheck.scene.importers.sniff import IMPORT_SUFFIXES

    if path.suffix.lower() not in IMPORT_SUFFIXES or not path.is_file():
        return False
    try:
        return not (cache_root() / cache_key(path, default_settings()) / "scene.toml").is_file()
    except (OSError, ValueError):  # unreadable: the load says why
        return False


def fill_cache(path: str, settings) -> list[tuple[str, type]]:
    """Import ``path`` into the cache (in the helper process); the warnings it gave, [] also
    when it failed (the caller's own import then reports the error)."""
    from mrcheck.scene.importers.cache import cached_manifest

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            cached_manifest(Path(path), settings)
        except Exception:  # reported by the caller's import of the same file
            return []
    return [(str(w.message), w.category) for w in caught]


def load_revisions(old_path: Path, new_path: Path) -> tuple[Scene, Scene]:
    """(OLD, NEW), the two imports side by side when both are uncached models (module docstring)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from mrcheck.scene.importers.records import default_settings

    old_path, new_path = Path(old_path), Path(new_path)
    if not (_uncached_model(old_path) and _uncached_model(new_path)):
        return load_revision(old_path), load_revision(new_path)
    # fork: the helper starts at once, without importing mrcheck again (no GL context or import
    # threads exist yet in this process; the helper returns before anything else runs)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as pool:
        helper = pool.submit(fill_cache, str(new_path), default_settings())
        old = load_revision(old_path)
        try:
            caught = helper.result()
        except Exception:  # the helper died (memory): NEW is imported below
            caught = []
    for message, category in caught:
        warnings.warn(message, category, stacklevel=2)
    return old, load_revision(new_path)


__all__ = ["load_revision", "load_revisions", "fill_cache"]
