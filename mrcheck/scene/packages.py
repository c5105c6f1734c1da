"""ROS ``package://NAME/PATH`` mesh references of URDF files, resolved the way a planner expects.

A URDF exported from a ROS workspace names its meshes ``package://ur_description/meshes/...``;
ROS finds the package ``ur_description`` on ``ROS_PACKAGE_PATH``. Outside ROS the same files
usually sit in a copied package folder. Search order for ``package://NAME/PATH``, first hit wins:

1. the folders given with ``mrcheck --package-path DIR`` (repeatable; also ``DIR1:DIR2``),
2. the manifest's ``package_path = ["dir", ...]`` (relative to the manifest),
3. ``ROS_PACKAGE_PATH`` (``:``-separated),
4. the URDF's own folder and its parents (ROS keeps a URDF inside its package).

A search folder is either the package itself (its name is NAME, or its ``package.xml`` says
``<name>NAME</name>``) or holds it (``DIR/NAME``). Names match with ``-`` and ``_`` alike
(``example-robot-data`` is the folder ``example_robot_data``). Inside the package, PATH is tried
whole and then without its leading folders (``robots/ur_description/meshes/a.dae`` is found as
``ur_description/meshes/a.dae``), as packages are often copied in part.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

PREFIX = "package://"
_configured: list[Path] = []
_PACKAGE_NAME = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")


def set_package_path(folders) -> None:
    """The folders of ``--package-path`` (process-wide, as ROS_PACKAGE_PATH is)."""
    _configured[:] = [Path(p) for folder in folders for p in str(folder).split(os.pathsep) if p]


def package_path() -> list[Path]:
    """The configured ``--package-path`` folders."""
    return list(_configured)


def search_folders(urdf: Path, manifest_folders=()) -> list[Path]:
    """Every folder a ``package://`` reference of ``urdf`` is looked up in, in order."""
    env = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    ancestors = list(Path(os.path.abspath(urdf)).parents)
    return list(dict.fromkeys([*_configured, *(Path(p) for p in manifest_folders), *env, *ancestors]))


def _norm(name: str) -> str:
    return name.replace("-", "_").lower()


def _declared_name(folder: Path) -> str | None:
    try:
        match = _PACKAGE_NAME.search((folder / "package.xml").read_bytes()[:20000])
    except OSError:
        return None
    return match.group(1).decode("utf-8", "replace") if match else None


def _package_dirs(folder: Path, name: str) -> list[Path]:
    """``folder`` itself when it is the package NAME, and ``folder/NAME`` (either spelling)."""
    found = []
    wanted = _norm(name)
    if _norm(folder.name) == wanted or _norm(_declared_name(folder) or "") == wanted:
        found.append(folder)
    try:
        found += [child for child in folder.iterdir() if child.is_dir() and _norm(child.name) == wanted]
    except OSError:
        pass
    return found


def resolve(uri: str, folders) -> str | None:
    """The file a ``package://NAME/PATH`` reference names, or None when no folder has it."""
    if not uri.startswith(PREFIX):
        return None
    name, _, rest = uri[len(PREFIX) :].partition("/")
    parts = [p for p in rest.split("/") if p]
    if not name or not parts:
        return None
    for folder in folders:
        for package in _package_dirs(Path(folder), name):
            for start in range(len(parts)):  # whole PATH first, then without its leading folders
                candidate = package.joinpath(*parts[start:])
                if candidate.is_file():
                    return str(candidate)
    return None


def hint(name: str) -> str:
    """What to do about an unresolved ``package://NAME/...``."""
    return (
        f"give --package-path DIR (the package folder {name}, or the folder holding it), a manifest "
        'package_path = ["DIR"], or set ROS_PACKAGE_PATH'
    )


def handler(urdf: Path, fallback, manifest_folders=()):
    """A yourdfpy filename handler: ``package://`` through :func:`resolve`, the rest (and an
    unresolved reference, whose text then appears in the not-found message) through ``fallback``."""
    folders = search_folders(urdf, manifest_folders)

    def find(fname: str) -> str:
        return resolve(fname, folders) or fallback(fname) if fname.startswith(PREFIX) else fallback(fname)

    return find


__all__ = ["set_package_path", "package_path", "search_folders", "resolve", "hint", "handler", "PREFIX"]
