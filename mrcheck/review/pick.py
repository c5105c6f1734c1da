"""Which CAD part is under a pixel: an Open3D ray cast from the registered camera.

The RaycastingScene holds every instance of every part once per scene, in float32 relative to
the scene's centre (factory coordinates can be kilometres from the origin; float32 keeps ~mm
near the centre). The ray starts at the camera centre (same shift) and goes through the
*undistorted* pixel: the photo carries the lens distortion, so the pixel is undistorted with
the shot's K and dist first. ``geometry_ids`` -> (part, instance) is the triangle -> part table.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np
import open3d as o3d

from ..camera import Camera
from ..scene import Scene


class Picker:
    def __init__(self, scene: Scene):
        self.origin = scene.bounds().mean(axis=0)
        self.raycaster = o3d.t.geometry.RaycastingScene()
        self.table = {}
        for part in scene.parts:
            v = np.asarray(part.vertices, np.float64)
            hom = np.column_stack([v, np.ones(len(v))])
            faces = np.ascontiguousarray(part.faces, np.uint32)
            for transform, instance in zip(part.transforms, part.instance_ids):
                world = (hom @ np.asarray(transform).T)[:, :3] - self.origin
                gid = self.raycaster.add_triangles(o3d.core.Tensor(world.astype(np.float32)),
                                                   o3d.core.Tensor(faces))
                self.table[int(gid)] = (part.name, instance)
        self._lock = threading.Lock()

    def pick(self, camera: Camera, u: float, v: float) -> dict:
        """The part at pixel (u, v) of ``camera``'s (distorted) photo: name, instance, distance (m)."""
        pixel = np.array([[[u, v]]], np.float64)
        x, y = cv2.undistortPoints(pixel, camera.K, camera.dist).reshape(2)
        direction = camera.R.T @ np.array([x, y, 1.0])
        direction /= np.linalg.norm(direction)
        start = camera.center - self.origin
        ray = np.concatenate([start, direction]).astype(np.float32)[None]
        with self._lock:
            hit = self.raycaster.cast_rays(o3d.core.Tensor(ray))
        t = float(hit["t_hit"].numpy()[0])
        if not np.isfinite(t):
            return {"part": None, "instance": None, "distance": None}
        part, instance = self.table[int(hit["geometry_ids"].numpy()[0])]
        return {"part": part, "instance": instance, "distance": round(t, 3),
                "triangle": int(hit["primitive_ids"].numpy()[0])}
