"""A small scene for the edge registration's tests and bench: a floor, a back wall, a column and
crates (boxes only: every edge a crease), built in memory so that a photo of it can leave a
crate out and add clutter without files. Photos of it come from :mod:`mrcheck.eval.edgephotos`.
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
    return make_part(name, Path(name), np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces), T[None],
                     color=colour, units="m")


def crate_scene() -> Scene:
    parts = [_box_part(*crate) for crate in CRATES]
    parts.append(_box_part("floor", (0.5, 0.8), (9.0, 7.0, 0.1), 0, (0.45, 0.45, 0.42), z0=-0.1))
    parts.append(_box_part("wall", (0.5, 3.4), (9.0, 0.2, 3.2), 0, (0.75, 0.72, 0.68), z0=-0.1))
    return Scene("crates", Path("crates"), parts)


def crate_camera(width=320, height=240, dist=(-0.1, 0.04, 0.0005, -0.0003, 0.0)) -> Camera:
    cam = Camera.from_look_at([-3.2, -4.6, 2.4], [0.3, 0.8, 0.5], [0, 0, 1], 55.0, width, height)
    return Camera(cam.width, cam.height, cam.K, cam.R, cam.t, np.asarray(dist, float))


__all__ = ["CRATES", "crate_scene", "crate_camera"]
