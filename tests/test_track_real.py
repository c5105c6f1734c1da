"""``mrcheck track`` on real videos (issue 40): the hand-held biscuit box (455 frames) and ViSP's
tea box (39 frames) of ``../shared/data/real/``, each from a pose solved from corners clicked on
its first frame (``tests/data/track/``), written with 6 decimals as a pose from clicks or
``solvePnP`` would be. Skipped where the shared data is absent (the videos are not in the
repository). The outline test: the convex hull of the projected cuboid, sampled every 2 px, lies
within a median 3 px of a Canny edge of the frame."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from mrcheck.apps.track import track_command
from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.eval.realdata import cuboid_corners, real_root
from mrcheck.eval.realvideo import BOX_K, track_one

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
REAL = real_root()  # $MRCHECK_REAL_DATA or shared/data/real beside the repository
DATA = ROOT / "tests" / "data" / "track"


def _needs(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"{path} absent: the shared real data (../shared/data/real or $MRCHECK_REAL_DATA) is not here")
    return path


def _frames(video: Path):
    import av

    with av.open(str(video)) as source:
        for frame in source.decode(video=0):
            yield frame.to_ndarray(format="rgb24")


def _start(tmp_path, video, scene, camera, corners, *extra) -> Path:
    """frame 0 as a PNG, registered from the clicks, R and t rounded to 6 decimals."""
    cv2.imwrite(str(tmp_path / "frame0.png"), cv2.cvtColor(next(_frames(video)), cv2.COLOR_RGB2BGR))
    shot = tmp_path / "SHOT.json"
    args = ["register", str(scene), "--photo", str(tmp_path / "frame0.png"), "--intrinsics", str(camera)]
    assert main([*args, "--points", str(corners), *extra, "-o", str(shot)]) == 0
    pose = json.loads(shot.read_text())
    pose["R"], pose["t"] = np.round(pose["R"], 6).tolist(), np.round(pose["t"], 6).tolist()
    shot.write_text(json.dumps(pose))
    return shot


def _outline_px(video: Path, result, K, low, size) -> np.ndarray:
    """Per frame, the median distance (px) from the cuboid's projected outline to the frame's edges."""
    corners = np.array(
        [
            [low[0] + i * size[0], low[1] + j * size[1], low[2] + k * size[2]]
            for i in (0, 1)
            for j in (0, 1)
            for k in (0, 1)
        ]
    )
    out = []
    for rgb, pose in zip(_frames(video), result.frames):
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        edges = cv2.Canny(cv2.GaussianBlur(grey, (5, 5), 1.0), 30, 90)
        distance = cv2.distanceTransform((edges == 0).astype(np.uint8), cv2.DIST_L2, 3)
        X = corners @ pose.camera.R.T + pose.camera.t
        uv = (X @ K.T)[:, :2] / X[:, 2:]
        hull = cv2.convexHull(uv.astype(np.float32)).reshape(-1, 2)
        points = np.concatenate(
            [
                a + np.outer(np.arange(0, 1, 2 / max(np.linalg.norm(b - a), 2)), b - a)
                for a, b in zip(hull, np.roll(hull, -1, 0))
            ]
        )
        inside = np.all((points >= 0) & (points < [grey.shape[1] - 1, grey.shape[0] - 1]), axis=1)
        q = np.round(points[inside]).astype(int)
        out.append(float(np.median(distance[q[:, 1], q[:, 0]])) if len(q) >= 10 else np.inf)
    return np.array(out)


def test_the_hand_held_box_video_is_tracked_from_five_clicks_with_outlines(tmp_path):
    """``track --outline``. Measured (2026-12-07, AMD EPYC): 454 of 455 frames held (not lost,
    outline within 3 px), 1 lost. Without ``--outline`` the same start measured 455 of 455 on the
    machine this test was first written on, but 203 held and 147 lost on the AMD EPYC (the same
    lock file: the fit is deterministic on one machine only; 432 held since the relocalisation
    starts from the best supported recent frame too, next test): the pose slides off the lifted
    box from frame 103 on (outline 4-22 px). The edges alone leave this video on the edge of
    the track's reach (the printed borders run a few px inside the box's edges); the outline,
    the box's colour against the table and the wall, holds it in every frame. The floors
    below leave a margin for other machines. Frame 0's pose held for every frame meets the
    outline test in 215 frames only (47 %). The start is solved with a 3 px inlier threshold,
    which leaves out the first click (4.5 px off; RMS 0.17 px on the other four); with the
    default threshold (3.72 x --click-sigma 1.5 = 5.6 px) all five are kept (RMS 1.36 px), see
    docs/edge-registration.md for that start's figures."""
    video = _needs(REAL / "box_video" / "box.mp4")
    scene, camera = ROOT / "examples" / "box" / "scene.toml", DATA / "box_video" / "camera.json"
    shot = _start(tmp_path, video, scene, camera, DATA / "box_video" / "corners.json", "--max-error", "3")
    result = track_command(video, scene, camera, shot, tmp_path / "overlay.mp4", outline=True)
    assert len(result.frames) == 455
    K = np.array(json.loads(camera.read_text())["K"])
    outline = _outline_px(video, result, K, (0, 0, 0), (0.189, 0.258, 0.075))
    good = [not f.lost and d <= 3.0 for f, d in zip(result.frames, outline)]
    assert len(result.lost) <= 23 and sum(good) >= 410, (result.lost, np.flatnonzero(outline > 3.0))


