"""Which CAD part is under a pixel: an Open3D ray cast from the registered camera.

Open3D casts in float32, and a factory at map coordinates may sit 5e6 m from the origin, or
hold one stray element there (an IFC export's): float32 relative to the scene's centre would
then round the geometry near the camera to metres. The RaycastingScene therefore holds every
instance of every part relative to an origin near the camera, subtracted in float64 before the
cast: float32 keeps better than 0.1 mm within a few kilometres of it. One such scene serves
every shot whose camera stands within :data:`ORIGIN_RADIUS_M` of its origin (the shots of one
hall share one); a shot elsewhere gets its own, around its camera centre. The ray starts at the
camera centre and goes through the *undistorted* pixel: the photo carries the lens distortion,
so the pixel is undistorted with the shot's K and dist first. The ray casting itself is
:class:`mrcheck.eval.raycast.SceneCaster`'s (its hits name the part instance and the triangle).
"""

from __future__ import annotations

import threading

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.eval.raycast import SceneCaster, build_caster
from mrcheck.scene.model import Scene

ORIGIN_RADIUS_M = 1000.0   # float32 spacing 6e-5 m at 1 km: picks to the millimetre nearby
MAX_ORIGINS = 4            # ray-casting scenes kept (each holds the whole scene once)


class Picker:
    def __init__(self, scene: Scene):
        self.scene = scene
        self._casters: list[tuple[np.ndarray, SceneCaster | None]] = []
        self._lock = threading.Lock()

    def _caster_for(self, centre: np.ndarray):
        """(origin, caster or None for a scene without triangles) for a camera at ``centre``;
        call with the lock held."""
        for entry in self._casters:
            if np.linalg.norm(centre - entry[0]) <= ORIGIN_RADIUS_M:
                return entry
        entry = (centre.copy(), build_caster(self.scene, centre))
        self._casters = [entry] + self._casters[:MAX_ORIGINS - 1]
        return entry

    def pick(self, camera: Camera, u: float, v: float) -> dict:
        """The part at pixel (u, v) of ``camera``'s (distorted) photo: name, instance, distance (m)."""
        pixel = np.array([[[u, v]]], np.float64)
        x, y = cv2.undistortPoints(pixel, camera.K, camera.dist).reshape(2)
        direction = camera.R.T @ np.array([x, y, 1.0])
        direction /= np.linalg.norm(direction)
        with self._lock:
            origin, caster = self._caster_for(camera.center)
            ray = np.concatenate([camera.center - origin, direction]).astype(np.float32)[None]
            hits = caster.cast(ray) if caster is not None else None
        if hits is None or not hits.hit[0]:
            return {"part": None, "instance": None, "distance": None}
        part, instance = caster.label(hits.instance[0])
        return {"part": part, "instance": instance, "distance": round(float(hits.t[0]), 3),
                "triangle": int(hits.triangle[0])}
