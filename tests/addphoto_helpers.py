"""The review's "Add photo" in tests: a SCENE --shots DIR review of the sample cell whose folder
holds a synthetic photo (rendered at a known camera, lens distortion included) and its
intrinsics, and the pairs of clicks a careful planner would make on it and on a CAD view."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from mrcheck.apps.review.pick import Picker
from mrcheck.core.camera import Camera
from mrcheck.core.output import write_image
from mrcheck.core.resources import sample_scene_path
from mrcheck.scene.model import load_scene

from .mr_helpers import make_camera, render_photo

SIZE = (480, 360)
TRUTH_EYE, TRUTH_TARGET = np.array([2.6, -6.6, 2.0]), np.array([3.2, -2.4, 0.8])
VIEW = "view:robot"  # the CAD view clicked on: the sample cell's named viewpoint "robot"


def truth_camera() -> Camera:
    return make_camera(*SIZE, 420.0, dist=(-0.06, 0.0, 0.0, 0.0, 0.0), eye=TRUTH_EYE, target=TRUTH_TARGET)


def make_folder(ctx, folder: Path) -> Path:
    """``folder`` with photo.png (of :func:`truth_camera`), cam.json (its intrinsics) and one
    registered shot (other.json, another view with the same photo: the review needs one)."""
    folder.mkdir(parents=True, exist_ok=True)
    scene = load_scene(sample_scene_path())
    truth = truth_camera()
    write_image(folder / "photo.png", render_photo(ctx, scene, truth))
    (folder / "cam.json").write_text(json.dumps(truth.to_dict(pose=False)))
    other = make_camera(*SIZE, 420.0, eye=TRUTH_EYE + (-1.0, 0.5, 0.0), target=TRUTH_TARGET)
    (folder / "other.json").write_text(json.dumps({**other.to_dict(), "photo": "photo.png"}))
    return folder


def project(camera: Camera, world) -> np.ndarray:
    """Pixels of world points in ``camera``'s (distorted) image."""
    world = np.asarray(world, np.float64)
    pixels, _ = cv2.projectPoints(world, cv2.Rodrigues(camera.R)[0], camera.t, camera.K, camera.dist)
    return pixels.reshape(-1, 2)


def _solid(picker, camera: Camera, pixel, hit) -> bool:
    """The pixels 3 px around ``pixel`` hit the same part within 15 cm of ``hit``: a point on a
    face a planner can click, not on a fence's wire (which a click a pixel off misses)."""
    for du, dv in ((-3, 0), (3, 0), (0, -3), (0, 3)):
        near = picker.world_point(camera, pixel[0] + du, pixel[1] + dv)
        if near is None or near[1] != hit[1] or np.linalg.norm(near[0] - hit[0]) > 0.15:
            return False
    return True


def scene_points(scene, view: Camera, count: int = 8, truth: Camera | None = None) -> np.ndarray:
    """World points on the CAD seen by both the truth camera (default :func:`truth_camera`) and
    ``view`` (the ray cast from each hits the same point, on a solid face), spread over the
    photo: what a planner would click."""
    picker, truth = Picker(scene), truth or truth_camera()
    points = []
    for v in np.linspace(0.1, 0.9, 9) * truth.height:
        for u in np.linspace(0.05, 0.95, 10) * truth.width:
            hit = picker.world_point(truth, u, v)
            if hit is None or not _solid(picker, truth, (u, v), hit):
                continue
            seen = project(Camera(view.width, view.height, view.K, view.R, view.t), hit[0][None])[0]
            if not (5 <= seen[0] < view.width - 5 and 5 <= seen[1] < view.height - 5):
                continue
            back = picker.world_point(view, *seen)
            if back is not None and np.linalg.norm(back[0] - hit[0]) < 0.01 and _solid(picker, view, seen, back):
                points.append(hit[0])
    points = np.array(points)
    assert len(points) >= count, f"only {len(points)} points seen from both cameras"
    return points[np.linspace(0, len(points) - 1, count).astype(int)]


def median_error_px(camera: Camera, scene_world) -> float:
    """Median distance (px) between the points as ``camera`` and as the truth sees them."""
    return float(np.median(np.linalg.norm(project(camera, scene_world) - project(truth_camera(), scene_world), axis=1)))
