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
:class:`mrcheck.scene.raycast.SceneCaster`'s (its hits name the part instance and the triangle).
"""

from __future__ import annotations

import threading

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene
from mrcheck.scene.raycast import SceneCaster, build_caster

ORIGIN_RADIUS_M = 1000.0  # float32 spacing 6e-5 m at 1 km: picks to the millimetre nearby
MAX_ORIGINS = 4  # ray-casting scenes kept (each holds the whole scene once)


class Picker:
    def __init__(self, scene: Scene):
        self.scene = scene
        self._casters: list[tuple[np.ndarray, SceneCaster | None]] = []
        self._lock = threading.Lock()
        self._element_table: dict | None = None

    def _caster_for(self, centre: np.ndarray):
        """(origin, caster or None for a scene without triangles) for a camera at ``centre``;
        call with the lock held."""
        for entry in self._casters:
            if np.linalg.norm(centre - entry[0]) <= ORIGIN_RADIUS_M:
                return entry
        entry = (centre.copy(), build_caster(self.scene, centre))
        self._casters = [entry] + self._casters[: MAX_ORIGINS - 1]
        return entry

    @staticmethod
    def ray(camera: Camera, u: float, v: float) -> np.ndarray:
        """The unit world direction of the ray through the (distorted) photo pixel (u, v)."""
        pixel = np.array([[[u, v]]], np.float64)
        x, y = cv2.undistortPoints(pixel, camera.K, camera.dist).reshape(2)
        direction = camera.R.T @ np.array([x, y, 1.0])
        return direction / np.linalg.norm(direction)

    def _cast(self, camera: Camera, u: float, v: float):
        """(hits or None for no hit, caster, unit ray direction) of pixel (u, v)."""
        direction = self.ray(camera, u, v)
        with self._lock:
            origin, caster = self._caster_for(camera.center)
            ray = np.concatenate([camera.center - origin, direction]).astype(np.float32)[None]
            hits = caster.cast(ray) if caster is not None else None
        return (hits if hits is not None and hits.hit[0] else None), caster, direction

    def world_point(self, camera: Camera, u: float, v: float):
        """(world point (3,) float64, instance id) of the CAD surface at pixel (u, v), or None."""
        hits, caster, direction = self._cast(camera, u, v)
        if hits is None:
            return None
        return camera.center + float(hits.t[0]) * direction, caster.label(hits.instance[0])[1]

    def pick(self, camera: Camera, u: float, v: float, point: bool = False) -> dict:
        """The part at pixel (u, v) of ``camera``'s (distorted) photo: name, instance, distance (m);
        with ``point``, also the world ``point`` hit (None where nothing is), from the same cast."""
        hits, caster, direction = self._cast(camera, u, v)
        if hits is None:
            return {"part": None, "instance": None, "distance": None, **({"point": None} if point else {})}
        part, instance = caster.label(hits.instance[0])
        info = self._elements().get(instance)
        where = camera.center + float(hits.t[0]) * direction
        return {
            **({"point": [round(float(c), 5) for c in where]} if point else {}),
            "part": part,
            "instance": instance,
            "distance": round(float(hits.t[0]), 3),
            "triangle": int(hits.triangle[0]),
            # an imported (IFC/STEP) element's name, class and storey; empty for other scenes
            "name": info.name if info else "",
            "ifc_class": info.ifc_class if info else "",
            "storey": info.storey if info else "",
        }

    def _elements(self) -> dict:
        """{instance id: ElementInfo} of the scene (made once)."""
        if self._element_table is None:
            self._element_table = {
                iid: info for part in self.scene.parts for iid, info in zip(part.instance_ids, part.instance_info)
            }
        return self._element_table
