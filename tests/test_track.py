"""``mrcheck track`` (issue 20): a short video made here from a camera path over the crate scene
(Open3D photos, so another renderer than mrcheck's), one frame of it blanked out."""

from __future__ import annotations

import json
import math
import os
import re
import stat

import av
import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.camerafiles import write_camera
from mrcheck.eval.edgephotos import reprojection_error, scene_points, synthetic_photo
from mrcheck.eval.edgescenes import crate_camera, crate_scene, write_crate_scene
from mrcheck.eval.walks import walk_camera, write_video

FRAMES = 6
BLANK = 3


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    folder = tmp_path_factory.mktemp("track")
    manifest = write_crate_scene(folder / "scene")
    scene, camera = crate_scene(), crate_camera(480, 360)
    # the camera walked sideways 4 cm and turned 0.2 degrees per frame
    truths = [walk_camera(camera, "side", k) for k in range(FRAMES)]
    path = folder / "walk.mp4"
    photos = (synthetic_photo(scene, truth, 0, clutter=0, leave_out=False)[0] for truth in truths)
    write_video(path, (np.full_like(grey, 128) if k == BLANK else grey for k, grey in enumerate(photos)))
    write_camera(folder / "cam.json", camera, pose=False)
    # the first frame's rough pose: 6 px off
    rough = truths[0].with_pose(cv2.Rodrigues(np.array([0.004, -0.006, 0.002]))[0] @ truths[0].R, truths[0].t)
    write_camera(folder / "rough.json", rough)
    return folder, manifest, truths, scene_points(scene, camera)


@pytest.mark.slow
def test_track_writes_the_overlay_video_and_the_poses(video, capsys):
    folder, manifest, truths, points = video
    out = folder / "overlay.mp4"
    code = main(
        [
            "track",
            str(folder / "walk.mp4"),
            "--scene",
            str(manifest),
            "--intrinsics",
            str(folder / "cam.json"),
            "--initial",
            str(folder / "rough.json"),
            "-o",
            str(out),
        ]
    )
    assert code == 0
    with av.open(str(out)) as written:
        frames = [f.to_ndarray(format="rgb24") for f in written.decode(video=0)]
    assert len(frames) == FRAMES and frames[0].shape == (360, 480, 3)
    poses = [json.loads(line) for line in (folder / "overlay.poses.jsonl").read_text().splitlines()]
    assert [p["frame"] for p in poses] == list(range(FRAMES))
    assert [p["frame"] for p in poses if p["lost"]] == [BLANK]
    assert "support" in poses[BLANK]["reason"] or "no photo edges" in poses[BLANK]["reason"]
    for p, truth in zip(poses, truths):
        if p["lost"]:
            continue
        estimate = truth.with_pose(np.array(p["R"]), np.array(p["t"]))
        # the frames are MPEG-4 compressed; measured 0.1-0.4 px
        assert np.median(reprojection_error(truth, estimate, points)) < 1.0, p["frame"]
    printed = capsys.readouterr().out
    assert f"tracked {FRAMES} frames" in printed and "frames/s" in printed
    assert f"frame {BLANK} lost" in printed and "not trusted" in printed
    # the whole run's rate and the tracking rate after the first frame, consistent with each other
    rates = r"in ([\d.]+) s \(([\d.]+) frames/s; ([\d.]+) after the first frame, which took ([\d.]+) s\)"
    total, whole, after, first = map(float, re.search(rates, printed).groups())
    assert 0 < first < total and abs(whole - FRAMES / total) < 0.05 * whole + 0.01
    assert abs(after - (FRAMES - 1) / (total - first)) < 0.1 * after and after > whole
    # the usual permissions of a new file (the video is encoded into a mkstemp file, 0600) and no
    # temporary file left beside it
    umask = os.umask(0)
    os.umask(umask)
    for path in (out, folder / "overlay.poses.jsonl"):
        assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask, path
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]


def test_a_single_frame_has_no_rate_after_the_first():
    from types import SimpleNamespace

    from mrcheck.apps.track import TrackResult

    frame = SimpleNamespace(frame=0, lost=False)
    result = TrackResult(frames=[frame], seconds=2.0, first_s=2.0)
    assert math.isnan(result.fps_after_first) and "after the first" not in result.summary_line()
    result = TrackResult(frames=[frame] * 5, seconds=3.0, first_s=1.0)
    assert result.fps_after_first == pytest.approx(2.0)
    assert "2.00 after the first frame, which took 1.00 s" in result.summary_line()


