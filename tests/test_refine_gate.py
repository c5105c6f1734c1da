"""The gate of ``--points/--markers --refine`` (:func:`mrcheck.mr.register.refinement_gate`): the
start's own correspondences and the edges' support decide whether the edges' pose replaces it."""

from __future__ import annotations

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.shot import Anchors, Shot
from mrcheck.mr.edges import EdgeOptions
from mrcheck.mr.register import anchor_excess, refinement_gate, start_options, start_sigma_px, support_gain

_BOUNDS = np.array([[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]])


def _start(sigma: float = 1.5) -> Shot:
    camera = Camera.from_look_at([0.0, -3.0, 0.5], [0.0, 0.0, 0.0], [0, 0, 1], 50.0, 640, 480)
    world = np.array([[x, y, z] for x in (-0.4, 0.4) for y in (-0.4, 0.4) for z in (-0.4, 0.4)])
    report = {"method": "points", "expected_overlay_error_px": 2.0}
    return Shot(camera, None, report, Anchors(world, camera.project(world), sigma))


def _refined(start: Shot, shift_m: float, gained: int = 60, lost: int = 5) -> Shot:
    camera = start.camera.with_pose(start.camera.R, start.camera.t + np.array([shift_m, 0.0, 0.0]))
    report = {"method": "edges", "above_chance": 0.3, "support_change": {"gained": gained, "lost": lost}}
    return Shot(camera, None, report)


def _px(start: Shot, refined: Shot) -> float:
    assert start.anchors is not None
    return float(np.mean(np.linalg.norm(refined.camera.project(start.anchors.world) - start.anchors.pixels, axis=1)))


def test_the_anchor_excess_is_the_growth_of_the_squared_errors_over_the_noise():
    start = _start(sigma=1.5)
    assert anchor_excess(start, start.camera) == 0.0
    refined = _refined(start, 0.002)
    assert start.anchors is not None
    moved = refined.camera.project(start.anchors.world) - start.anchors.pixels
    assert np.isclose(anchor_excess(start, refined.camera), np.sum(moved**2) / 1.5**2)
    assert anchor_excess(Shot(start.camera, None, start.report), refined.camera) is None


def test_a_pose_the_clicks_contradict_is_not_taken_one_they_allow_is():
    """8 clicks of 1.5 px: a pose that moves them 0.5 px passes (excess 0.9), one that moves
    them 3 px does not (excess 32, above 16.81)."""
    start = _start()
    near, far = _refined(start, 0.003), _refined(start, 0.0174)
    assert 0.3 < _px(start, near) < 0.7 and 2.5 < _px(start, far) < 3.5
    assert refinement_gate(start, near, _BOUNDS) is None
    reason = refinement_gate(start, far, _BOUNDS)
    assert reason is not None and reason.startswith("the edges' pose contradicts the clicked points")


def test_edges_that_gain_no_support_over_the_start_are_not_taken():
    """McNemar's chi-square: 30 samples gained against 10 lost is 10 (> 6.63, taken); 12 against
    8 is 0.8 (not taken); losing more is negative."""
    start = _start()
    assert support_gain(_refined(start, 0.0016, 30, 10)) == 10.0
    assert support_gain(_refined(start, 0.0016, 8, 12)) == -0.8
    assert support_gain(Shot(start.camera, None, {})) is None
    assert refinement_gate(start, _refined(start, 0.0016, 30, 10), _BOUNDS) is None
    reason = refinement_gate(start, _refined(start, 0.0016, 12, 8), _BOUNDS)
    assert reason is not None and reason.startswith("the edges find no more support"), reason


def test_the_refinement_searches_as_far_as_the_start_can_be_off_where_the_scene_is():
    """Clicks on a 10 cm object 3 m away: its pose is known to about a pixel there, far worse
    at the image's corners (``expected_overlay_error_px``). The search radius is 3 sigma at the
    object's box (at least 4 px), from the level where it is about 4 level px, along the normal;
    the other settings are the caller's."""
    camera = Camera.from_look_at([0.0, -3.0, 0.5], [0.0, 0.0, 0.0], [0, 0, 1], 50.0, 640, 480)
    world = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05)])
    start = Shot(camera, None, {"expected_overlay_error_px": 40.0}, Anchors(world, camera.project(world), 1.5))
    box = np.array([[-0.05, -0.05, -0.05], [0.05, 0.05, 0.05]])
    sigma = start_sigma_px(start, box)
    assert 0.3 < sigma < 3.0, sigma  # about the clicks' own noise, not the corners' 40 px
    options = start_options(start, box, EdgeOptions(silhouette=True))
    assert options.search_px == max(3 * sigma, 4.0) and options.coarse == "normal" and options.silhouette
    assert options.levels == 1 + max(0, int(np.floor(np.log2(options.search_px / 4.0))))
    far = start_options(start, box * 40)  # a scene reaching the image's corners: wider, coarser
    assert far.search_px > 3 * sigma and far.levels > options.levels
    without = Shot(camera, None, {"expected_overlay_error_px": 5.0})  # no correspondences kept
    assert start_sigma_px(without, box) == 5.0
