"""``mrcheck bench --track`` (issue 20's speed figure): walk videos made by Open3D, tracked by the
app's own code, the frames/s and errors measured (a small walk here; the bench's own are 24
frames at 640x480)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import mrcheck.eval.walks as walks
from mrcheck.cli import main
from mrcheck.eval.edgescenes import crate_camera, crate_scene, write_crate_scene
from mrcheck.eval.trackbench import TrackRun, run_walk, summary_lines
from mrcheck.eval.walks import make_walk, walk_camera


@pytest.fixture(scope="module")
def small_walk(tmp_path_factory):
    folder = tmp_path_factory.mktemp("walks")
    scene = crate_scene()
    return make_walk(scene, crate_camera(320, 240), "side", 4, folder), scene, folder


@pytest.mark.slow
def test_a_walk_is_tracked_in_a_process_of_its_own_and_measured_against_its_true_path(
    small_walk, tmp_path, monkeypatch
):
    import mrcheck.eval.trackbench as bench

    # a fresh process imports the module anew: this replacement is not what it runs
    monkeypatch.setattr(bench, "track_command", lambda *args: pytest.fail("tracked in the bench's own process"))
    walk, _, _ = small_walk
    out = tmp_path / "out"
    out.mkdir()
    run = run_walk(walk, write_crate_scene(tmp_path / "scene"), out)
    assert run.frames == 4 and run.lost == 0
    assert run.fps == pytest.approx(run.frames / run.seconds)
    assert run.first_s < run.seconds
    # the crates from 0.4 degrees off, then frame to frame: well within a pixel
    assert run.error_max_px < 1.0 and run.error_median_px <= run.error_max_px
    assert "overlay render" in run.times_s
    assert not list(out.iterdir())  # the overlay video, poses and cameras are not left behind


@pytest.mark.slow
def test_a_walk_is_made_once_and_again_when_what_it_depends_on_changes(tmp_path, monkeypatch):
    scene, camera = crate_scene(), crate_camera(160, 120)
    walk = make_walk(scene, camera, "side", 2, tmp_path)
    assert [c.center.round(6).tolist() for c in walk.truths] == [
        walk_camera(camera, "side", k).center.round(6).tolist() for k in range(2)
    ]

    def no_photos(*args, **kwargs):
        raise AssertionError("the walk was made again")

    monkeypatch.setattr(walks, "synthetic_photo", no_photos)
    assert make_walk(scene, camera, "side", 2, tmp_path).video == walk.video
    with pytest.raises(AssertionError, match="made again"):
        make_walk(scene, camera, "side", 2, tmp_path, key=b"another scene file")
    assert [p.name for p in tmp_path.iterdir()] == [walk.video.name]  # no half-written video left
    monkeypatch.undo()
    other = make_walk(scene, camera, "side", 2, tmp_path, key=b"another scene file")
    assert [p.name for p in tmp_path.iterdir()] == [other.video.name] != [walk.video.name]  # the stale one gone


def test_the_summary_counts_the_runs_at_the_target_and_spreads_the_rounds():
    def run(walk, fps, after, first=0.5, err=0.2, worst=0.4):
        return TrackRun(walk, 24, 24 / fps, fps, after, first, err, worst, 0, {"overlay render": 1.2})

    runs = [run("a", 4.9, 5.5), run("b", 5.0, 4.6), run("a", 5.3, 5.9, worst=0.9), run("b", 6.0, 4.8)]
    lines = summary_lines(runs, "test")
    table = {line.split()[0]: line for line in lines[2:4]}
    assert "5.10 (4.90-5.30)" in table["a"] and table["a"].split()[-2] == "0.90"
    assert "5.50 (5.00-6.00)    4.70 (4.60-4.80)" in table["b"]
    assert "3 of 4 (whole run), 2 of 4 (after the first frame); frames/s 4.90-6.00" in lines[4]
    assert lines[5] == "ms per frame: overlay render 50"  # 4 x 1.2 s over 96 frames


def test_the_track_bench_refuses_a_second_bench_and_a_bad_json_path_before_any_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(walks, "synthetic_photo", lambda *a, **k: pytest.fail("work was started"))
    assert main(["bench", "--track", "--edges"]) == 2
    assert "give one of them" in capsys.readouterr().err
    assert main(["bench", "--outline"]) == 2
    assert "--outline goes with --track" in capsys.readouterr().err
    assert main(["bench", "--track", "--quick", "--json", str(tmp_path / "out.txt")]) == 1
    err = capsys.readouterr().err
    assert "JSON output must end in .json" in err and "Traceback" not in err


@pytest.mark.slow
def test_the_track_bench_makes_its_walks_once_and_writes_its_runs_as_json(tmp_path, monkeypatch):
    import mrcheck.eval.trackbench as bench

    plan = [
        bench.WalkPlan(
            "crates-side", crate_scene(), write_crate_scene(tmp_path / "scene"), crate_camera(320, 240), "side", 3
        )
    ]
    monkeypatch.setattr(bench, "bench_plan", lambda quick, folder: plan)
    seen = []
    runs, lines = bench.track_bench(
        quick=True,
        rounds=2,
        json_path=tmp_path / "track.json",
        folder=tmp_path / "walks",
        progress=lambda done, total, label: seen.append((done, total, label)),
    )
    record = json.loads((tmp_path / "track.json").read_text())
    assert record["rounds"] == 2 and len(record["runs"]) == 2 == len(runs)
    assert [r["fps"] for r in record["runs"]] == [r.fps for r in runs]
    assert lines[0] == "== mrcheck track: 1 walks of 3 frames at 320x240, 2 rounds =="
    assert np.isfinite(record["runs"][0]["error_median_px"])
    # progress in frames: 3 photos, then 3 frames tracked per round
    assert [done for done, _, _ in seen] == [1, 2, 3, 3, 6, 9] and {total for _, total, _ in seen} == {9}
    seen.clear()
    runs, lines = bench.track_bench(
        quick=True,
        rounds=1,
        json_path=tmp_path / "outline.json",
        folder=tmp_path / "walks",
        progress=lambda *a: seen.append(a),
        outline=True,
    )
    assert seen[0] == (3, 6, "crates-side ready")  # found made: no photos
    assert lines[0] == "== mrcheck track: 1 walks of 3 frames at 320x240, 1 round, --outline =="
    assert json.loads((tmp_path / "outline.json").read_text())["outline"] is True
    assert runs[0].frames == 3 and np.isfinite(runs[0].error_median_px)
