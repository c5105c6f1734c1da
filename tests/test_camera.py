"""The camera contract: OpenCV pinhole, GL projection exactly from K, camera JSON."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera
from mrcheck.core.errors import MrcheckError

from .conftest import box, render_depth, scene_of

W, H = 320, 240


def _off_centre_camera() -> Camera:
    # fx != fy and a principal point far from the centre, as calibrations deliver them
    K = np.array([[300.0, 0.0, 0.31 * W], [0.0, 285.0, 0.62 * H], [0.0, 0.0, 1.0]])
    pose = Camera.from_look_at((1.0, -6.0, 2.0), (0.0, 0.0, 1.0), (0, 0, 1), 60, W, H)
    return Camera(W, H, K, pose.R, pose.t)


def test_rendered_pixels_are_exactly_those_opencv_projects_inside(ctx):
    # GL covers a pixel when its centre is inside the projected triangle, and OpenCV puts the
    # centre of pixel (i, j) at (u, v) = (i, j). So the covered pixels of a square must be
    # exactly those whose (i, j) lies inside the polygon of its corners projected by
    # cv2.projectPoints; a half-pixel or principal-point error flips whole rows or columns.
    camera = _off_centre_camera()
    rvec = cv2.Rodrigues(camera.R)[0]
    for centre in ([0, 0, 1], [-1.5, 0.5, 2.2], [1.2, -0.4, 0.3], [0.4, 1.0, 1.6], [-0.8, -1.0, 0.2]):
        square = trimesh.creation.box((0.3, 0.2, 0.001))
        square.apply_transform(trimesh.geometry.align_vectors((0, 0, 1), camera.center - np.asarray(centre, float)))
        square.apply_translation(centre)
        covered = render_depth(ctx, scene_of(square), camera) > 0
        front = square.vertices[(square.vertices - centre) @ (camera.center - centre) > 0]
        corners, _ = cv2.projectPoints(front, rvec, camera.t, camera.K, None)
        hull = cv2.convexHull(corners.reshape(-1, 2).astype(np.float32))
        (u0, v0), (u1, v1) = np.floor(hull.min(axis=(0, 1))) - 2, np.ceil(hull.max(axis=(0, 1))) + 2
        for j, i in np.ndindex(int(v1 - v0), int(u1 - u0)):
            i, j = int(u0) + i, int(v0) + j
            d = cv2.pointPolygonTest(hull, (float(i), float(j)), True)
            if abs(d) > 0.02:  # pixel centres right on an edge may go either way
                assert covered[j, i] == (d > 0), (centre, i, j, d)
        assert covered.sum() > 50
    assert np.allclose(
        camera.project(np.eye(3)), cv2.projectPoints(np.eye(3), rvec, camera.t, camera.K, None)[0].reshape(-1, 2)
    )


def test_depth_buffer_holds_linear_camera_z(ctx):
    camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 60, W, H)
    depth = render_depth(ctx, scene_of(box((100, 0.1, 100), (0, 7.05, 0))), camera)
    assert depth.dtype == np.float32
    assert np.allclose(depth, 7.0, rtol=1e-6)


def test_look_at_puts_the_target_at_the_image_centre_and_keeps_up_up():
    camera = Camera.from_look_at((3, -4, 1.7), (0, 0, 1.0), (0, 0, 1), 50, W, H)
    u, v = camera.project(np.array([[0, 0, 1.0], [0, 0, 2.0]])).T
    assert u[0] == pytest.approx((W - 1) / 2) and v[0] == pytest.approx((H - 1) / 2)
    assert v[1] < v[0]  # higher in the world is higher in the image (smaller row)
    assert camera.fy == pytest.approx(0.5 * H / np.tan(np.radians(25)))
    assert np.allclose(camera.center, (3, -4, 1.7))


def test_camera_json_round_trip_and_shot_files(tmp_path):
    camera = _off_centre_camera()
    shot = camera.to_dict() | {
        "dist": [0.1, -0.05, 0.001, 0.0, 0.01],
        "photo": "IMG_1.jpg",
        "rms": 0.4,
        "method": "markers",
    }
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(shot))
    loaded = load_camera(path)
    assert np.allclose(loaded.K, camera.K) and np.allclose(loaded.R, camera.R) and np.allclose(loaded.t, camera.t)
    assert loaded.dist.tolist() == shot["dist"]
    assert Camera.from_dict(loaded.to_dict()).to_dict() == loaded.to_dict()


def test_resize_scales_about_the_pixel_grid():
    camera = _off_centre_camera()
    half = camera.resized(W // 2, H // 2)
    point = np.array([[0.3, 0.2, 1.1]])
    u, v = camera.project(point)[0]
    hu, hv = half.project(point)[0]
    # pixel u covers [u - 0.5, u + 0.5]: the image edge at -0.5 stays the edge
    assert hu == pytest.approx((u + 0.5) / 2 - 0.5) and hv == pytest.approx((v + 0.5) / 2 - 0.5)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"width": 0}, "positive"),
        ({"K": [[0, 0, 1], [0, 100, 1], [0, 0, 1]]}, "focal"),
        ({"K": [[1, 2], [3, 4]]}, "shape"),
        ({"R": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}, "rotation"),
        ({"t": [0, float("nan"), 0]}, "NaN"),
    ],
)
def test_bad_cameras_are_refused_with_a_reason(change, message):
    data = _off_centre_camera().to_dict() | change
    with pytest.raises(MrcheckError, match=message):
        Camera.from_dict(data, "cam.json")
