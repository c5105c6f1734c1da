"""Which views a baseline holds: the scene's named viewpoints by default, or those named with
``--views``, or camera files (camera JSON, OpenCV YAML, a registered SHOT.json).

A view's name is the viewpoint's name or the camera file's stem (a ``SHOT.json`` takes its
folder's name, as ``mrcheck register`` writes one per photo folder); names are file names in the
baseline, so two views of one name are refused.
"""

from __future__ import annotations

import re
from pathlib import Path

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.scene.model import Scene

CAMERA_SUFFIXES = (".json", ".yml", ".yaml")
_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def is_camera_file(spec: str) -> bool:
    return Path(spec).suffix.lower() in CAMERA_SUFFIXES


def view_name(path: Path) -> str:
    stem = path.parent.name if path.stem.upper() == "SHOT" and path.parent.name else path.stem
    return _SAFE.sub("_", stem).strip("_") or "view"


def split_views(specs) -> list[str]:
    """``--views a,b --views cam.json`` as ["a", "b", "cam.json"]."""
    return [s.strip() for spec in specs or () for s in str(spec).split(",") if s.strip()]


def resolve_views(scene: Scene, specs, width: int, height: int) -> list[tuple[str, Camera]]:
    """(name, camera) of every view asked for, each at ``width`` x ``height``; no ``specs``: every
    viewpoint of the scene, by name."""
    specs = split_views(specs)
    if not specs:
        specs = sorted(scene.viewpoints)
        if not specs:
            raise MrcheckError("the scene has no viewpoints; name camera files with --views", scene.source)
    views: dict[str, Camera] = {}
    for spec in specs:
        if is_camera_file(spec):
            name, camera = view_name(Path(spec)), load_camera(spec).fitted(width, height, spec)
        else:
            name, camera = spec, scene.camera(spec, width, height)
        if _SAFE.search(name):
            raise MrcheckError(f"view name {name!r}: use letters, digits, '.', '_' and '-' only")
        if name in views:
            raise MrcheckError(f"two views named {name!r} (a viewpoint and a camera file, or two files)")
        views[name] = camera
    return list(views.items())


__all__ = ["resolve_views", "split_views", "is_camera_file", "view_name"]
