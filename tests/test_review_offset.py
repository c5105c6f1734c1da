"""A marker's offset in metres (issue 42, mrcheck.apps.review.measure): the marker's photo pixel
against the pixel of the CAD point that should be there, stored on the marker, measured again
when the marker moves, and in the CSV, the HTML report and the BCF topic."""

from __future__ import annotations

import csv
import io
import sqlite3
import zipfile

import cv2
import numpy as np
import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.pick import Picker  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .mr_helpers import make_camera, sample_shot  # noqa: E402

EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
CAD_PIXEL = (160.0, 130.0)  # on the cell's equipment in this view


@pytest.fixture(scope="module")
def shots(ctx, tmp_path_factory):
    """One 320x240 shot of the sample cell through a lens with barrel distortion."""
    root = tmp_path_factory.mktemp("offset-shots")
    cam = make_camera(320, 240, 250.0, dist=(-0.05, 0.0, 0.0, 0.0), eye=EYE, target=TARGET)
    sample_shot(ctx, root, cam)
    return root, cam


def _photo_pixel(cam, world) -> tuple[float, float]:
    """Where ``world`` lies in the (distorted) photo."""
    rvec, _ = cv2.Rodrigues(cam.R)
    px, _ = cv2.projectPoints(np.asarray(world, np.float64)[None], rvec, cam.t, cam.K, cam.dist)
    return tuple(float(c) for c in px.reshape(2))


def _app(root, tmp_path):
    return create_app(open_source(sample_scene_path(), root), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")


def _marker(client, xy) -> dict:
    """A "moved" marker placed at photo pixel ``xy`` of shot p1."""
    marker = {"shot": "p1", "x": xy[0], "y": xy[1], "category": "moved", "severity": 2}
    return client.post("/api/markers", json=marker).json()


def _cad_point(cam) -> np.ndarray:
    hit = Picker(load_scene(sample_scene_path())).world_point(cam, *CAD_PIXEL)
    assert hit is not None, "the test's CAD pixel must lie on a part"
    return hit[0]


@pytest.mark.slow
def test_the_offset_across_the_view_is_measured_in_metres(shots, tmp_path):
    """A thing 0.40 m right of and 0.15 m below its planned place, both across the line of sight:
    the stored offset is that vector within 1 mm (the pick's float32 and the undistortion's
    iterations, not the photo: the pixels are exact projections here)."""
    root, cam = shots
    planned = _cad_point(cam)
    moved = planned + 0.40 * cam.R[0] + 0.15 * cam.R[1]  # camera right and down, in world axes
    marker_xy = _photo_pixel(cam, moved)
    with TestClient(_app(root, tmp_path)) as client:
        m = _marker(client, marker_xy)
        assert m["offset"] is None
        r = client.put(f"/api/markers/{m['id']}/offset", json={"x": CAD_PIXEL[0], "y": CAD_PIXEL[1]})
        assert r.status_code == 200, r.text
        offset = r.json()["offset"]
        np.testing.assert_allclose(offset["offset_m"], moved - planned, atol=1e-3)
        assert offset["distance_m"] == pytest.approx(np.hypot(0.40, 0.15), abs=1e-3)
        np.testing.assert_allclose(offset["cad_point"], planned, atol=1e-3)
        assert offset["part"] and (offset["cad_x"], offset["cad_y"]) == CAD_PIXEL
        # kept: a new page gets it from the store
        assert client.get("/api/markers?shot=p1").json()[0]["offset"] == offset

        # the marker moved onto the planned place: measured again from the same CAD point, ~0
        r = client.patch(f"/api/markers/{m['id']}", json={"x": CAD_PIXEL[0], "y": CAD_PIXEL[1]})
        assert r.json()["offset"]["distance_m"] < 1e-3

        # in the exports: CSV columns, the report's line, the BCF topic's description
        client.put(f"/api/markers/{m['id']}/offset", json={"x": CAD_PIXEL[0], "y": CAD_PIXEL[1]})
        client.patch(f"/api/markers/{m['id']}", json={"x": marker_xy[0], "y": marker_xy[1]})
        rows = list(csv.DictReader(io.StringIO(client.get("/api/export/markers.csv").text)))
        assert float(rows[0]["offset_m"]) == pytest.approx(np.hypot(0.40, 0.15), abs=1e-3)
        assert float(rows[0]["offset_x_m"]) == pytest.approx((moved - planned)[0], abs=1e-3)
        assert "offset 0.427 m from the planned position" in client.get("/api/export/report.html").text
        with zipfile.ZipFile(io.BytesIO(client.get("/api/bcf/markers.bcfzip").content)) as z:
            markup = next(z.read(n).decode() for n in z.namelist() if n.endswith("markup.bcf"))
        assert "offset 0.427 m" in markup

        # cleared
        assert client.delete(f"/api/markers/{m['id']}/offset").json()["offset"] is None


@pytest.mark.slow
def test_along_the_line_of_sight_is_not_measured(shots, tmp_path):
    """One photo cannot see depth: a thing 1 m farther away along the ray through its planned
    place projects onto that place, and the offset says 0 (the documented limit)."""
    root, cam = shots
    planned = _cad_point(cam)
    farther = planned + (planned - cam.center) / np.linalg.norm(planned - cam.center)
    marker_xy = _photo_pixel(cam, farther)
    with TestClient(_app(root, tmp_path)) as client:
        m = _marker(client, marker_xy)
        offset = client.put(f"/api/markers/{m['id']}/offset", json={"x": CAD_PIXEL[0], "y": CAD_PIXEL[1]}).json()[
            "offset"
        ]
        assert offset["distance_m"] < 2e-3


def test_bad_offset_requests_are_clear_4xx(shots, tmp_path):
    """No CAD under the pixel, outside the photo, no such marker, wrong types: 4xx with a reason."""
    root, _ = shots
    with TestClient(_app(root, tmp_path)) as client:
        m = _marker(client, (100, 100))
        sky = client.put(f"/api/markers/{m['id']}/offset", json={"x": 5, "y": 2})
        assert sky.status_code == 422 and "no CAD part under" in sky.json()["error"]
        assert client.put(f"/api/markers/{m['id']}/offset", json={"x": 500, "y": 2}).status_code == 422
        assert client.put("/api/markers/999/offset", json={"x": 100, "y": 100}).status_code == 404
        assert client.put(f"/api/markers/{m['id']}/offset", json={"x": "a", "y": 1}).status_code == 422
        assert client.get(f"/api/markers/{m['id']}").status_code in (404, 405)  # no such route: markers are listed


def test_a_database_without_the_offset_column_gets_it(tmp_path, shots):
    """A review database of an earlier mrcheck (markers without photo_offset) opens, keeps its
    markers, and stores offsets from then on."""
    root, _ = shots
    db = tmp_path / "old.sqlite"
    app = create_app(open_source(sample_scene_path(), root), db_path=db, cache_dir=tmp_path / "c")
    with TestClient(app) as client:
        client.post("/api/markers", json={"shot": "p1", "x": 100, "y": 100, "category": "moved", "severity": 2})
    with sqlite3.connect(db) as con:
        con.execute("ALTER TABLE markers DROP COLUMN photo_offset")
    app = create_app(open_source(sample_scene_path(), root), db_path=db, cache_dir=tmp_path / "c")
    with TestClient(app) as client:
        markers = client.get("/api/markers?shot=p1").json()
        assert len(markers) == 1 and markers[0]["offset"] is None
