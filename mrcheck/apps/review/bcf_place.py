"""Where a topic another tool made lands in the review: an issue raised in a BIM tool (a GUID no
marker has, a perspective camera, maybe a selected element) becomes a marker on a shot.

* the shot whose camera the viewpoint's camera is (within :data:`POSITION_M` and
  :data:`ANGLE_DEG`: a BIM tool stores the pose rounded, and a topic made on an exported view
  comes back with it): the marker where the selected element's centre projects, else at the
  image centre (what the camera looks at);
* else the shot that sees the selected element (its bounding box's centre projects inside the
  photo, in front of the camera), the one where it lies nearest the image centre;
* else none: the topic is counted as unknown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

POSITION_M = 0.25  # metres between the viewpoint's eye and a shot's camera centre
ANGLE_DEG = 5.0  # degrees between the viewing directions


@dataclass(frozen=True)
class Place:
    """A shot and a photo pixel, with the element found there (its instance id, or None)."""

    shot: str
    x: float
    y: float
    part: str | None


def _element(scene, topic) -> tuple[str, np.ndarray] | None:
    """(instance id, world centre) of the topic's first component the scene has (by IfcGuid,
    which an IFC import uses as instance id, or by the authoring tool's id)."""
    for component in topic.components:
        for key in (component.ifc_guid, component.tool_id):
            found = scene.element(key) if key else None
            if found:
                part, k, _ = found
                return key, part.instance_bounds()[k].mean(axis=0)
    return None


def _pixel(camera, point) -> tuple[float, float] | None:
    """Where ``point`` projects in the photo of ``camera``, None when behind it or outside."""
    if (camera.R @ point + camera.t)[2] <= 0:
        return None
    x, y = camera.project(point[None])[0]
    return (float(x), float(y)) if 0 <= x < camera.width and 0 <= y < camera.height else None


def _same_camera(camera, bcf) -> bool:
    eye = np.asarray(bcf.viewpoint, np.float64)
    direction = np.asarray(bcf.direction, np.float64)
    norm = np.linalg.norm(direction)
    if not (np.all(np.isfinite(eye)) and np.isfinite(norm) and norm > 0):
        return False
    axis = camera.R.T @ np.array([0.0, 0.0, 1.0])
    angle = math.degrees(math.acos(float(np.clip(axis @ direction / norm, -1.0, 1.0))))
    return float(np.linalg.norm(camera.center - eye)) <= POSITION_M and angle <= ANGLE_DEG


def place_topic(shots: dict, scene, topic) -> Place | None:
    """Where the topic's marker goes among ``shots`` ({name: shot with a ``camera``}), or None."""
    element = _element(scene, topic) if scene is not None else None
    part = element[0] if element else None
    if topic.camera is not None:
        for name, shot in shots.items():
            if _same_camera(shot.camera, topic.camera):
                at = _pixel(shot.camera, element[1]) if element else None
                x, y = at or (shot.camera.cx, shot.camera.cy)
                return Place(name, x, y, part if at else None)
    if element is None:
        return None
    best = None
    for name, shot in shots.items():
        at = _pixel(shot.camera, element[1])
        if at is not None:
            off = math.hypot(
                (at[0] - shot.camera.cx) / shot.camera.width, (at[1] - shot.camera.cy) / shot.camera.height
            )
            if best is None or off < best[0]:
                best = (off, Place(name, at[0], at[1], part))
    return best[1] if best else None


__all__ = ["Place", "place_topic", "POSITION_M", "ANGLE_DEG"]