@pytest.mark.slow
def test_a_lost_frame_inside_a_part_is_written_without_overlay(video, tmp_path):
    """A start pose inside a crate (as a lost frame's prediction can coast into a part): every
    frame is lost, the renderer refuses the pose, and the run still writes its video and log
    (it ended with "the camera is inside geometry" before), each frame saying why."""
    folder, manifest, truths, _ = video
    inside = truths[0].with_pose(truths[0].R, -truths[0].R @ np.array([0.0, 0.0, 0.45]))  # crate-a's middle
    write_camera(tmp_path / "inside.json", inside)
    out = tmp_path / "overlay.mp4"
    code = main(
        [
            "track",
            str(folder / "walk.mp4"),
            "--scene",
            str(manifest),
            "--intrinsics",
            str(folder / "cam.json"),
            "--initial",
            str(tmp_path / "inside.json"),
            "-o",
            str(out),
        ]
    )
    assert code == 0 and out.exists()
    poses = [json.loads(line) for line in (tmp_path / "overlay.poses.jsonl").read_text().splitlines()]
    assert len(poses) == FRAMES and all(p["lost"] for p in poses)
    assert all("no overlay drawn" in p["reason"] and "inside geometry" in p["reason"] for p in poses), poses[0]


@pytest.mark.slow
def test_each_frame_finds_its_visible_edges_on_the_last_overlay(video, tmp_path, monkeypatch):
    """From the second frame on, the snap is given the frame before's overlay render (its depth
    and normals at that frame's pose) instead of rendering at its start: one render less per
    frame (measured on eight cell walks: the whole run 3.3-4.2 -> 4.3-5.5 frames/s); it serves the
    whole fit, and only a frame that would be lost renders."""
    import mrcheck.apps.track as track

    folder, manifest, _, _ = video
    seen, retried, real = [], [], track.refine_pose

    def recording(*args, seed=None, options=None, **kwargs):
        (retried if options is track.RETRY_OPTIONS else seen).append(seed)
        return real(*args, seed=seed, options=options, **kwargs)

    monkeypatch.setattr(track, "refine_pose", recording)
    out = tmp_path / "overlay.mp4"
    code = main(
        [
            "track",
            str(folder / "walk.mp4"),
            "--scene",
            str(manifest),
            "--intrinsics",
            str(folder / "cam.json"),
            "--initial",
            str(folder / "rough.json"),
            "-o",
            str(out),
        ]
    )
    assert code == 0
    poses = [json.loads(line) for line in (tmp_path / "overlay.poses.jsonl").read_text().splitlines()]
    assert len(seen) == FRAMES and seen[0] is None
    # the blank frame, lost, was snapped once more with a render of its own (RETRY_OPTIONS)
    assert retried == [None] and [p["frame"] for p in poses if p["lost"]] == [BLANK]
    for seed, before in zip(seen[1:], poses):
        assert seed is not None
        assert np.allclose(seed.camera.R, before["R"]) and np.allclose(seed.camera.t, before["t"])
        assert seed.depth.shape == (seed.camera.height, seed.camera.width)
        assert seed.normals.shape == (*seed.depth.shape, 3) and np.any(seed.depth > 0)


