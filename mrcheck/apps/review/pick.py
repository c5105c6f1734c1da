"""Which CAD part is under a pixel: an Open3D ray cast from the registered camera.

Open3D casts in float32, and a factory at map coordinates may sit 5e6 m from the origin, or
hold one stray element there (an IFC export's): float32 relative to the scene's centre would
then round the geometry near the camera to metres. The RaycastingScene therefore holds every
instance of every part relative to an origin near the camera, subtracted in float64 before the
cast: float32 keeps better than 0.1 mm within a few kilometres of it. One such scene serves
every shot whose camera stands within :data:`ORIGIN_RADIUS_M` of its origin (the shots of one
hall share one); a shot elsewhere gets its own, around its camera centre. The ray starts at the
camera centre and goes through the *undistorted* pixel: the photo carries the lens distortion,
so the pixel is undistorted with the shot's K and dist first. ``geometry_ids`` -> (part,
instance) is the triangle -> part table.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np
import open3d as o3d

from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene

ORIGIN_RADIUS_M = 1000.0   # float32 spacing 6e-5 m at 1 km: picks to the millimetre nearby
MAX_ORIGINS = 4            # ray-casting scenes kept (each holds the whole scene once)


class Picker:
    def __init__(self, scene: Scene):
        self.scene = scene
        self._casters: list[tuple[np.ndarray, o3d.t.geometry.RaycastingScene, dict]] = []
        self._lock = threading.Lock()

    def _build(self, origin: np.ndarray):
        """The ray-casting scene of every instance relative to ``origin``, and its id table."""
        raycaster, table = o3d.t.geometry.RaycastingScene(), {}
        for part in self.scene.parts:
            v = np.asarray(part.vertices, np.float64)
            faces = np.ascontiguousarray(part.faces, np.uint32)
            for transform, instance, info in zip(part.transforms, part.instance_ids, part.instance_info):
                T = np.asarray(transform, np.float64)
                world = v @ T[:3, :3].T + (T[:3, 3] - origin)     # float64 until relative to origin
                gid = raycaster.add_triangles(o3d.core.Tensor(world.astype(np.float32)), o3d.core.Tensor(faces))
                table[int(gid)] = (part.name, instance, info)
        return raycaster, table

    def _caster_for(self, centre: np.ndarray):
        """(origin, raycaster, table) for a camera at ``centre``; call with the lock held."""
        for entry in self._casters:
            if np.linalg.norm(centre - entry[0]) <= ORIGIN_RADIUS_M:
                return entry
        entry = (centre.copy(), *self._build(centre))
        self._casters = [entry] + self._casters[:MAX_ORIGINS - 1]
        return entry

    def pick(self, camera: Camera, u: float, v: float) -> dict:
        """The part at pixel (u, v) of ``camera``'s (distorted) photo: name, instance, distance (m),
        and for an imported (IFC/STEP) element its ``name``, ``ifc_class`` and ``storey``."""
        pixel = np.array([[[u, v]]], np.float64)
        x, y = cv2.undistortPoints(pixel, camera.K, camera.dist).reshape(2)
        direction = camera.R.T @ np.array([x, y, 1.0])
        direction /= np.linalg.norm(direction)
        with self._lock:
            origin, raycaster, table = self._caster_for(camera.center)
            ray = np.concatenate([camera.center - origin, direction]).astype(np.float32)[None]
            hit = raycaster.cast_rays(o3d.core.Tensor(ray))
        t = float(hit["t_hit"].numpy()[0])
        if not np.isfinite(t):
            return {"part": None, "instance": None, "distance": None}
        part, instance, info = table[int(hit["geometry_ids"].numpy()[0])]
        return {"part": part, "instance": instance, "distance": round(t, 3),
                "triangle": int(hit["primitive_ids"].numpy()[0]),
                "name": info.name, "ifc_class": info.ifc_class, "storey": info.storey}
