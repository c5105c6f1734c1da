"""The edge-registration tests' scene as files (the scene itself: :mod:`mrcheck.eval.edgescenes`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from mrcheck.eval.edgescenes import crate_camera, crate_scene

__all__ = ["crate_camera", "crate_scene", "write_crate_scene"]


def write_crate_scene(folder: Path) -> Path:
    """The crate scene as files (one PLY per part, metres) with a ``scene.toml``; a ``front``
    viewpoint at :func:`crate_camera`'s pose. Returns the manifest's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lines = ['format = 1', 'name = "crates"', '']
    for part in crate_scene().parts:
        mesh = trimesh.Trimesh(part.vertices.astype(np.float64) @ part.transforms[0][:3, :3].T
                               + part.transforms[0][:3, 3], part.faces, process=False)
        mesh.export(folder / f"{part.name}.ply")
        lines += ["[[parts]]", f'name = "{part.name}"', f'mesh = "{part.name}.ply"', 'units = "m"',
                  f"color = {list(part.color)}", ""]
    lines += ["[[viewpoints]]", 'name = "front"', "eye = [-3.2, -4.6, 2.4]", "target = [0.3, 0.8, 0.5]",
              "up = [0.0, 0.0, 1.0]", "fov_y_deg = 55.0", "width = 640", "height = 480", ""]
    manifest = folder / "scene.toml"
    manifest.write_text("\n".join(lines))
    return manifest
