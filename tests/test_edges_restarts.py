"""Restarts of an accepted edge fit when one part fits far worse than the others
(:mod:`mrcheck.mr.edges.restarts`): which part lags, the steps along the weakest directions, and
DLR M3T frame 200, where the prism landed in a wrong basin while the bottle fit."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.eval.realdata import real_root
from mrcheck.mr.edges import EdgeOptions, solver
from mrcheck.mr.edges.model import Samples
from mrcheck.mr.edges.options import EdgeFit
from mrcheck.mr.edges.restarts import RESTART_PX, lagging_part, weak_steps
from mrcheck.mr.edges.uncertainty import PoseUncertainty

K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])


def _fit(parts: dict) -> EdgeFit:
    camera = Camera(640, 480, K, np.eye(3), np.zeros(3))
    return EdgeFit(camera, 1.0, 0.5, 100, PoseUncertainty.__new__(PoseUncertainty), part_above=parts)


def test_the_lagging_part_is_the_lowest_below_nine_tenths_of_the_best():
    assert lagging_part(_fit({"prism": 0.24, "bottle": 0.57})) == "prism"
    assert lagging_part(_fit({"prism": 0.85, "bottle": 0.71})) == "bottle"  # 0.83 of the best
    assert lagging_part(_fit({"prism": 0.82, "bottle": 0.79})) is None  # 0.96 of the best: no restart
    assert lagging_part(_fit({"a": 0.5, "b": 0.3, "c": 0.1})) == "c"
    assert lagging_part(_fit({"only": 0.1})) is None  # one part: nothing to compare with
    assert lagging_part(_fit({"a": -0.1, "b": -0.2})) is None  # no part fits: the verdict's matter


def _line(start, direction, n=40):
    return start + np.linspace(0, 1, n)[:, None] * np.asarray(direction, float)


def test_steps_move_the_lagging_part_by_the_named_pixels_and_the_others_least():
    """A long bar along x (part 0) and a small square to its side (part 1): the bar alone leaves
    directions free (a turn about its own axis, a slide along it); the steps move the square by
    8 and 16 px (median) both ways and the bar's edges far less across themselves (along them
    the edges show nothing)."""
    bar = np.concatenate([_line([-0.5, 0.0, 2.0], [1, 0, 0]), _line([-0.5, 0.02, 2.0], [1, 0, 0])])
    square = np.concatenate([_line([0.3, 0.3, 2.2], d) for d in ([0.1, 0, 0], [0, 0.1, 0])])
    tangents = np.concatenate([np.tile([1.0, 0, 0], (80, 1)), np.tile([1.0, 0, 0], (40, 1)),
                               np.tile([0, 1.0, 0], (40, 1))])  # fmt: skip
    group = np.r_[np.zeros(80, int), np.ones(80, int)]
    samples = Samples(np.concatenate([bar, square]), tangents, group, np.arange(160))
    camera = Camera(640, 480, K, cv2.Rodrigues(np.array([0.05, 0.0, 0.0]))[0], np.zeros(3))
    pose = solver.PoseState.of(camera, samples.points.mean(axis=0))
    steps = weak_steps(camera, samples, pose, 1)
    assert len(steps) == 4 * len(RESTART_PX)
    before = camera.project(samples.points)
    normals = solver.project(pose, camera, samples.points, samples.tangents).normal
    for k, step in enumerate(steps):
        after = pose.moved(step).camera(camera).project(samples.points)
        moved = np.linalg.norm(after - before, axis=1)
        across = np.abs(np.sum((after - before) * normals, axis=1))
        assert np.median(moved[group == 1]) == pytest.approx(RESTART_PX[(k // 2) % len(RESTART_PX)], rel=0.1)
        assert np.median(across[group == 0]) < 0.25 * np.median(moved[group == 1])


needs_m3t = pytest.mark.skipif(not (real_root() / "m3t").is_dir(), reason="../shared/data/real (DLR M3T) is absent")


def _m3t_fits(seed: int) -> tuple:
    """M3T frame 200 from ``bench --real``'s 20 px start ``seed``, fitted without and with the
    restarts; (each body's median px from the published pose per fit, the two fits)."""
    from mrcheck.core.camerafiles import read_photo
    from mrcheck.eval.edgephotos import perturbed, reprojection_error
    from mrcheck.eval.realbench import MAX_POINTS, placed
    from mrcheck.eval.realdata import camera_scene, m3t_photo
    from mrcheck.mr.edges import refine_pose

    photo = m3t_photo(real_root(), 200)
    scene, truth = camera_scene(photo)
    rgb = read_photo(photo.photo)
    points = np.concatenate([placed(o.vertices, o.pose, MAX_POINTS) for o in photo.objects])
    start = perturbed(truth, points, 20.0, np.random.default_rng(1000 * seed + 20))
    bodies = {o.name: placed(o.vertices, o.pose) for o in photo.objects}
    fits = [refine_pose(scene, truth, rgb, initial=start, options=EdgeOptions(restarts=r)) for r in (False, True)]
    errors = [{n: float(np.median(reprojection_error(truth, f.camera, p))) for n, p in bodies.items()} for f in fits]
    return errors, fits


@needs_m3t
def test_m3t_prism_in_a_wrong_basin_is_restarted_into_the_right_one():
    """M3T frame 200 from 20 px off (``bench --real``'s seed 1): without restarts the bottle fits
    (2.4 px) and the prism is 11.9 px off; with them both are within 2 px (measured 1.49 and
    1.35 px, the same in every run: the fit is deterministic; seeds 0-9: 10 of 10 within 2 px
    over all vertices, seeds 40-49 held out: 9 of 10)."""
    (alone, errors), (first, fit) = _m3t_fits(1)
    assert max(alone.values()) > 5.0 and first.restart == ""
    assert max(errors.values()) < 2.0, errors
    assert "kept a restart" in fit.restart and fit.above_chance > first.above_chance


@needs_m3t
def test_m3t_second_start_in_a_wrong_basin_is_mended():
    """M3T frame 200 from ``bench --real``'s 20 px start 4: the chamfer schedule's fit leaves the
    prism in a wrong basin, and the restarts or the normal schedule's fit (a candidate after a
    chamfer fit with a part lagging) mend it. Which wrong basin depends on the CPU's floating
    point (the fit is deterministic on one machine, not across CPUs): measured on two 2-core
    x86_64 machines, one put the prism 52.8 px off (0.12 beyond chance, the bottle's own 0.06) and
    the normal schedule's fit won (1.3 px, 0.80); an AMD EPYC put it 14.5 px off (0.55) and a
    restart won (1.7 px, 0.80). Either way the fit kept says so, and both bodies end within 2 px."""
    (alone, errors), (first, fit) = _m3t_fits(4)
    assert max(alone.values()) > 5.0 and first.restart == ""
    assert max(errors.values()) < 2.0, errors
    assert fit.restart.startswith("the chamfer schedule's fit had") or "kept a restart" in fit.restart, fit.restart
    assert fit.above_chance > first.above_chance + 0.05
