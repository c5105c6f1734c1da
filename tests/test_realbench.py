"""``mrcheck bench --real``: the harness (counts, same starts for both methods, the truth start,
the held-out photo apart), not a target figure; and its small parts on made-up inputs."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from mrcheck.core.camera import Camera
from mrcheck.eval.realbench import LMO_HELD_OUT, METHODS, pose_errors, real_bench, summary_lines
from mrcheck.eval.realdata import cuboid_corners, cuboid_faces, nearest_rotation, real_root
from mrcheck.eval.realvideo import outline_distance, start_from_clicks

K = np.array([[800.0, 0, 320], [0, 800.0, 240], [0, 0, 1]])


def _box_camera() -> Camera:
    R = cv2.Rodrigues(np.array([0.4, -0.3, 0.1]))[0]
    return Camera(640, 480, K, R, np.array([-0.05, -0.03, 0.6]))


def test_pose_errors_measure_rotation_and_translation():
    truth = _box_camera()
    turned = truth.with_pose(cv2.Rodrigues(np.array([0.0, np.radians(3.0), 0.0]))[0] @ truth.R, truth.t + [0.04, 0, 0])
    deg, cm = pose_errors(truth, turned)
    assert deg == pytest.approx(3.0, abs=1e-6) and cm == pytest.approx(4.0, abs=1e-9)
    assert pose_errors(truth, truth) == pytest.approx((0.0, 0.0), abs=1e-6)


def test_nearest_rotation_of_a_bop_like_matrix():
    R = cv2.Rodrigues(np.array([0.3, 0.2, -0.1]))[0] * 1.006  # not orthonormal, as LM-O's
    fixed = nearest_rotation(R)
    assert np.allclose(fixed @ fixed.T, np.eye(3), atol=1e-12) and np.linalg.det(fixed) == pytest.approx(1.0)
    assert np.allclose(fixed, R / 1.006, atol=1e-9)


def test_cuboid_faces_point_outwards():
    corners = cuboid_corners(np.array([[0, 0, 0], [1.0, 2.0, 3.0]]))
    centre = corners.mean(axis=0)
    for a, b, c in cuboid_faces():
        normal = np.cross(corners[b] - corners[a], corners[c] - corners[a])
        assert np.dot(normal, corners[a] - centre) > 0


def test_clicks_give_the_pose_back_and_the_outline_distance_sees_a_wrong_pose():
    truth = _box_camera()
    corners = cuboid_corners(np.array([[0, 0, 0], [0.189, 0.258, 0.075]]))
    start, rms = start_from_clicks(Camera(640, 480, K), truth.project(corners[:6]), corners[:6])
    assert rms < 1e-6 and pose_errors(truth, start)[0] < 1e-4
    grey = np.zeros((480, 640), np.uint8)
    hull = cv2.convexHull(truth.project(corners).astype(np.float32)).astype(np.int32)
    cv2.fillPoly(grey, [hull], 200)
    assert outline_distance(truth, corners, grey) <= 1.0
    moved = truth.with_pose(truth.R, truth.t + [0.02, 0, 0])  # about 27 px to the right
    assert outline_distance(moved, corners, grey) > 5.0


def test_one_bench_at_a_time():
    from mrcheck.cli import cli

    result = CliRunner().invoke(cli, ["bench", "--real", "--edges"])
    assert result.exit_code != 0 and "separate benches" in result.output


@pytest.mark.slow
@pytest.mark.skipif(not (real_root() / "lmo").is_dir(), reason="../shared/data/real (LM-O) is absent")
def test_quick_real_bench_harness(tmp_path):
    out = tmp_path / "real.json"
    bench = real_bench(quick=True, json_path=out)
    lmo = [f for f in bench.fits if f.dataset == "lmo"]
    # quick: 2 photos (one tuned, the held-out one) x 2 anchors x (truth + one 20 px start) x 2 methods
    assert len(lmo) == 16 and {f.method for f in lmo} == set(METHODS)
    pairs: dict = {}
    for f in bench.fits:
        pairs.setdefault((f.photo, f.anchor, f.offset_px, f.seed), {})[f.method] = f.start_px
    assert all(set(p) == set(METHODS) and len(set(p.values())) == 1 for p in pairs.values())
    truth = [f for f in bench.fits if f.offset_px == 0]
    assert len(truth) == 10 and all(f.start_px < 1e-6 for f in truth)
    assert all(f.refused == (f.error_px is None) for f in bench.fits)
    assert all(f.note for f in bench.fits if f.refused)
    moved = [f for f in lmo if f.offset_px == 20.0]
    assert all(abs(f.start_px - 20.0) < 0.1 for f in moved)
    # the anchor is one of the objects (500 of its vertices): the farthest is at least about it
    assert all(f.farthest_px >= 0.9 * f.start_px for f in moved)
    held = {f.photo for f in lmo if f.split == "held-out"}
    assert held == {f"lmo-{i:06d}" for i in LMO_HELD_OUT} and {f.photo for f in lmo if f.split == "tuned"} - held
    table = summary_lines(bench)
    assert any(line.startswith("lmo   held-out") for line in table) and any(
        line.startswith("lmo   tuned") for line in table
    )
    data = json.loads(out.read_text())
    assert len(data["fits"]) == len(bench.fits) and data["held_out"]["lmo"] == ["lmo-000819"]
    if (real_root() / "teabox").is_dir():
        (tea,) = bench.videos
        assert tea.frames == 5 and len(tea.outline_px) == 5


def test_both_methods_get_the_same_starts_and_the_truth_first(monkeypatch):
    import mrcheck.eval.realbench as realbench

    seen: dict = {"mrcheck": [], "cv2.rapid": []}

    def ours(scene, camera, grey, initial, edges):
        seen["mrcheck"].append(initial)
        return type("Fit", (), {"camera": initial, "restart": "", "part_above": {}})()

    def rapid(scene, camera, grey, initial, search_px):
        seen["cv2.rapid"].append(initial)
        return initial

    monkeypatch.setattr(realbench, "refine_pose", ours)
    monkeypatch.setattr(realbench, "rapid_refine", rapid)
    monkeypatch.setattr(realbench, "scene_edges", lambda scene: None)
    truth = _box_camera()
    points = cuboid_corners(np.array([[0, 0, 0], [0.189, 0.258, 0.075]]))
    label = {"dataset": "t", "photo": "p", "split": "tuned", "anchor": "a"}
    photo = np.zeros((truth.height, truth.width, 3), np.uint8)  # rapid is given its grey
    # the anchor and a second object beside it: the farthest offset is at least the anchor's
    far = points + np.array([0.5, 0.0, 0.0])
    rows = realbench.fit_starts(label, None, truth, photo, points, (10.0, 40.0), range(2), [points, far])
    assert len(rows) == 2 * (1 + 2 * 2) and len(seen["mrcheck"]) == 5
    assert all(r.farthest_px >= r.start_px - 1e-9 for r in rows) and rows[0].farthest_px == 0.0
    assert all(r.worst_px == pytest.approx(r.farthest_px, abs=1e-9) for r in rows)  # each fit returned its start
    for a, b in zip(seen["mrcheck"], seen["cv2.rapid"]):
        assert np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t)
    assert seen["mrcheck"][0] is truth
    assert all(abs(r.start_px - r.offset_px) < 0.01 for r in rows)
    # each stand-in fit returned its start: only the truth start succeeds, and its error is 0
    assert [r.ok_px for r in rows] == [r.offset_px == 0 for r in rows]
    assert all(r.error_px == pytest.approx(r.start_px, abs=1e-9) for r in rows)


def test_reach_lines_count_starts_beyond_the_search_radius():
    from mrcheck.eval.realbench import RealFit, reach_lines

    def fit(split, farthest, refused):
        return RealFit("lmo", "p", split, "a", "mrcheck", 0, 20.0, 20.0, None if refused else 1.0,
                       None if refused else 0.5, None if refused else 0.5, refused, 1.0, farthest_px=farthest)  # fmt: skip

    fits = [fit("tuned", 30.0, False), fit("tuned", 60.0, True), fit("tuned", 100.0, False), fit("tuned", 20.0, True)]
    (line,) = reach_lines(fits, 48.0)
    assert "tuned: 2 of 4 starts put an object beyond the 48 px" in line
    assert "(refused 1, succeeded 1); the other 2: refused 1, succeeded 1" in line


def test_restart_lines_count_the_fits_made_again_per_set_and_split():
    from mrcheck.eval.realbench import RealFit, restart_lines

    def fit(dataset, split, note, refused=False):
        return RealFit(dataset, "p", split, "a", "mrcheck", 0, 20.0, 20.0, 1.0, 0.5, 0.5, refused, 1.0, note=note)

    kept = "prism fitted far worse than the other parts (...): 8 restarts along the weakest directions, kept a restart"
    first = kept.replace("kept a restart", "kept the first fit")
    fits = [fit("m3t", "tuned", kept), fit("m3t", "tuned", first), fit("m3t", "tuned", ""),
            fit("m3t", "tuned", "too little support", refused=True), fit("lmo", "held-out", "")]  # fmt: skip
    assert restart_lines(fits) == [
        "  mrcheck, lmo held-out: 0 of 1 fits restarted (a part lagging), 0 kept a restart",
        "  mrcheck, m3t tuned: 2 of 3 fits restarted (a part lagging), 1 kept a restart",
    ]


def test_the_box_video_is_tracked_with_the_nominal_and_the_fitted_camera(tmp_path, monkeypatch):
    """Each with and without ``--outline``; the fitted camera is the repository's
    (``tests/data/track/box_video/camera.json``, f = 680 px), the start the same clicks."""
    import mrcheck.eval.realvideo as realvideo

    (tmp_path / "box_video").mkdir()
    (tmp_path / "box_video" / "box.mp4").write_bytes(b"")  # only looked for: track_one is replaced
    calls = []

    def track_one(name, video, scene, camera, clicks, corners, limit, folder, outline=False):
        calls.append((name, float(camera.K[0, 0]), float(camera.K[1, 1]), clicks.name, outline))
        return realvideo.VideoRun(name, 1, 0, 1, 1.0, 0.0)

    monkeypatch.setattr(realvideo, "track_one", track_one)
    runs, skipped = realvideo.video_runs(tmp_path, quick=False)
    assert calls == [
        ("box_video", 1578.48, 1771.81, "box_video_clicks.json", False),
        ("box_video", 1578.48, 1771.81, "box_video_clicks.json", True),
        ("box_video_f680", 680.0, 680.0, "box_video_clicks.json", False),
        ("box_video_f680", 680.0, 680.0, "box_video_clicks.json", True),
    ]
    assert len(runs) == 4 and any("tea box" in reason for reason in skipped)
