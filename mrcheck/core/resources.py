"""Where the shaders, the shipped scenes and the robot assets are, installed or in a checkout.

The shaders: a wheel carries them inside the package (``mrcheck/_data/shaders``, see
``pyproject.toml``); an editable install or a checkout finds them at the top of the repository.
The scenes and robot assets live in the ``factory_scenes`` package, installed next to
``mrcheck`` (the wheel carries both, an editable install or a checkout has both at the top of the
repository). mrcheck finds that folder as data and never imports the package: the generator
imports mrcheck's public API, and only the command line (``mrcheck scene generate``) imports the
generator, so the two never import each other. This module is the one place that knows the
package's folder layout (tests/test_architecture.py checks that no other module spells it).
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent.parent  # mrcheck/
_REPO = _PACKAGE.parent


def _first_existing(*candidates: Path) -> Path:
    for candidate in candidates:
        if candidate.exists():
            return candidate
    return candidates[0]


def shader_dir() -> Path:
    return _first_existing(_PACKAGE / "_data" / "shaders", _REPO / "shaders")


def _factory_scenes() -> Path:
    """The ``factory_scenes`` package folder, found beside ``mrcheck/`` without importing it."""
    return _REPO / "factory_scenes"


SHIPPED_SCENES = ("sample_cell", "cell", "line")  # the scene folders factory_scenes ships


def shipped_scene(name: str) -> Path:
    """The manifest (``scene.toml``) of the shipped scene ``name``, one of :data:`SHIPPED_SCENES`:
    the embedded sample cell, the robot cell of the edge and track benches, the production line of
    the frame bench."""
    if name not in SHIPPED_SCENES:
        raise ValueError(f"no shipped scene {name!r} (shipped: {', '.join(SHIPPED_SCENES)})")
    return _factory_scenes() / name / "scene.toml"


def sample_scene_path() -> Path:
    """The manifest of the embedded sample factory cell."""
    return shipped_scene("sample_cell")


def robot_assets_dir() -> Path:
    """The folder of the shipped URDF robots, one sub-folder per robot."""
    return _factory_scenes() / "assets" / "robots"


__all__ = ["shader_dir", "SHIPPED_SCENES", "shipped_scene", "sample_scene_path", "robot_assets_dir"]
