"""The review's "Calibrate this camera" and Live's own intrinsics (issue 42,
mrcheck.apps.review.calibrator, mrcheck.apps.review.livecamera): video frames of a chessboard
seen by a known camera (tests/chessboard_photos.py) sent to ``/api/calibrate/frame``, the views
kept, the camera solved, saved beside the database and made Live's."""

from __future__ import annotations

import base64
import json

import cv2
import numpy as np
import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.calibrator import MAX_VIEWS, Calibrator  # noqa: E402
from mrcheck.apps.review.livecamera import calibrated_path, read_intrinsics  # noqa: E402
from mrcheck.apps.review.livesession import LiveStart, LiveTracker  # noqa: E402
from mrcheck.apps.review.server import start  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.camerafiles import read_camera, write_camera  # noqa: E402
from mrcheck.core.errors import MrcheckError  # noqa: E402

from .chessboard_photos import BOARD, TRUE, board_poses, chessboard_photo, jpeg  # noqa: E402
from .test_review import box_review  # noqa: E402

OCTETS = {"Content-Type": "application/octet-stream"}


@pytest.fixture(scope="module")
def frames():
    """JPEG frames of the board at 12 varied poses (each pose twice: other noise)."""
    poses = board_poses(12)
    return [jpeg(chessboard_photo(r, t, seed=k)) for k, (r, t) in enumerate(poses)], [
        jpeg(chessboard_photo(r, t, seed=100 + k)) for k, (r, t) in enumerate(poses)
    ]


def _app(tmp_path, **kwargs):
    return create_app(box_review(tmp_path / "box", (0.0, 0.0, 0.0)), db_path=tmp_path / "r.sqlite",
                      cache_dir=tmp_path / "c", samples=2, **kwargs)  # fmt: skip


def _frame(client, data):
    response = client.post("/api/calibrate/frame", content=data, headers=OCTETS)
    assert response.status_code == 200, response.text
    return response.json()


def test_frames_with_and_without_the_board_and_a_near_duplicate(tmp_path, frames):
    client = TestClient(_app(tmp_path, board=BOARD))
    assert client.get("/api/calibrate").json()["board"] == BOARD  # --board: what the page offers
    assert client.get("/api/live/camera").json() == {"width": None, "height": None, "source": None}
    before = client.post("/api/calibrate/frame", content=frames[0][0], headers=OCTETS)
    assert before.status_code == 422 and "start a calibration" in before.json()["error"]
    assert client.post("/api/calibrate/start", json={"board": BOARD}).json()["views"] == 0
    blank = jpeg(np.full((480, 640, 3), 128, np.uint8))
    assert _frame(client, blank) == {**_frame(client, blank), "found": False, "kept": False, "corners": []}
    first = _frame(client, frames[0][0])
    assert first["found"] and first["kept"] and first["views"] == 1 and len(first["corners"]) == 54
    # the same view again (other noise: a still camera) is not kept
    again = _frame(client, frames[1][0])
    assert again["found"] and not again["kept"] and "like a view kept" in again["reason"] and again["views"] == 1
    assert _frame(client, frames[0][1])["kept"]  # another pose is
    # too few views: a 422 with one line
    refused = client.post("/api/calibrate/solve", json={})
    assert refused.status_code == 422 and "2 views kept, need at least 5" in refused.json()["error"]
    assert "\n" not in refused.json()["error"]
    # a frame of another size than the views kept
    other = _frame(client, jpeg(cv2.resize(chessboard_photo(*board_poses(1)[0]), (320, 240))))
    assert not other["kept"] and "one camera at one size" in other["reason"]
    # a new start resets the views
    assert client.post("/api/calibrate/start", json={"board": BOARD}).json()["views"] == 0


