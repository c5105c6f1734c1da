"""Clicked points (issue 40): the outlier threshold follows from the click noise, the pose is refit
on all inliers, equally supported click sets that disagree are refused, and ``--refine`` never
replaces the start's pose with one its own evidence does not support. Synthetic and fast; the
LM-O measurement is tests/test_lmo_clicks.py."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.shot import Shot
from mrcheck.mr import register as register_module
from mrcheck.mr.edges import EdgeFitError
from mrcheck.mr.pose import CLICK_SIGMA_PX, Pose, Rival, click_threshold, reprojection_errors, solve_pose
from mrcheck.mr.register import gated_refinement, overlay_moved, refinement_gate
from mrcheck.mr.registration import refuse_ambiguous, register_points

TRUTH = Camera.from_look_at([0.6, -0.9, 0.5], [0.0, 0.0, 0.0], [0, 0, 1], 50.0, 640, 480)
INTRINSICS = Camera(640, 480, TRUTH.K)


def _object(n: int = 8, seed: int = 0) -> np.ndarray:
    """``n`` points on a 0.2 m object at ~1.2 m: a small part seen like LM-O's."""
    return np.random.default_rng(seed).uniform(-0.1, 0.1, size=(n, 3))


def _pairs(world: np.ndarray, pixels: np.ndarray) -> dict:
    return {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels, world)]}


def test_the_threshold_is_the_999_quantile_of_a_2d_gaussian_click():
    assert click_threshold(1.0) == pytest.approx(math.sqrt(-2 * math.log(0.001)))  # 3.72 sigma
    assert click_threshold(CLICK_SIGMA_PX) == pytest.approx(5.57, abs=0.01)
    errors = np.linalg.norm(np.random.default_rng(0).normal(0.0, 1.5, size=(400_000, 2)), axis=1)
    assert np.mean(errors > click_threshold(1.5)) == pytest.approx(0.001, abs=0.0003)
    world = _object()
    pose = solve_pose(INTRINSICS, TRUTH.project(world), world, noise_px=2.0)
    assert pose.threshold == pytest.approx(click_threshold(2.0))


@pytest.mark.slow
def test_honest_clicks_are_kept_and_a_gross_misclick_rejected():
    """12 sets of 8 clicks with 1.5 px noise, one moved 10-30 px: no honest click is lost and the
    mis-click always is; a fixed 3 px threshold (the old rule) loses honest ones."""
    honest_lost = fixed_lost = 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        world = _object(seed=seed)
        pixels = TRUTH.project(world) + rng.normal(0.0, 1.5, size=(8, 2))
        pixels[3] += rng.uniform(10, 30) * np.array([0.6, 0.8])
        try:
            shot = register_points(INTRINSICS, _pairs(world, pixels))
        except MrcheckError as exc:
            assert "ambiguous clicks" in str(exc)
            continue
        rejected = {r["index"] for r in shot.report["rejected"]}
        assert 3 in rejected
        honest_lost += len(rejected - {3})
        fixed = solve_pose(INTRINSICS, pixels, world, max_error=3.0)
        fixed_lost += int((~fixed.inliers).sum()) - (not fixed.inliers[3])
    assert honest_lost == 0, honest_lost
    assert fixed_lost >= 3, fixed_lost  # the rule the threshold replaces


def test_the_pose_is_refit_on_all_inliers():
    world = _object(12, seed=3)
    pixels = TRUTH.project(world) + np.random.default_rng(3).normal(0.0, 1.5, size=(12, 2))
    pose = solve_pose(INTRINSICS, pixels, world, noise_px=1.5)
    assert pose.inliers.all()
    rvec, tvec = cv2.Rodrigues(pose.R)[0], pose.t.reshape(3, 1).copy()
    refit_r, refit_t = cv2.solvePnPRefineLM(world, pixels, INTRINSICS.K, INTRINSICS.dist, rvec.copy(), tvec.copy())
    refit = reprojection_errors(INTRINSICS, refit_r, refit_t, pixels, world)
    assert pose.rms <= math.sqrt(np.mean(refit**2)) + 1e-9  # no better fit of all 12 exists nearby
    assert np.allclose(refit_t.ravel(), pose.t, atol=1e-6)