@pytest.mark.slow
def test_a_frame_lost_on_the_last_overlay_is_snapped_again_with_a_render_of_its_own(video, tmp_path, monkeypatch):
    """A later frame whose snap on the frame before's overlay fails is snapped once more from the
    same start with RETRY_OPTIONS and no seed (a render at its start, re-renders after 3 px), and
    kept when that one succeeds. Here frame 2's first snap is made to fail."""
    import mrcheck.apps.track as track
    from mrcheck.mr.edges import EdgeFitError

    folder, manifest, truths, points = video
    calls, real = [], track.refine_pose

    def failing_once(*args, options=None, seed=None, initial=None, **kwargs):
        calls.append((options, seed, initial))
        if len(calls) == 3:
            raise EdgeFitError("made to fail")
        return real(*args, options=options, seed=seed, initial=initial, **kwargs)

    monkeypatch.setattr(track, "refine_pose", failing_once)
    result = track.track_command(
        folder / "walk.mp4", manifest, folder / "cam.json", folder / "rough.json", tmp_path / "overlay.mp4"
    )
    (first, seed, start), (again, no_seed, same_start) = calls[2], calls[3]
    assert first is track.TRACK_OPTIONS and seed is not None
    assert again is track.RETRY_OPTIONS and no_seed is None and same_start is start
    assert again.rerender_px < math.inf and track.TRACK_OPTIONS.rerender_px == math.inf
    assert result.lost == [BLANK]  # frame 2 kept, the blank frame lost
    frame = result.frames[2]
    assert not frame.lost and np.median(reprojection_error(truths[2], frame.camera, points)) < 1.0


@pytest.mark.slow
def test_no_second_snap_right_after_a_lost_frame(video, tmp_path, monkeypatch):
    """Within a lost stretch both snaps would start from the same coasting prediction: the frame
    after the blank (lost) one, made to fail here, is not snapped again and is lost too."""
    import mrcheck.apps.track as track
    from mrcheck.mr.edges import EdgeFitError

    folder, manifest, _, _ = video
    calls, real = [], track.refine_pose

    def failing(*args, options=None, **kwargs):
        calls.append(options)
        if len(calls) == 6:  # frames 0-2 one snap each, the blank frame 3 two, frame 4's first
            raise EdgeFitError("made to fail")
        return real(*args, options=options, **kwargs)

    monkeypatch.setattr(track, "refine_pose", failing)
    result = track.track_command(
        folder / "walk.mp4", manifest, folder / "cam.json", folder / "rough.json", tmp_path / "overlay.mp4"
    )
    assert result.lost == [BLANK, BLANK + 1]
    assert calls.count(track.RETRY_OPTIONS) == 1 and calls[4] is track.RETRY_OPTIONS  # the blank frame's
    assert len(calls) == FRAMES + 1


@pytest.mark.slow
def test_outline_fits_every_frame_after_the_first_in_colour(video, tmp_path, monkeypatch):
    """``track --outline``: the frames after the first (their retries too) are snapped with the
    outlines on and read in colour (the outlines' region criterion compares colours); the first
    frame and the relocalisation as without it. The crate walk is tracked as well as without."""
    import mrcheck.apps.track as track

    folder, manifest, truths, points = video
    calls, real = [], track.refine_pose

    def recording(scene, camera, image, *args, options=None, **kwargs):
        calls.append((options, np.asarray(image).ndim))
        return real(scene, camera, image, *args, options=options, **kwargs)

    monkeypatch.setattr(track, "refine_pose", recording)
    args = ["--intrinsics", str(folder / "cam.json"), "--initial", str(folder / "rough.json")]
    out = tmp_path / "overlay.mp4"
    code = main(["track", str(folder / "walk.mp4"), "--scene", str(manifest), *args, "--outline", "-o", str(out)])
    assert code == 0
    assert calls[0] == (track.FIRST_OPTIONS, 2)
    assert all(o.silhouette is True and ndim == 3 for o, ndim in calls[1:] if o is not track.RELOCALISE_OPTIONS)
    assert calls[1][0] is track.OUTLINE_OPTIONS and (track.retry_options(True), 3) in calls  # the blank frame's retry
    poses = [json.loads(line) for line in out.with_suffix(".poses.jsonl").read_text().splitlines()]
    assert [p["frame"] for p in poses if p["lost"]] == [BLANK]
    for truth, pose in zip(truths, poses):
        if not pose["lost"]:
            found = truth.with_pose(np.array(pose["R"]), np.array(pose["t"]))
            assert np.median(reprojection_error(truth, found, points)) < 1.0