def test_bad_requests_are_refused(tmp_path, frames):
    client = TestClient(_app(tmp_path))
    assert client.get("/api/calibrate").json()["board"] is None  # without --board the page asks
    bad = client.post("/api/calibrate/start", json={"board": "chessboard:2x2:0.02"})
    assert bad.status_code == 422 and "at least 3x3" in bad.json()["error"]
    client.post("/api/calibrate/start", json={"board": BOARD})
    assert client.post("/api/calibrate/frame", content=b"no image", headers=OCTETS).status_code == 422
    # octets only (a page of another site cannot send them without a preflight), JSON only
    plain = client.post("/api/calibrate/frame", content=frames[0][0], headers={"Content-Type": "text/plain"})
    assert plain.status_code == 415
    assert client.post("/api/calibrate/start", content=BOARD, headers={"Content-Type": "text/plain"}).status_code == 415


def test_the_routes_need_the_token_and_this_server(tmp_path, frames):
    app = create_app(box_review(tmp_path / "box", (0.0, 0.0, 0.0)), db_path=tmp_path / "r.sqlite",
                     cache_dir=tmp_path / "c", token="s3cret", host="127.0.0.1", max_body=64 << 10)  # fmt: skip
    client = TestClient(app, base_url="http://127.0.0.1:8765")
    assert client.get("/api/live/camera").status_code == 401
    assert client.post("/api/calibrate/start", json={"board": BOARD}).status_code == 401
    token = {"X-Review-Token": "s3cret"}
    assert client.post("/api/calibrate/start", json={"board": BOARD}, headers=token).status_code == 200
    foreign = {**token, "Host": "attacker.example"}
    assert client.post("/api/calibrate/frame", content=frames[0][0], headers={**OCTETS, **foreign}).status_code == 403
    cross = {**token, **OCTETS, "Sec-Fetch-Site": "cross-site"}
    assert client.post("/api/calibrate/frame", content=frames[0][0], headers=cross).status_code == 403
    big = client.post("/api/calibrate/frame", content=b"x" * (65 << 10), headers={**token, **OCTETS})
    assert big.status_code == 413  # --max-body


def test_solve_saves_the_camera_and_live_uses_it(tmp_path, frames):
    """12 poses (35 degree tilts, 0.35-0.7 m) at 640x480 with 0.1 px corners: within 1.5 px of the
    true fx, fy, cx, cy (15-view subsets of 40 such poses: 0.9 px at most, 0.3 px std)."""
    app = _app(tmp_path)
    client = TestClient(app)
    client.post("/api/calibrate/start", json={"board": BOARD})
    assert all(_frame(client, data)["kept"] for data in frames[0])
    solved = client.post("/api/calibrate/solve", json={})
    assert solved.status_code == 200, solved.text
    got = solved.json()
    for key in ("fx", "fy", "cx", "cy"):
        assert got[key] == pytest.approx(getattr(TRUE, key), abs=1.5), (key, got)
        assert 0 < got["std"][key] < 1.5
    assert got["rms_px"] < 0.3 and got["views"] == 12 and got["warning"] is None
    saved = calibrated_path(tmp_path / "r.sqlite")
    assert got["path"] == str(saved) and read_camera(saved).fx == pytest.approx(got["fx"], abs=1e-3)
    assert json.loads(saved.read_text())["board"] == BOARD and "R" not in json.loads(saved.read_text())
    assert client.get("/api/live/camera").json() == {"width": 640, "height": 480, "source": "calibrated"}
    # Live tracks with it, from the shot's pose
    review = app.state.review
    shot = review.source.shots["a"]
    camera = LiveTracker(review.source, LiveStart("a"), live_camera=review.live_camera).camera
    assert (camera.width, camera.height) == (640, 480) and camera.fx == pytest.approx(got["fx"], abs=1e-3)
    assert np.allclose(camera.R, shot.served_camera().R) and np.allclose(camera.t, shot.served_camera().t)
    assert LiveTracker(review.source, LiveStart("a")).camera.width == shot.served_camera().width  # without: the shot's
    # the file persists: a new server loads it
    assert TestClient(_app(tmp_path)).get("/api/live/camera").json()["source"] == "calibrated"