def _two_explanations(turn_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """4 clicks from the true pose and 4 from the object (0.6 m) turned ``turn_deg`` about its centre."""
    world = 3.0 * np.array(
        [[-0.1, -0.1, 0], [0.1, -0.1, 0.02], [0.1, 0.1, -0.02], [-0.1, 0.1, 0.05]]
        + [[-0.05, 0, 0.1], [0.05, -0.05, -0.1], [0, 0.08, 0.08], [0.08, 0.02, -0.06]]
    )
    turn = cv2.Rodrigues(np.array([0.0, 0.0, math.radians(turn_deg)]))[0]
    pixels = TRUTH.project(world)
    pixels[4:] = TRUTH.project(world[4:] @ turn.T)
    return world, pixels


def test_two_disagreeing_click_sets_of_equal_support_are_refused():
    world, pixels = _two_explanations(12.0)
    with pytest.raises(MrcheckError, match=r"ambiguous clicks: points 0, 1, 2, 3 .* and 4, 5, 6, 7 .*12.0 deg apart"):
        register_points(INTRINSICS, _pairs(world, pixels))
    world, pixels = _two_explanations(0.0)  # one explanation: all 8 used
    assert len(register_points(INTRINSICS, _pairs(world, pixels)).report["used"]) == 8


def test_a_rival_within_the_pose_s_own_noise_is_not_a_refusal():
    """The rule: refused beyond 3 sigma of the returned pose's rotation (and 2 deg)."""
    pose = Pose(np.eye(3), np.zeros(3), np.zeros(8), np.arange(8) < 7, 5.0)
    refuse_ambiguous(pose)  # no rival
    refuse_ambiguous(Pose(pose.R, pose.t, pose.errors, pose.inliers, 5.0, Rival(~pose.inliers, 1.0, 5.0, 2.0)))
    refuse_ambiguous(Pose(pose.R, pose.t, pose.errors, pose.inliers, 5.0, Rival(~pose.inliers, 1.0, 1.9, 0.1)))
    with pytest.raises(MrcheckError, match="ambiguous"):
        refuse_ambiguous(Pose(pose.R, pose.t, pose.errors, pose.inliers, 5.0, Rival(~pose.inliers, 1.0, 6.5, 2.0)))


# -- the --refine gate ---------------------------------------------------------------------------

BOUNDS = np.array([[-0.1, -0.1, -0.1], [0.1, 0.1, 0.1]])


def _start(sigma_px: float = 0.5) -> Shot:
    return Shot(TRUTH, None, {"method": "points", "expected_overlay_error_px": sigma_px, "warnings": []})


def _moved(px: float, above_chance: float | None) -> Shot:
    """A refined shot whose camera is turned so that the object's overlay moves ~``px``."""
    turn = cv2.Rodrigues(np.array([0.0, px / TRUTH.K[0, 0], 0.0]))[0]
    camera = TRUTH.with_pose(turn @ TRUTH.R, turn @ TRUTH.t)
    return Shot(camera, None, {"method": "edges", "above_chance": above_chance, "warnings": []})


def test_overlay_moved_measures_the_object_s_displacement():
    assert overlay_moved(TRUTH, _moved(10.0, None).camera, BOUNDS) == pytest.approx(10.0, rel=0.05)


def test_a_refinement_that_moves_away_without_strong_evidence_is_not_applied():
    reason = refinement_gate(_start(0.5), _moved(10.0, 0.2), BOUNDS)
    assert reason is not None and "moved the overlay 10" in reason and "0.20 beyond chance" in reason
    assert refinement_gate(_start(0.5), _moved(1.2, 0.2), BOUNDS) is None  # within 3 sigma (1.5 px)
    assert refinement_gate(_start(4.0), _moved(10.0, 0.2), BOUNDS) is None  # a weak start: 12 px
    assert refinement_gate(_start(0.5), _moved(10.0, 0.7), BOUNDS) is None  # strong edges


def test_the_start_is_kept_and_says_why(monkeypatch, tmp_path):
    def far(photo, camera, model, rough, start, options=None):
        return _moved(10.0, 0.1)

    class Model:
        def bounds(self):
            return BOUNDS

    monkeypatch.setattr(register_module, "snap_photo", far)
    kept = gated_refinement(_start(), tmp_path / "p.png", INTRINSICS, Model(), "points")
    assert kept.camera is TRUTH and kept.report["refinement"].startswith("not applied: the edges moved")
    assert kept.warnings[-1].startswith("refinement not applied: the edges moved")

    def failing(photo, camera, model, rough, start, options=None):
        raise EdgeFitError("edge registration failed: only 3 visible CAD edge samples (>= 30 needed)")

    monkeypatch.setattr(register_module, "snap_photo", failing)
    kept = gated_refinement(_start(), tmp_path / "p.png", INTRINSICS, Model(), "points")
    assert (
        kept.report["refinement"] == "not applied: the edge fit failed (only 3 visible CAD edge samples (>= 30 needed))"
    )
    applied = _moved(1.0, 0.3)
    monkeypatch.setattr(register_module, "snap_photo", lambda *args: applied)
    assert gated_refinement(_start(), tmp_path / "p.png", INTRINSICS, Model(), "points") is applied
