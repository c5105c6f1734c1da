"""The review's render session (issue 42, mrcheck.apps.review.viewsession): the WebSocket
``/api/view`` renders any camera the page moves to, the newest request only; ``/api/view/pick``
gives the CAD point under a pixel of that camera; the session keeps the review's security."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402
from starlette.websockets import WebSocketDisconnect  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .mr_helpers import make_camera, sample_shot  # noqa: E402

EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])


@pytest.fixture(scope="module")
def shots(ctx, tmp_path_factory):
    """One 320x240 shot of the sample cell, with a little barrel distortion."""
    root = tmp_path_factory.mktemp("view-shots")
    cam = make_camera(320, 240, 250.0, dist=(-0.05, 0.0, 0.0, 0.0), eye=EYE, target=TARGET)
    sample_shot(ctx, root, cam)
    return root, cam


def _app(shots, tmp_path, **options):
    return create_app(
        open_source(sample_scene_path(), shots[0]),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "cache",
        samples=4,
        accumulate=2,
        **options,
    )


def _request(cam, ident=1, quality="rest", mode="phong", R=None, t=None) -> str:
    R = cam.R if R is None else R
    t = cam.t if t is None else t
    return json.dumps({"id": ident, "shot": "p1", "R": np.asarray(R).tolist(), "t": np.asarray(t).tolist(),
                       "mode": mode, "intensity": 1.0, "quality": quality})  # fmt: skip


def _frame(ws):
    """The next frame: (header, decoded RGB image)."""
    header = ws.receive_json()
    assert header["type"] == "frame", header
    image = cv2.imdecode(np.frombuffer(ws.receive_bytes(), np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    return header, image


@pytest.mark.slow
def test_a_frame_at_the_shots_pose_is_the_shots_render(shots, tmp_path):
    """At the shot's pose, through its lens, the session's frame is the review's render of that
    shot (JPEG: within a few grey levels on average); moving, it is half the size."""
    _, cam = shots
    with TestClient(_app(shots, tmp_path)) as client:
        png = client.get("/api/shots/p1/render.png?mode=phong")
        assert png.status_code == 200
        review = cv2.imdecode(np.frombuffer(png.content, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
        with client.websocket_connect("/api/view") as ws:
            ws.send_text(_request(cam))
            header, image = _frame(ws)
            assert (header["width"], header["height"]) == (320, 240) and header["accumulate"] == 2
            assert image.shape == review.shape
            assert np.abs(image.astype(float) - review).mean() < 3.0
            ws.send_text(_request(cam, 2, quality="move"))
            header, image = _frame(ws)
            assert header["id"] == 2 and image.shape == (120, 160, 3) and header["accumulate"] == 1


@pytest.mark.slow
def test_only_the_newest_request_is_rendered_and_a_bad_one_is_answered(shots, tmp_path):
    _, cam = shots
    with TestClient(_app(shots, tmp_path)) as client, client.websocket_connect("/api/view") as ws:
        ws.send_text(json.dumps({"id": 1, "shot": "nope"}))
        assert "no shot named 'nope'" in ws.receive_json()["error"]
        ws.send_text(json.dumps({"id": 1, "shot": "p1", "R": (2 * np.eye(3)).tolist(), "t": [0, 0, 0]}))
        assert "not a rotation" in ws.receive_json()["error"]
        for ident in range(1, 7):  # sent at once: the first renders while the others replace each other
            yaw = cv2.Rodrigues(np.array([0.0, 0.0, 0.01 * ident]))[0]
            ws.send_text(_request(cam, ident, quality="move", mode="vector", R=cam.R @ yaw))
        seen = []
        while not seen or seen[-1] != 6:
            seen.append(_frame(ws)[0]["id"])
        assert seen == sorted(seen) and len(seen) < 6, seen


@pytest.mark.slow
def test_the_pick_of_a_moved_camera(shots, tmp_path):
    """At the shot's pose the session's pick is the shot's pick; its world point lies on the ray
    at the pick's distance; a camera moved 1 m back along its axis sees the point at the principal
    point 1 m farther."""
    _, cam = shots
    with TestClient(_app(shots, tmp_path)) as client:
        body = {"shot": "p1", "R": cam.R.tolist(), "t": cam.t.tolist(), "x": cam.cx, "y": cam.cy}
        hit = client.post("/api/view/pick", json=body).json()
        shot_hit = client.get(f"/api/shots/p1/pick?x={cam.cx}&y={cam.cy}").json()
        assert hit["instance"] == shot_hit["instance"] and hit["distance"] == pytest.approx(shot_hit["distance"])
        point = np.array(hit["point"])
        assert np.linalg.norm(point - cam.center) == pytest.approx(hit["distance"], abs=2e-3)
        back = cam.center - cam.R[2]  # one metre behind, same orientation
        moved = client.post("/api/view/pick", json={**body, "t": (-cam.R @ back).tolist()}).json()
        assert moved["instance"] == hit["instance"] and np.allclose(moved["point"], point, atol=2e-3)
        assert moved["distance"] == pytest.approx(hit["distance"] + 1.0, abs=0.01)
        outside = client.post("/api/view/pick", json={**body, "x": 400.0})
        assert outside.status_code == 422 and "outside" in outside.json()["error"]


def test_the_session_keeps_the_reviews_security(shots, tmp_path):
    """A token off loopback; the Host check; a page of another site cannot open the session."""
    app = _app(shots, tmp_path, token="s3cret", host="127.0.0.1")
    here = {"host": "127.0.0.1"}
    with TestClient(app) as client:
        for url, headers in [
            ("/api/view", here),
            ("/api/view?token=wrong", here),
            ("/api/view?token=s3cret", {"host": "evil.example"}),
            ("/api/view?token=s3cret", {**here, "origin": "http://evil.example"}),
        ]:
            with pytest.raises(WebSocketDisconnect) as refused, client.websocket_connect(url, headers=headers) as ws:
                ws.receive_json()
            assert refused.value.code == 1008, (url, headers)
        with client.websocket_connect("/api/view?token=s3cret", headers={**here, "origin": "http://127.0.0.1"}) as ws:
            ws.send_text("{")
            assert "not JSON" in ws.receive_json()["error"]
