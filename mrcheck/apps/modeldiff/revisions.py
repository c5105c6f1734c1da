"""Reading OLD and NEW: a glTF file by its nodes (:mod:`mrcheck.apps.modeldiff.glb`), anything
else as every command reads a scene (a manifest, or an IFC or STEP model through the import
cache).

The two are read one after the other. Importing NEW in a second process while this one imports
OLD was measured and dropped: on the 2-core CI machine, shared, the 5 M-triangle hall's pair
took 13.2 and 17.6 s side by side against 14.0 and 12.1 s in turn (the importer's geometry
iterator already uses every core).
"""

from __future__ import annotations

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


def load_revisions(old_path: Path, new_path: Path) -> tuple[Scene, Scene]:
    """(OLD, NEW), one after the other (module docstring)."""
    return load_revision(Path(old_path)), load_revision(Path(new_path))


__all__ = ["load_revision", "load_revisions"]
