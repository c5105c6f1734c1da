"""The review's live session (issue 42, mrcheck.apps.review.livesession): video frames sent over
``/api/live`` are tracked from a shot's pose, frame by frame, newest first; a walk of Open3D
photos with known cameras measures the poses it returns."""

from __future__ import annotations

import base64
import json
import struct

import cv2
import numpy as np
import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.eval.edgephotos import reprojection_error, scene_points, synthetic_photo  # noqa: E402
from mrcheck.eval.walks import walk_camera  # noqa: E402
from mrcheck.mr.markers import parse_marker_map  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .mr_helpers import paste_marker, standing_marker  # noqa: E402

FRAMES = 9


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """A 320x240 walk sideways over the sample cell (4 cm and 0.2 degrees per frame), Open3D
    photos in colour, as JPEG frames; the shot is frame 0 (its true pose and photo)."""
    root = tmp_path_factory.mktemp("live")
    scene = load_scene(sample_scene_path())
    camera = scene.camera("conveyor", 320, 240)
    truths = [walk_camera(camera, "side", k) for k in range(FRAMES)]
    photos = [synthetic_photo(scene, c, k, clutter=0, leave_out=False, colour=True)[0] for k, c in enumerate(truths)]
    write_image(root / "p1.png", photos[0])
    (root / "p1.json").write_text(json.dumps({**camera.to_dict(), "photo": "p1.png"}))
    frames = [cv2.imencode(".jpg", cv2.cvtColor(p, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
              for p in photos]  # fmt: skip
    return root, scene, truths, frames


def _client(walk, tmp_path):
    app = create_app(open_source(sample_scene_path(), walk[0]), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")
    return TestClient(app)


def _pose(ws) -> dict:
    header = ws.receive_json()
    assert header["type"] == "pose", header
    layer = cv2.imdecode(np.frombuffer(ws.receive_bytes(), np.uint8), cv2.IMREAD_COLOR)
    assert layer.shape == (header["height"], header["width"], 3)
    return header


@pytest.mark.slow
def test_a_walk_is_tracked_frame_by_frame(walk, tmp_path):
    """Measured: 0.10-0.21 px median from the truth per frame (scene points seen from frame 0),
    none lost. The limit, 1.5 px, leaves room for another machine's rasteriser and JPEG coder."""
    root, scene, truths, frames = walk
    points = scene_points(scene, truths[0])
    with _client(walk, tmp_path) as client, client.websocket_connect("/api/live") as ws:
        ws.send_text(json.dumps({"type": "start", "shot": "p1"}))
        errors = []
        for k, frame in enumerate(frames):
            ws.send_bytes(struct.pack("<d", 0.1 * k) + frame)  # one at a time: every frame is tracked
            header = _pose(ws)
            assert header["frame"] == k and not header["lost"], header
            found = Camera(320, 240, truths[k].K, np.array(header["R"]), np.array(header["t"]))
            errors.append(float(np.median(reprojection_error(truths[k], found, points))))
    print("live track, median px per frame:", np.round(errors, 2))
    assert max(errors) < 1.5, errors


@pytest.mark.slow
def test_frames_sent_at_once_are_tracked_newest_first_and_bad_ones_answered(walk, tmp_path):
    """Four frames sent at once: frame 0 is tracked while 1, 2 and 3 arrive and replace each
    other, so the second answer is frame 3's (its own time, 0.3 s, in the header). Its pose is
    tracked from frame 0's, three steps of the walk away with no motion known yet: measured on
    an AMD EPYC 1.84 px from frame 3's truth and 1.77 px from frame 1's (the test once asserted
    it nearer frame 3's, true on the machine before, and failed there), frame 0's answer 3.71 px
    from frame 3's truth. The limit 2.5 px says the answer moved to frame 3."""
    _, scene, truths, frames = walk
    points = scene_points(scene, truths[0])
    with _client(walk, tmp_path) as client, client.websocket_connect("/api/live") as ws:
        ws.send_bytes(struct.pack("<d", 0.0) + frames[0])
        assert "before the frames" in ws.receive_json()["error"]
        ws.send_text(json.dumps({"type": "start", "shot": "nope"}))
        assert "a shot of this review" in ws.receive_json()["error"]
        ws.send_text(json.dumps({"type": "start", "shot": "p1"}))
        ws.send_bytes(struct.pack("<d", 0.0) + b"no image")
        assert "JPEG or PNG" in ws.receive_json()["error"]
        for k, frame in enumerate(frames[:4]):
            ws.send_bytes(struct.pack("<d", 0.1 * k) + frame)
        first, second = _pose(ws), _pose(ws)
    assert first["time"] == 0.0 and second["time"] == pytest.approx(0.3), (first["time"], second["time"])
    assert (first["frame"], second["frame"]) == (0, 1)  # the answers count the frames tracked
    found = Camera(320, 240, truths[0].K, np.array(second["R"]), np.array(second["t"]))
    to = [float(np.median(reprojection_error(truths[k], found, points))) for k in (1, 3)]
    assert not second["lost"] and to[1] < 2.5, (second, to)


@pytest.mark.slow
def test_a_frozen_frame_becomes_a_shot_to_mark(walk, tmp_path):
    """Freeze and mark: a frame with its tracked pose is saved as a new shot (photo and
    SHOT.json beside the review's other added shots); a marker on it is in the CSV export; a
    frame that is no image is a 422."""
    root, _, truths, frames = walk
    image = base64.b64encode(frames[3]).decode()
    pose = {"R": truths[3].R.tolist(), "t": truths[3].t.tolist()}
    with _client(walk, tmp_path) as client:
        bad = client.post("/api/live/freeze", json={"shot": "p1", **pose, "image": "bm90IGFuIGltYWdl"})
        assert bad.status_code == 422 and "JPEG or PNG" in bad.json()["error"]
        made = client.post("/api/live/freeze", json={"shot": "p1", **pose, "image": image})
        assert made.status_code == 201, made.json()
        shot = made.json()
        assert shot["name"].startswith("live-p1") and shot["camera"]["t"] == pytest.approx(pose["t"])
        assert shot["name"] in [s["name"] for s in client.get("/api/shots").json()]
        marker = client.post(
            "/api/markers", json={"shot": shot["name"], "x": 160, "y": 120, "category": "moved", "severity": 2}
        )
        assert marker.status_code in (200, 201), marker.json()
        assert shot["name"] in client.get("/api/export/markers.csv").text
    saved = list(root.rglob(f"{shot['name']}.json"))
    assert len(saved) == 1 and (saved[0].parent / f"{shot['name']}.png").is_file()


def _shot_folder(tmp_path, walk, camera) -> object:
    """A shots folder whose p1 is frame 0's photo at ``camera``'s pose (a wrong one, to start from
    elsewhere)."""
    root = tmp_path / "shots"
    root.mkdir()
    write_image(root / "p1.png", cv2.imread(str(walk[0] / "p1.png"))[..., ::-1])
    (root / "p1.json").write_text(json.dumps({**camera.to_dict(), "photo": "p1.png"}))
    return root


def _median_px(scene, truth, header) -> float:
    found = Camera(320, 240, truth.K, np.array(header["R"]), np.array(header["t"]))
    return float(np.median(reprojection_error(truth, found, scene_points(scene, truth))))


@pytest.mark.slow
def test_live_starts_from_a_named_viewpoint_and_snaps(walk, tmp_path):
    """The shot's pose 0.6 m off; started at the `conveyor` viewpoint, a camera 4-24 cm beside
    it (1 to 6 steps of the walk: 1.2-7.7 px median from the viewpoint's pose) is snapped onto
    and tracked for 3 frames. Measured after the 3rd frame (2 runs): 0.18-1.06 px from five of
    the six starts, 1.75-1.96 px from the 8 cm one (the snap settles on a pose 1.9 px off there
    and the track keeps it); from 9 px and farther the snap does not reach (docs/review.md). Asserted:
    the median under 1 px and every start better than the viewpoint's pose."""
    _, scene, truths, frames = walk
    root = _shot_folder(tmp_path, walk, walk_camera(truths[0], "side", 15))
    app = create_app(open_source(sample_scene_path(), root), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")
    ends, before = [], []
    with TestClient(app) as client:
        with client.websocket_connect("/api/live") as ws:
            ws.send_text(json.dumps({"type": "start", "shot": "p1", "viewpoint": "nope"}))
            assert "no viewpoint named 'nope'" in ws.receive_json()["error"]
            ws.send_text(json.dumps({"type": "start", "shot": "p1", "markers": True}))
            assert "no marker map" in ws.receive_json()["error"]
        for first in range(1, 7):
            with client.websocket_connect("/api/live") as ws:
                ws.send_text(json.dumps({"type": "start", "shot": "p1", "viewpoint": "conveyor"}))
                for k in range(first, first + 3):
                    ws.send_bytes(struct.pack("<d", 0.1 * k) + frames[k])
                    header = _pose(ws)
                    assert not header["lost"] and not header["waiting"], header
            ends.append(_median_px(scene, truths[k], header))
            before.append(_median_px(scene, truths[k], {"R": truths[0].R, "t": truths[0].t}))
    print("from the viewpoint, px after 3 frames:", np.round(ends, 2), "the viewpoint's pose:", np.round(before, 2))
    assert np.median(ends) < 1.0 and all(e < b for e, b in zip(ends, before)), (ends, before)


@pytest.mark.slow
def test_live_waits_for_markers_then_tracks_from_their_pose(walk, tmp_path):
    """The shot's pose 0.6 m off and a marker map: frames without the marker are answered
    "waiting" (lost, no layer); the first frame showing it starts the track at the markers' pose
    (1.9 px median alone, one 0.5 m marker 3 m away), snapped onto the frame's edges. Measured:
    0.09-0.25 px over the frames after; limit 1.5 px, as the walk's."""
    _, scene, truths, frames = walk
    root = _shot_folder(tmp_path, walk, walk_camera(truths[0], "side", 15))
    marker_map = standing_marker(truths[0], (60, 190), 3.0, 0.5)
    photos = [cv2.imdecode(np.frombuffer(f, np.uint8), cv2.IMREAD_COLOR)[..., ::-1] for f in frames]
    marked = [paste_marker(p, t, marker_map) for p, t in zip(photos, truths)]
    jpegs = [cv2.imencode(".jpg", cv2.cvtColor(p, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
             for p in marked]  # fmt: skip
    app = create_app(
        open_source(sample_scene_path(), root),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "c",
        marker_map=parse_marker_map(marker_map),
    )
    with TestClient(app) as client:
        assert client.get("/api/info").json()["markers"] is True
        with client.websocket_connect("/api/live") as ws:
            ws.send_text(json.dumps({"type": "start", "shot": "p1", "markers": True}))
            ws.send_bytes(struct.pack("<d", 0.0) + frames[0])  # no marker in view
            header = ws.receive_json()
            assert header["waiting"] and header["lost"] and "waiting for markers" in header["reason"], header
            assert ws.receive_bytes() == b""
            errors = []
            for k in range(1, 5):
                ws.send_bytes(struct.pack("<d", 0.1 * k) + jpegs[k])
                header = _pose(ws)
                assert not header["lost"] and not header["waiting"], header
                errors.append(_median_px(scene, truths[k], header))
    print("from the markers, px:", np.round(errors, 2))
    assert max(errors) < 1.5, errors


@pytest.mark.slow
def test_a_frozen_frame_is_staged_for_add_photo_with_the_live_intrinsics(walk, tmp_path):
    """Live from clicks: the frozen frame and the shot's intrinsics become "Add photo" uploads
    of the frame's size (the browser test clicks on them); a frame that is no image is a 422."""
    root, scene, truths, frames = walk
    image = base64.b64encode(frames[2]).decode()
    with _client(walk, tmp_path) as client:
        staged = client.post("/api/live/clicks", json={"shot": "p1", "image": image})
        assert staged.status_code == 201, staged.json()
        refs = staged.json()
        info = client.get(
            "/api/addphoto/photo", params={"photo": refs["photo"]["ref"], "intrinsics": refs["intrinsics"]["ref"]}
        )
        assert info.status_code == 200 and (info.json()["width"], info.json()["height"]) == (320, 240)
        bad = client.post("/api/live/clicks", json={"shot": "p1", "image": "bm90IGFuIGltYWdl"})
        assert bad.status_code == 422


@pytest.mark.slow
def test_the_server_alone_keeps_up_with_offline_track(tmp_path):
    """The live rate without a browser on the same cores: a client sends a 320x240 walk at 30
    frames/s over a real socket (uvicorn, `websockets`) for 3 s after 10 warm-up answers; poses per
    second against ``mrcheck track`` on the same frames. Interleaved (offline, live, offline, live,
    offline) and each side counts its best run (as ``timeit``): the machine's speed drifts during
    a suite (offline 8.3-20.5 frames/s on this machine in three days), and one live run beside
    one offline run measured 0.80-1.07x (10 runs; a slow spell over one side made it 0.51x once).
    Why the live rate can equal offline's: a live step costs what an offline frame does (measured
    85-90 ms each on a slow day, whether the tracker sees every frame or every third as live
    does), and the socket adds little. Asserted: 0.8x, issue 42's target."""
    from .test_review import served_app
    from .test_review_live_browser import offline_track

    scene = load_scene(sample_scene_path())
    camera = scene.camera("conveyor", 320, 240)
    truths = [walk_camera(camera, "side", 6 * k / 90) for k in range(91)]
    photos = [synthetic_photo(scene, c, 0, clutter=0, leave_out=False, colour=True)[0] for c in truths]
    forth_back = [*photos, *photos[-2:0:-1]]
    jpegs = [cv2.imencode(".jpg", cv2.cvtColor(p, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 85])[1].tobytes()
             for p in forth_back]  # fmt: skip
    root = tmp_path / "shots"
    root.mkdir()
    write_image(root / "p1.png", photos[0])
    (root / "p1.json").write_text(json.dumps({**camera.to_dict(), "photo": "p1.png"}))
    app = create_app(open_source(sample_scene_path(), root), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")
    points = scene_points(scene, truths[0])
    offline, rates = [offline_track(tmp_path, forth_back, root, truths, points)[0]], []
    with served_app(app) as url:
        for _ in range(2):
            rates.append(_live_rate(url.replace("http", "ws", 1) + "api/live", jpegs, 3.0))
            offline.append(offline_track(tmp_path, forth_back, root, truths, points)[0])
    live, best = max(rates), max(offline)
    print(
        f"server alone: {np.round(rates, 1)} poses/s; offline track {np.round(offline, 1)} frames/s: {live / best:.2f}"
    )
    assert live >= 0.8 * best, (rates, offline)


def _live_rate(url: str, jpegs: list, window_s: float) -> float:
    """Poses per second a live session at ``url`` answers over ``window_s`` after 10 warm-up
    answers (the first frames find the edges), ``jpegs`` sent in a loop at 30 frames/s."""
    import threading
    import time

    from websockets.sync.client import connect

    stop, answered = threading.Event(), []
    with connect(url, max_size=None) as ws:
        ws.send(json.dumps({"type": "start", "shot": "p1"}))

        def send():
            began = time.perf_counter()
            for k in range(10**6):
                if stop.is_set():
                    return
                ws.send(struct.pack("<d", k / 30) + jpegs[k % len(jpegs)])
                time.sleep(max(0.0, began + (k + 1) / 30 - time.perf_counter()))

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        while len(answered) < 10 or answered[-1] < answered[9] + window_s:
            header = json.loads(ws.recv())
            ws.recv()  # the layer
            assert header["type"] == "pose" and not header["lost"], header
            answered.append(time.perf_counter())
        stop.set()
        sender.join()
    return (len(answered) - 10) / (answered[-1] - answered[9])
