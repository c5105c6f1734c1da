"""The review's BCF 2.1 round trip: markers out as a schema-valid .bcfzip (the part's component,
the shot's camera, a snapshot), a status, comment and priority changed "in another tool" back
onto the markers."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.bcf import read_bcf_bytes  # noqa: E402
from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .mr_helpers import make_camera, sample_shot  # noqa: E402
from .test_bcf import validate_bcfzip  # noqa: E402

OCTETS = {"Content-Type": "application/octet-stream"}  # what the page sends
EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])


@pytest.fixture(scope="module")
def shots(ctx, tmp_path_factory):
    root = tmp_path_factory.mktemp("review_bcf")
    cam = make_camera(320, 240, 250.0, eye=EYE, target=TARGET)
    sample_shot(ctx, root, cam)
    return root


@pytest.fixture()
def client(shots, tmp_path):
    app = create_app(
        open_source(sample_scene_path(), shots),
        db_path=tmp_path / "review.sqlite",
        cache_dir=tmp_path / ".cache",
        samples=4,
    )
    with TestClient(app) as c:
        yield c


def _changed(data: bytes) -> bytes:
    """The file as another tool leaves it: the first topic Closed, High, with a comment."""
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(data)) as src, zipfile.ZipFile(out, "w") as dst:
        for name in src.namelist():
            body = src.read(name)
            if name.endswith("markup.bcf") and b"Priority>Low<" in body:
                body = body.replace(b'TopicStatus="Open"', b'TopicStatus="Closed"').replace(b">Low<", b">High<")
                body = body.replace(
                    b"</Topic>",
                    b'</Topic><Comment Guid="0b8ac9f6-1d5e-4b5f-9a44-6c2f3e1d0a11">'
                    b"<Date>2026-02-01T10:00:00Z</Date><Author>site@example.com</Author>"
                    b"<Comment>fixed on site</Comment></Comment>",
                )
            dst.writestr(name, body)
    return out.getvalue()


@pytest.mark.slow
def test_markers_out_as_bcf_and_back(client):
    a = client.post(
        "/api/markers",
        json={"shot": "p1", "x": 160, "y": 150, "category": "moved", "severity": 1, "note": "conveyor 3 cm off"},
    ).json()
    b = client.post("/api/markers", json={"shot": "p1", "x": 40, "y": 40, "category": "missing", "severity": 3}).json()
    r = client.get("/api/bcf/markers.bcfzip")
    assert r.status_code == 200 and 'filename="review.bcfzip"' in r.headers["content-disposition"]
    assert sum(n.endswith("markup.bcf") for n in validate_bcfzip(r.content)) == 2
    topics = {t.title: t for t in read_bcf_bytes(r.content)}
    first = next(t for t in topics.values() if t.description == "conveyor 3 cm off")
    assert first.priority == "Low" and first.status == "Open" and first.snapshot_png.startswith(b"\xff\xd8\xff")  # JPEG
    assert first.components and first.components[0].tool_id == a["part"] and first.components[0].ifc_guid is None
    assert np.allclose(first.camera.viewpoint, EYE)
    # the same markers give the same topic ids: the round trip finds them again
    assert {t.guid for t in read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)} == {
        t.guid for t in topics.values()
    }

    got = client.post("/api/bcf/import", content=_changed(r.content), headers=OCTETS)
    assert got.status_code == 200 and got.json() == {"matched": 2, "added": 0, "unknown": 0}
    by_id = {m["id"]: m for m in client.get("/api/markers").json()}
    assert by_id[a["id"]]["status"] == "Closed" and by_id[a["id"]]["severity"] == 3
    assert by_id[a["id"]]["comments"][0]["text"] == "fixed on site"
    assert by_id[b["id"]]["status"] == "Open" and by_id[b["id"]]["comments"] == []
    # and the next export carries the other tool's status and comment
    again = {t.guid: t for t in read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)}
    assert again[first.guid].status == "Closed" and again[first.guid].comments[0].author == "site@example.com"


def test_a_bad_upload_is_a_400(client):
    r = client.post("/api/bcf/import", content=b"not a zip", headers=OCTETS)
    assert r.status_code == 400 and "not a BCF file" in r.json()["error"]
