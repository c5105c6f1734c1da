"""A small scene for the edge registration's tests and bench: a floor, a back wall, a column and
crates (boxes only: every edge a crease), built in memory so that a photo of it can leave a
crate out and add clutter without files (:func:`write_crate_scene` writes it as files for the
commands). Photos of it come from :mod:`mrcheck.eval.edgephotos`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene, make_part

# (name, centre x y, size x y z, yaw deg, colour): standing on the floor (z = 0)
CRATES = [
    ("crate-a", (0.0, 0.0), (1.2, 0.8, 0.9), 0, (0.55, 0.35, 0.15)),
    ("crate-b", (1.6, 0.6), (0.8, 0.8, 1.4), 20, (0.2, 0.3, 0.6)),
    ("crate-c", (-1.5, 0.9), (0.9, 0.6, 0.6), -15, (0.7, 0.7, 0.65)),
    ("crate-d", (0.4, 1.7), (1.6, 0.7, 1.1), 5, (0.3, 0.5, 0.3)),
    ("crate-e", (-0.6, -1.1), (0.5, 0.5, 0.5), 40, (0.8, 0.6, 0.2)),
    ("column", (2.6, 2.2), (0.3, 0.3, 3.0), 0, (0.6, 0.6, 0.6)),
]


def _box_part(name, centre_xy, size, yaw_deg, colour, z0=0.0):
    mesh = trimesh.creation.box(extents=size)
    T = trimesh.transformations.rotation_matrix(np.radians(yaw_deg), (0, 0, 1))
    T[:3, 3] = (centre_xy[0], centre_xy[1], z0 + size[2] / 2.0)
    return make_part(
        name,
        Path(name),
        np.asarray(mesh.vertices, np.float64),
        np.asarray(mesh.faces),
        T[None],
        color=colour,
        units="m",
    )


def crate_scene() -> Scene:
    parts = [_box_part(*crate) for crate in CRATES]
    parts.append(_box_part("floor", (0.5, 0.8), (9.0, 7.0, 0.1), 0, (0.45, 0.45, 0.42), z0=-0.1))
    parts.append(_box_part("wall", (0.5, 3.4), (9.0, 0.2, 3.2), 0, (0.75, 0.72, 0.68), z0=-0.1))
    return Scene("crates", Path("crates"), parts)


def crate_camera(width=320, height=240, dist=(-0.1, 0.04, 0.0005, -0.0003, 0.0)) -> Camera:
    cam = Camera.from_look_at([-3.2, -4.6, 2.4], [0.3, 0.8, 0.5], [0, 0, 1], 55.0, width, height)
    return Camera(cam.width, cam.height, cam.K, cam.R, cam.t, np.asarray(dist, float))


def write_crate_scene(folder: Path) -> Path:
    """The crate scene as files (one PLY per part, metres) with a ``scene.toml``; a ``front``
    viewpoint at :func:`crate_camera`'s pose. Returns the manifest's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lines = ["format = 1", 'name = "crates"', ""]
    for part in crate_scene().parts:
        mesh = trimesh.Trimesh(
            part.vertices.astype(np.float64) @ part.transforms[0][:3, :3].T + part.transforms[0][:3, 3],
            part.faces,
            process=False,
        )
        mesh.export(folder / f"{part.name}.ply")
        lines += [
            "[[parts]]",
            f'name = "{part.name}"',
            f'mesh = "{part.name}.ply"',
            'units = "m"',
            f"color = {list(part.color)}",
            "",
        ]
    lines += [
        "[[viewpoints]]",
        'name = "front"',
        "eye = [-3.2, -4.6, 2.4]",
        "target = [0.3, 0.8, 0.5]",
        "up = [0.0, 0.0, 1.0]",
        "fov_y_deg = 55.0",
        "width = 640",
        "height = 480",
        "",
    ]
    manifest = folder / "scene.toml"
    manifest.write_text("\n".join(lines))
    return manifest


__all__ = ["CRATES", "crate_scene", "crate_camera", "write_crate_scene"]
