"""The camera of ``deviation --per-element``'s status picture (and its BCF snapshots) without a
shot: a view that sees the elements, not one from above the roof of an enclosed building."""

from __future__ import annotations

import numpy as np

from mrcheck.apps.deviation.element_image import overview_camera
from mrcheck.apps.discrepancies.ids import object_ids

from .conftest import box, scene_of

OUTSIDE = {"name": "overview", "eye": [-25.0, -30.0, 25.0], "target": [10.0, 10.0, 0.0], "fov_y_deg": 60.0}
INSIDE = {"name": "aisle", "eye": [2.0, 2.0, 1.6], "target": [15.0, 15.0, 0.5], "fov_y_deg": 60.0}


def _hall(roof: bool, *views):
    """A 20 x 20 m floor, four 4 m walls, 9 machines (1 m cubes) and, with ``roof``, a roof."""
    shell = [box((20, 20, 0.2), (10, 10, -0.1))]
    shell += [box((20, 0.2, 4), (10, y, 2)) for y in (0.1, 19.9)] + [box((0.2, 20, 4), (x, 10, 2)) for x in (0.1, 19.9)]
    if roof:
        shell.append(box((20, 20, 0.2), (10, 10, 4.1)))
    machines = [box((1, 1, 1), (x, y, 0.5)) for x in (5, 10, 15) for y in (5, 10, 15)]
    scene = scene_of(*shell, *machines)
    scene.viewpoints = {v["name"]: v for v in views}
    return scene, list(range(len(shell), len(shell) + len(machines)))


def _machines_seen(scene, machines, camera) -> int:
    ids, _, labels = object_ids(scene, camera.resized(320, 240))
    parts = {f"part{i}" for i in machines}
    return len({labels[i][0] for i in np.unique(ids[ids >= 0])} & parts)


def test_under_a_roof_the_picture_is_taken_inside():
    scene, machines = _hall(True, OUTSIDE)
    assert _machines_seen(scene, machines, scene.camera("overview")) == 0  # the roof hides them all
    camera = overview_camera(scene)
    lo, hi = scene.bounds()
    assert np.all(camera.center > lo) and np.all(camera.center < hi)
    assert _machines_seen(scene, machines, camera) >= 6


def test_a_viewpoint_inside_is_taken_as_it_is():
    scene, _ = _hall(True, OUTSIDE, INSIDE)
    np.testing.assert_allclose(overview_camera(scene).center, INSIDE["eye"])


def test_without_a_roof_the_first_viewpoint_stays():
    scene, machines = _hall(False, OUTSIDE)
    camera = overview_camera(scene)
    np.testing.assert_allclose(camera.center, OUTSIDE["eye"])
    assert _machines_seen(scene, machines, camera) == 9