def test_the_edges_alone_come_back_onto_the_box_from_the_same_start(tmp_path):
    """The same start without ``--outline``. Measured (2026-12-08, AMD EPYC): 17 lost, 432 held;
    before the relocalisation also started from the best supported recent frame
    (``trackmotion.relocalisation_anchors``) 147 lost and 203 held: the pose slid off the lifted
    box at frame 103, the frames kept at 26-30 % support lay 12-38 px off, and every
    relocalisation started from them. The floors leave a margin for other machines (where the
    edges alone held all 455 frames)."""
    video = _needs(REAL / "box_video" / "box.mp4")
    scene, camera = ROOT / "examples" / "box" / "scene.toml", DATA / "box_video" / "camera.json"
    shot = _start(tmp_path, video, scene, camera, DATA / "box_video" / "corners.json", "--max-error", "3")
    result = track_command(video, scene, camera, shot, tmp_path / "overlay.mp4")
    K = np.array(json.loads(camera.read_text())["K"])
    outline = _outline_px(video, result, K, (0, 0, 0), (0.189, 0.258, 0.075))
    good = [not f.lost and d <= 3.0 for f, d in zip(result.frames, outline)]
    assert len(result.lost) <= 60 and sum(good) >= 380, (result.lost, np.flatnonzero(outline > 3.0))


def test_outlines_with_a_camera_that_does_not_fit_are_found_again(tmp_path):
    """``--outline`` with the tutorial's nominal intrinsics (fx 1578.5, fy 1771.8: not this
    video's camera) from ``bench --real``'s start. Measured (2026-12-08, AMD EPYC): 7 lost, 427
    held (the bench's oriented outline distance); before the best supported recent frame was a
    relocalisation start, 256 lost and 192 held: frame 215 was kept at 31 % support with the
    pose mostly out of view, and every relocalisation from it found too few edges in view for
    the remaining 240 frames."""
    video = _needs(REAL / "box_video" / "box.mp4")
    corners = cuboid_corners(np.array([[0, 0, 0], [0.189, 0.258, 0.075]]))
    camera = Camera(640, 480, np.array(BOX_K))
    run = track_one("box", video, ROOT / "examples" / "box" / "scene.toml", camera,
                    ROOT / "tests" / "data" / "box_video_clicks.json", corners, None, tmp_path, outline=True)  # fmt: skip
    assert run.frames == 455 and run.lost <= 60 and run.held >= 360, (run.lost, run.held, run.error)


def test_the_tea_box_video_is_tracked_in_every_frame(tmp_path):
    """Measured: 39 of 39 frames, none lost, every outline within 3 px (median 0.95 px); the
    clicks agree within 2.6 px RMS (the box's cardboard is not a perfect cuboid), hence
    --max-error 6."""
    folder = _needs(REAL / "teabox")
    video = folder / "teabox.mp4"
    (tmp_path / "teabox.ply").write_text(_cuboid_ply(folder / "teabox.cao"))
    scene = tmp_path / "scene.toml"
    scene.write_text('format = 1\nname = "teabox"\n\n[[parts]]\nname = "teabox"\nmesh = "teabox.ply"\nunits = "m"\n')
    K = [[839.21470, 0, 325.66776], [0, 839.44555, 243.69727], [0, 0, 1]]  # teabox.xml
    camera = tmp_path / "camera.json"
    camera.write_text(json.dumps({"width": 640, "height": 480, "K": K}))
    shot = _start(tmp_path, video, scene, camera, DATA / "teabox" / "corners.json", "--max-error", "6")
    result = track_command(video, scene, camera, shot, tmp_path / "overlay.mp4")
    outline = _outline_px(video, result, np.array(K), (0, 0, -0.08), (0.165, 0.068, 0.08))
    assert len(result.frames) == 39 and result.lost == [] and np.all(outline <= 3.0), outline


def _cuboid_ply(cao: Path) -> str:
    """The 8 points and 6 quads of ViSP's ``teabox.cao`` as an ASCII PLY (12 triangles)."""
    rows = [line.split("#")[0].split() for line in cao.read_text().splitlines()]
    rows = [r for r in rows if r][1:]  # "V1" first
    points = rows[1 : 1 + int(rows[0][0])]
    at = 1 + len(points) + 2  # the line and face-from-lines counts, both 0
    faces = [list(map(int, r[1:])) for r in rows[at + 1 : at + 1 + int(rows[at][0])]]
    triangles = [(f[0], f[k], f[k + 1]) for f in faces for k in (1, 2)]
    head = ["ply", "format ascii 1.0", f"element vertex {len(points)}", "property float x", "property float y"]
    head += ["property float z", f"element face {len(triangles)}", "property list uchar int vertex_index", "end_header"]
    return "\n".join(head + [" ".join(p) for p in points] + [f"3 {a} {b} {c}" for a, b, c in triangles]) + "\n"
