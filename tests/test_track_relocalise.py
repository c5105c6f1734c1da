"""``mrcheck track`` after a lost stretch (issue 40): the object comes back where it was last seen,
not where the constant-velocity prediction coasted to, and the track finds it again from the last
good pose; a pose written with a few digits (from clicks or ``solvePnP``) is a rotation again."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from mrcheck.apps import track, trackmotion
from mrcheck.core.camera import Camera, nearest_rotation
from mrcheck.core.camerafiles import load_camera, write_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.eval.edgephotos import reprojection_error, scene_points, synthetic_photo
from mrcheck.eval.edgescenes import crate_camera, crate_scene, write_crate_scene
from mrcheck.eval.walks import walk_camera, write_video

# frames 0-3 walk sideways, 4-6 are blank, 7-9 show the scene from 20 steps the other way (the
# walk went back while nothing was seen): about 18 px from the last good pose, 21 px from where
# the prediction coasted to (a frame's search reaches 8 px, the relocalisation's 48)
WALK = [0, 1, 2, 3, None, None, None, -20, -20, -20]
BACK = 7


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    folder = tmp_path_factory.mktemp("relocalise")
    manifest = write_crate_scene(folder / "scene")
    scene, camera = crate_scene(), crate_camera(480, 360)
    truths = [walk_camera(camera, "side", 0 if k is None else k) for k in WALK]
    seen = {
        k: synthetic_photo(scene, walk_camera(camera, "side", k), 0, clutter=0, leave_out=False)[0]
        for k in set(WALK) - {None}
    }
    write_video(folder / "walk.mp4", (np.full_like(seen[0], 128) if k is None else seen[k] for k in WALK))
    write_camera(folder / "cam.json", camera, pose=False)
    # the first frame's pose as a solvePnP result printed with 5 decimals: R is a rotation to 1e-5
    start = truths[0].with_pose(cv2.Rodrigues(np.array([0.004, -0.006, 0.002]))[0] @ truths[0].R, truths[0].t)
    rounded = {"width": 480, "height": 360, "K": camera.K.tolist(), "R": np.round(start.R, 5).tolist()}
    rounded["t"] = np.round(start.t, 5).tolist()
    (folder / "rough.json").write_text(json.dumps(rounded))
    return folder, manifest, truths, scene_points(scene, camera)


def _run(video, tmp_path):
    folder, manifest, truths, points = video
    result = track.track_command(
        folder / "walk.mp4", manifest, folder / "cam.json", folder / "rough.json", tmp_path / "overlay.mp4"
    )
    errors = [float(np.median(reprojection_error(t, f.camera, points))) for t, f in zip(truths, result.frames)]
    return result, errors


@pytest.mark.slow
def test_the_track_is_found_again_from_the_last_good_pose_after_a_lost_stretch(video, tmp_path):
    result, errors = _run(video, tmp_path)
    assert result.lost == [4, 5, 6], [f.reason for f in result.frames]
    assert all(errors[k] < 1.0 for k in range(len(WALK)) if WALK[k] is not None), (
        errors,
        [f.reason for f in result.frames],
    )


@pytest.mark.slow
def test_without_relocalisation_the_coasting_prediction_does_not_find_it(video, tmp_path, monkeypatch):
    """The check above fails without the relocalisation: from the coasted prediction the frames
    after the blank stretch are lost or snapped far from the truth."""
    monkeypatch.setattr(trackmotion, "RELOCALISE_AFTER", 10**9)
    result, errors = _run(video, tmp_path)
    assert all(result.frames[k].lost or errors[k] > 5.0 for k in range(BACK, len(WALK))), (errors, result.lost)


def test_relocalisation_comes_after_three_lost_frames_then_every_fifth():
    def frames(lost_run):
        return [_Frame(0, False)] + [_Frame(k + 1, True) for k in range(lost_run)]

    due = [run for run in range(16) if trackmotion.relocalise_now(frames(run))]
    assert due == [3, 8, 13]
    stretch = frames(4)
    anchors = trackmotion.relocalisation_anchors(stretch, None)
    assert len(anchors) == 1 and anchors[0][1] is stretch[0].camera  # the last good pose
    none_good = trackmotion.relocalisation_anchors(stretch[1:], stretch[0].camera)
    assert len(none_good) == 1 and none_good[0][1] is stretch[0].camera  # none good: the start


def test_the_relocalisation_starts_also_from_the_best_supported_recent_frame():
    """A weakly supported last good frame may hold the wrong place: the best supported of the last
    RECENT_GOOD good frames is the second start (lost frames and older ones do not count)."""
    cams = [Camera(640, 480, np.diag([500.0, 500.0, 1.0]), t=np.array([0.01 * k, 0.0, 0.0])) for k in range(80)]
    frames = [_Frame(k, False, cams[k], support=0.5) for k in range(80)]
    frames[5].support = 0.99  # beyond the recent window of 60 good frames
    frames[40].support, frames[41].support = 0.9, 0.9  # equals: the latest is taken
    frames[50].support, frames[50].lost = 0.95, True  # lost: not a start
    frames[79].support = 0.3
    anchors = trackmotion.relocalisation_anchors(frames, None)
    assert len(anchors) == 2 and anchors[0][1] is cams[79] and anchors[1][1] is cams[41]
    assert anchors[0][0] == "the last good pose" and "frame 41" in anchors[1][0], anchors
    frames[79].support = 0.95  # the last good pose is the best supported: one start
    again = trackmotion.relocalisation_anchors(frames, None)
    assert len(again) == 1 and again[0][1] is cams[79]
    lost = [_Frame(k, True, cams[k]) for k in range(3)]
    again = trackmotion.relocalisation_anchors(lost, cams[7])
    assert len(again) == 1 and again[0] == ("the start", cams[7])


def test_a_frame_found_again_predicts_with_the_mean_motion_since_the_last_good_one():
    camera = crate_camera(480, 360)
    walk = [walk_camera(camera, "side", k) for k in range(8)]
    seen = [_Frame(0, False, walk[0]), _Frame(1, False, walk[1]), _Frame(2, True, walk[0]), _Frame(3, False, walk[3])]
    guess = trackmotion.predicted(seen)  # frames 1 -> 3: one walk step per frame
    assert np.abs(guess.R - walk[4].R).max() < 1e-9 and np.abs(guess.center - walk[4].center).max() < 1e-9


class _Frame:
    def __init__(self, frame, lost, camera=None, support=0.5):
        self.frame, self.lost, self.support = frame, lost, support
        self.camera = camera if camera is not None else Camera(640, 480, np.diag([500.0, 500.0, 1.0]))


def test_a_rotation_written_with_a_few_digits_is_made_a_rotation_again(tmp_path):
    R = cv2.Rodrigues(np.array([0.3, -1.1, 0.4]))[0]
    for digits in (4, 5, 6):
        rounded = np.round(R, digits)
        assert np.abs(rounded @ rounded.T - np.eye(3)).max() > 1e-9  # not one as written
        path = tmp_path / f"shot{digits}.json"
        path.write_text(
            json.dumps(
                {
                    "width": 640,
                    "height": 480,
                    "K": np.diag([500.0, 500.0, 1.0]).tolist(),
                    "R": rounded.tolist(),
                    "t": [0.0, 0.0, 1.0],
                }
            )
        )
        loaded = load_camera(path).R
        assert np.abs(loaded @ loaded.T - np.eye(3)).max() < 1e-12 and abs(np.linalg.det(loaded) - 1) < 1e-12
        assert np.abs(loaded - R).max() < 10.0**-digits


def test_a_rotation_to_rounding_passes_through_unchanged():
    R = cv2.Rodrigues(np.array([0.3, -1.1, 0.4]))[0]
    assert np.array_equal(Camera(640, 480, np.diag([500.0, 500.0, 1.0]), R).R, R)


@pytest.mark.parametrize(
    "matrix",
    [
        np.array([[1.0, 0.01, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),  # a shear
        np.diag([1.0, 1.0, 1.01]),  # a scale
        np.diag([1.0, 1.0, -1.0]),  # a mirror
    ],
)
def test_a_matrix_that_is_no_rotation_is_still_refused(matrix):
    with pytest.raises(MrcheckError, match="camera R is not a rotation matrix"):
        nearest_rotation(matrix)
    with pytest.raises(MrcheckError, match="camera R is not a rotation matrix"):
        Camera(640, 480, np.diag([500.0, 500.0, 1.0]), matrix)


def test_coasting_through_a_long_lost_stretch_keeps_a_rotation():
    """A pose orthonormal to 1e-5 (as solvePnP's, printed), then 400 frames of constant-velocity
    prediction: every prediction is a rotation. Kept as read, R's error compounded through the
    products (R' = R_1 R_0^T R_1) and the sixth prediction was refused: "camera R is not a
    rotation matrix", as on the box video with its nominal camera after a lost stretch."""
    K = np.diag([500.0, 500.0, 1.0])
    turn = cv2.Rodrigues(np.array([0.002, 0.03, -0.001]))[0]
    R0 = cv2.Rodrigues(np.array([0.3, -1.1, 0.4]))[0]
    frames = [_Frame(0, False, Camera(640, 480, K, R0)), _Frame(1, False, Camera(640, 480, K, (1 + 1e-5) * turn @ R0))]
    for k in range(2, 400):
        frames.append(_Frame(k, True, trackmotion.predicted(frames)))
    R = frames[-1].camera.R
    assert np.abs(R @ R.T - np.eye(3)).max() < 2e-9
    assert np.abs(R - np.linalg.matrix_power(turn, 399) @ R0).max() < 1e-3  # still the walk's turn
