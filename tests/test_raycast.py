"""The one ray caster (:mod:`mrcheck.scene.raycast`): hits and closest points name the part
instance and its triangle, hold their precision a million metres from the origin, and a scene
without triangles has no caster. Plus the warning / progress reporting of the commands that use
it (:mod:`mrcheck.cli.messages`, ``reference_ao``'s callback)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mrcheck.cli.messages import warning_lines
from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckWarning
from mrcheck.eval.reference import PROGRESS_STAGE, reference_ao
from mrcheck.scene.model import Scene, make_part
from mrcheck.scene.raycast import NO_HIT, build_caster, instance_labels

from .conftest import box


def _translation(x):
    T = np.eye(4)
    T[:3, 3] = x
    return T


def _scene(offset=(0.0, 0.0, 0.0)) -> Scene:
    """A floor plate (top at z = -0.5) and a 1 m cube at two instances, x = 0 and x = 3."""
    o = np.asarray(offset, np.float64)
    plate, cube = box((20, 20, 0.2), (0, 0, -0.6)), box((1, 1, 1), (0, 0, 0))
    parts = [
        make_part("plate", "t", np.asarray(plate.vertices, np.float64), np.asarray(plate.faces), [_translation(o)]),
        make_part(
            "cube",
            "t",
            np.asarray(cube.vertices, np.float64),
            np.asarray(cube.faces),
            [_translation(o), _translation(o + (3, 0, 0))],
            instance_ids=["left", "right"],
        ),
    ]
    return Scene("t", "t", parts)


def _rays(origin, targets):
    """(N, 6) rays from ``origin`` towards ``targets`` with unit directions."""
    d = np.asarray(targets, np.float64) - origin
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.column_stack((np.broadcast_to(origin, d.shape), d)).astype(np.float32)


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (1e6, -1e6, 3e5)])
def test_hits_name_the_instance_its_triangle_and_the_distance(offset):
    scene = _scene(offset)
    eye = np.asarray(offset) + (0.0, -5.0, 0.0)
    caster = build_caster(scene, eye)
    # rays relative to the caster's origin (the eye): to each cube's front face centre, and up into the sky
    hits = caster.cast(_rays(np.zeros(3), [(0, 5, 0), (3, 5, 0), (0, 5, 100)]))
    assert hits.hit.tolist() == [True, True, False]
    assert [caster.label(i) for i in hits.instance[:2]] == [("cube", "left"), ("cube", "right")]
    assert hits.instance[2] == NO_HIT and hits.triangle[2] == NO_HIT and np.isinf(hits.t[2])
    assert hits.t[0] == pytest.approx(4.5, abs=1e-4)  # the face at y = -0.5
    assert hits.t[1] == pytest.approx(0.9 * np.hypot(3.0, 5.0), abs=1e-4)  # enters the front face at x = 2.7
    cube = scene.parts[1]
    for triangle in hits.triangle[:2]:
        assert 0 <= triangle < len(cube.faces)
        corners = cube.vertices[cube.faces[triangle]].astype(np.float64)  # part-local: centred on the cube
        np.testing.assert_allclose(corners[:, 1], -0.5, atol=1e-6)  # a triangle of the front face


def test_occlusion_stops_at_tfar():
    caster = build_caster(_scene(), (0.0, -5.0, 0.0))
    ray = _rays(np.zeros(3), [(0, 5, 0)])
    assert caster.occluded(ray, tfar=4.4).tolist() == [False]
    assert caster.occluded(ray, tfar=4.6).tolist() == [True]


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (1e6, -1e6, 3e5)])
def test_closest_points_give_the_offset_the_normal_and_the_instance(offset):
    scene = _scene(offset)
    o = np.asarray(offset)
    caster = build_caster(scene, o + (3.0, 0.0, 1.0))
    points = o + np.array(
        [[3.0, 0.1, 0.75], [0.2, 0.0, 0.3], [8.0, 8.0, -0.4]]
    )  # above right, inside left, over the floor
    closest = caster.closest_points(points)
    np.testing.assert_allclose(closest.offset, [[0, 0, 0.25], [0, 0, -0.2], [0, 0, 0.1]], atol=1e-4)
    np.testing.assert_allclose(closest.normal, [[0, 0, 1], [0, 0, 1], [0, 0, 1]], atol=1e-6)
    assert [caster.label(i) for i in closest.instance] == [("cube", "right"), ("cube", "left"), ("plate", "plate")]


def test_a_scene_without_triangles_has_no_caster_and_labels_follow_the_soup():
    assert build_caster(Scene("t", "t", []), np.zeros(3)) is None
    scene = _scene()
    assert instance_labels(scene) == [("plate", "plate"), ("cube", "left"), ("cube", "right")]


def test_reference_ao_reports_its_rays_through_the_callback():
    scene = _scene()
    camera = Camera.from_look_at((0.0, -5.0, 1.0), (0.0, 0.0, -0.5), (0, 0, 1), 60, 16, 12)
    hits = build_caster(scene, camera.center)
    v, u = np.mgrid[0:12, 0:16].astype(np.float64)
    dirs = np.stack(((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)), -1).reshape(-1, 3)
    cast = hits.cast(np.column_stack((np.zeros_like(dirs), dirs @ camera.R)).astype(np.float32))
    depth = np.where(cast.hit, cast.t, 0.0).astype(np.float32).reshape(12, 16)  # camera z: the ray's z is 1
    normals = np.zeros((12, 16, 3), np.float32)
    normals[..., 2] = -1.0  # facing the camera
    calls = []
    reference_ao(scene, camera, depth, normals, 8, "world", 0.5, progress=lambda *a: calls.append(a))
    covered = int(np.count_nonzero(depth > 0))
    assert covered > 50 and calls and all(stage == PROGRESS_STAGE for stage, _, _ in calls)
    assert [total for _, _, total in calls] == [covered * 8] * len(calls)
    assert calls[-1][1] == covered * 8 and all(a[1] < b[1] for a, b in zip(calls, calls[1:]))


def test_mrcheck_warnings_become_one_line_each_time_and_others_stay_as_python_shows_them(capsys):
    # pytest.warns outside: a library's warning goes on to the handler that was there before
    with pytest.warns(UserWarning, match="a library's own warning"), warning_lines():
        for _ in range(2):  # the same place twice: both shown (no "once per location" filter)
            warnings.warn(MrcheckWarning("--radius has no effect"))
        warnings.warn("a library's own warning", UserWarning)
    assert capsys.readouterr().err.splitlines() == ["warning: --radius has no effect"] * 2