@pytest.mark.slow
def test_numpy_blas_runs_on_one_thread_while_tracking(video, tmp_path, monkeypatch):
    """OpenBLAS's idle threads spin on the core that llvmpipe and the encoder need: the track
    keeps numpy's BLAS on one thread while it runs and gives the threads back after (measured
    over 20 interleaved walk pairs: faster in 17, median +10 %, the poses identical)."""
    from threadpoolctl import threadpool_info

    import mrcheck.apps.track as track

    def blas_threads():
        return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]

    before = blas_threads()
    if not before or max(before) < 2:
        pytest.skip("numpy's BLAS runs on one thread here already")
    folder, manifest, _, _ = video
    during, real = [], track.refine_pose

    def recording(*args, **kwargs):
        during.append(blas_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(track, "refine_pose", recording)
    monkeypatch.setattr(track, "RETRY_OPTIONS", None)  # one snap per frame
    code = main(
        [
            "track",
            str(folder / "walk.mp4"),
            "--scene",
            str(manifest),
            "--intrinsics",
            str(folder / "cam.json"),
            "--initial",
            str(folder / "rough.json"),
            "-o",
            str(tmp_path / "overlay.mp4"),
        ]
    )
    assert code == 0 and len(during) == FRAMES
    assert all(max(threads) == 1 for threads in during), during
    assert blas_threads() == before


@pytest.mark.slow
def test_the_next_frame_is_decoded_and_its_pyramid_made_on_a_thread_beside_the_snap(video, tmp_path, monkeypatch):
    """The reader (:class:`~mrcheck.apps.trackframes.FrameReader`) makes frame k+1's gradient
    pyramid on its thread while frame k is snapped (each snap below waits until that has happened:
    without the thread it never would), and every snap is given its own frame's pyramid, made
    with its own options."""
    import threading

    import mrcheck.apps.track as track
    import mrcheck.apps.trackframes as trackframes
    from mrcheck.mr.edges import photo_pyramid

    folder, manifest, _, _ = video
    made, snaps, real_pyramid, real_refine = [], [], trackframes.photo_pyramid, track.refine_pose
    ahead = [threading.Event() for _ in range(FRAMES + 1)]

    def pyramid(grey, options):
        made.append(threading.current_thread().name)
        ahead[len(made) - 1].set()
        return real_pyramid(grey, options)

    def refine(scene, camera, grey, *, options, pyramid, **kwargs):
        k = len(snaps)
        snaps.append((grey.copy(), options, pyramid))
        if k + 1 < FRAMES:
            assert ahead[k + 1].wait(timeout=30), f"frame {k + 1} was not read beside the snap of frame {k}"
        return real_refine(scene, camera, grey, options=options, pyramid=pyramid, **kwargs)

    monkeypatch.setattr(trackframes, "photo_pyramid", pyramid)
    monkeypatch.setattr(track, "refine_pose", refine)
    monkeypatch.setattr(track, "RETRY_OPTIONS", None)  # one snap per frame
    code = main(
        [
            "track",
            str(folder / "walk.mp4"),
            "--scene",
            str(manifest),
            "--intrinsics",
            str(folder / "cam.json"),
            "--initial",
            str(folder / "rough.json"),
            "-o",
            str(tmp_path / "overlay.mp4"),
        ]
    )
    assert code == 0 and len(snaps) == FRAMES == len(made)
    assert all(name.startswith("mrcheck-video-reader") for name in made), made
    for k, (grey, options, given) in enumerate(snaps):
        assert options is (track.FIRST_OPTIONS if k == 0 else track.TRACK_OPTIONS)
        expected = photo_pyramid(grey, options)
        assert len(given) == len(expected)
        assert all(np.array_equal(a.gx, b.gx) and np.array_equal(a.gy, b.gy) for a, b in zip(given, expected))


def test_a_frame_that_cannot_be_decoded_is_raised_by_the_reader():
    """An error on the reader's thread (FFmpeg failing on a frame) reaches the loop at that frame."""
    from mrcheck.apps.track import frame_options
    from mrcheck.apps.trackframes import FrameReader

    class Frame:
        time = 0.5

        def to_ndarray(self, format):
            return np.zeros((24, 32, 3), np.uint8)

    def frames():
        yield Frame()
        raise av.error.InvalidDataError(1094995529, "corrupt frame")

    reader = FrameReader(frames(), frame_options)
    try:
        first = reader.next()
        assert first.time_s == 0.5 and first.grey.shape == (24, 32)
        with pytest.raises(av.error.FFmpegError):
            reader.next()
    finally:
        reader.close()