def test_live_intrinsics_from_a_file_win(tmp_path):
    given = Camera(1280, 720, np.array([[900.0, 0, 640], [0, 900, 360], [0, 0, 1]]), dist=[0.1, -0.05, 0, 0, 0])
    write_camera(tmp_path / "tablet.json", given, pose=False)
    saved = calibrated_path(tmp_path / "r.sqlite")
    saved.parent.mkdir()
    write_camera(saved, TRUE, {"rms": 0.1}, pose=False)
    app = _app(tmp_path, live_intrinsics=read_intrinsics(tmp_path / "tablet.json"))
    assert TestClient(app).get("/api/live/camera").json() == {"width": 1280, "height": 720, "source": "file"}
    camera = app.state.review.live_camera.for_shot(app.state.review.source.shots["a"])
    assert camera.fx == 900 and camera.dist[0] == pytest.approx(0.1)
    lines = app.state.review.live_camera.lines()
    assert "tablet.json" in lines[0] and f"wins over the calibrated {saved}" in lines[0]


def test_start_reads_and_checks_the_options(tmp_path):
    source = tmp_path / "box"
    box_review(source, (0.0, 0.0, 0.0))
    args = (source / "box.stl",)
    with pytest.raises(MrcheckError, match="board SPEC"):
        start(*args, shots_dir=source / "shots", port=0, board="chessboard:9x6")
    with pytest.raises(MrcheckError, match="missing.json"):
        start(*args, shots_dir=source / "shots", port=0, live_intrinsics=tmp_path / "missing.json")
    saved = calibrated_path(source / "shots" / "review.sqlite")
    saved.parent.mkdir()
    write_camera(saved, TRUE, pose=False)
    with pytest.raises(MrcheckError):  # the file Calibrate writes cannot be the input too
        start(*args, shots_dir=source / "shots", port=0, live_intrinsics=saved)
    server = start(*args, shots_dir=source / "shots", port=0, board=BOARD)
    try:
        assert any(line.startswith("live: intrinsics calibrated in the page") for line in server.messages())
    finally:
        server.close()
        server.app.state.renders.close()


def test_a_still_camera_cannot_fill_the_set_and_the_set_is_bounded(monkeypatch, frames):
    calibrator = Calibrator()
    calibrator.start(BOARD)
    kept = [calibrator.frame(data)["kept"] for data in [frames[0][0]] * 3 + [frames[1][0]] * 3]
    assert kept == [True, False, False, False, False, False]
    monkeypatch.setattr("mrcheck.apps.review.calibrator.MAX_VIEWS", 2)
    assert calibrator.frame(frames[0][1])["kept"]
    full = calibrator.frame(frames[0][2])
    assert not full["kept"] and "the most" in full["reason"] and MAX_VIEWS == 40


def test_a_frozen_frame_is_saved_with_lives_own_camera(tmp_path):
    """Freeze (routes/view.py) saves the frame at Live's camera's size with its K and the pose tracked."""
    write_camera(tmp_path / "tablet.json", TRUE, pose=False)
    app = _app(tmp_path, live_intrinsics=read_intrinsics(tmp_path / "tablet.json"))
    client = TestClient(app)
    shot = app.state.review.source.shots["a"].served_camera()
    image = base64.b64encode(jpeg(np.full((480, 640, 3), 90, np.uint8))).decode()
    made = client.post(
        "/api/live/freeze", json={"shot": "a", "R": shot.R.tolist(), "t": shot.t.tolist(), "image": image}
    )
    assert made.status_code == 201, made.text
    frozen = made.json()
    assert (frozen["width"], frozen["height"]) == (640, 480) and frozen["camera"]["K"] == TRUE.K.tolist()
    assert np.allclose(frozen["camera"]["R"], shot.R) and np.allclose(frozen["camera"]["t"], shot.t)
