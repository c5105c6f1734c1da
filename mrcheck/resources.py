"""Where the shaders and the embedded sample scene are, installed or in a checkout.

A wheel carries them inside the package (``mrcheck/_data/``, see ``pyproject.toml``); an editable
install or a checkout finds them at the top of the repository (``shaders/``,
``factory_scenes/sample_cell/``).
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_REPO = _PACKAGE.parent


def _first_existing(*candidates: Path) -> Path:
    for candidate in candidates:
        if candidate.exists():
            return candidate
    return candidates[0]


def shader_dir() -> Path:
    return _first_existing(_PACKAGE / "_data" / "shaders", _REPO / "shaders")


def sample_scene_path() -> Path:
    """The manifest of the embedded sample factory cell."""
    folder = _first_existing(_PACKAGE / "_data" / "sample_cell", _REPO / "factory_scenes" / "sample_cell")
    return folder / "scene.toml"


__all__ = ["shader_dir", "sample_scene_path"]
