"""Where the shaders and the embedded sample scene are, installed or in a checkout.

The shaders: a wheel carries them inside the package (``mrcheck/_data/shaders``, see
``pyproject.toml``); an editable install or a checkout finds them at the top of the repository.
The scenes and robot assets live in the ``factory_scenes`` package, installed next to
``mrcheck`` (the wheel carries both, an editable install or a checkout has both at the top of the
repository). mrcheck finds that folder as data and never imports the package: the generator
imports mrcheck's public API, and only the command line (``mrcheck scene generate``) imports the
generator, so the two never import each other.
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


def factory_scenes_dir() -> Path:
    """The ``factory_scenes`` package folder (shipped scenes, robot assets), found beside
    ``mrcheck/`` without importing it."""
    return _REPO / "factory_scenes"


def sample_scene_path() -> Path:
    """The manifest of the embedded sample factory cell."""
    return factory_scenes_dir() / "sample_cell" / "scene.toml"


__all__ = ["shader_dir", "sample_scene_path", "factory_scenes_dir"]
