"""``mrcheck review``: API (bad input, path traversal, token, marker CRUD, WAL persistence) and
end to end in headless Chromium (Playwright driving Debian's /usr/bin/chromium)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.cli import main  # noqa: E402
from mrcheck.cli.messages import console  # noqa: E402
from mrcheck.core.errors import MrcheckError  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.render.settings import MODES  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .mr_helpers import make_camera, render_photo  # noqa: E402

EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
CHROMIUM = "/usr/bin/chromium"


@pytest.fixture(scope="module")
def outdir(ctx, tmp_path_factory):
    root = tmp_path_factory.mktemp("review_job")
    scene = load_scene(sample_scene_path())
    for i, offset in enumerate([(0, 0, 0), (0.4, -0.3, 0.1)]):
        cam = make_camera(320, 240, 250.0, dist=(-0.05, 0, 0, 0, 0), eye=EYE + offset, target=TARGET)
        write_image(root / f"shot{i}.png", render_photo(ctx, scene, cam))
        (root / f"shot{i}.json").write_text(json.dumps({**cam.to_dict(), "photo": f"shot{i}.png", "rms": 0.1 + i}))
    shots = "".join(f'\n[[shots]]\nshot = "shot{i}.json"\n' for i in range(2))
    (root / "job.toml").write_text(
        f'scene = "{sample_scene_path()}"\nmodes = ["phong", "vector"]\nsamples = 4\n{shots}'
    )
    assert main(["export", str(root / "job.toml"), "-o", str(root / "out")]) == 0
    return root / "out"


@pytest.fixture()
def client(outdir, tmp_path):
    app = create_app(open_source(outdir), db_path=tmp_path / "review.sqlite", cache_dir=outdir / ".cache", samples=4)
    with TestClient(app) as c:
        yield c


@pytest.mark.slow
def test_shots_images_and_pick(client):
    shots = client.get("/api/shots").json()
    assert [s["name"] for s in shots] == ["shot0", "shot1"] and shots[0]["width"] == 320
    for kind in ("photo", "thumb", "edges", "render"):
        r = client.get(f"/api/shots/shot0/{kind}.png", params={"mode": "vector", "intensity": 1.5})
        assert r.status_code == 200 and r.content[:4] == b"\x89PNG"
    hit = client.get("/api/shots/shot0/pick", params={"x": 160, "y": 150}).json()
    assert hit["part"] and 1.0 < hit["distance"] < 30.0


@pytest.mark.parametrize(
    "url",
    [
        "/api/shots/../../etc/passwd/photo.png",
        "/api/shots/..%2F..%2Fetc%2Fpasswd/photo.png",
        "/api/shots/%2e%2e%2f%2e%2e%2fetc%2fpasswd/photo.png",
        "/static/..%2F..%2Fcli.py",
        "/static/../app.py",
        "/static/%2e%2e/app.py",
        "/api/shots/shot0/..%2F..%2FSHOT.json.png",
        "/api/shots/shot0/passwd.png",
    ],
)
def test_path_traversal_is_refused(client, url):
    r = client.get(url)
    assert r.status_code == 404 and b"root:" not in r.content and b"import" not in r.content


def test_bad_input_is_a_clear_4xx(client):
    base = {"shot": "shot0", "x": 10, "y": 10, "category": "missing", "severity": 2, "note": "x"}
    for bad, status in [
        ({"category": "broken"}, 422),
        ({"severity": 4}, 422),
        ({"note": "n" * 2001}, 422),
        ({"x": 320}, 422),
        ({"y": -1}, 422),
        ({"shot": "nope"}, 404),
        ({"mode": "fancy"}, 422),
    ]:
        r = client.post("/api/markers", json={**base, **bad})
        assert r.status_code == status, (bad, r.text)
        assert "error" in r.json()
    assert client.get("/api/shots/shot0/render.png", params={"mode": "fancy"}).status_code == 422
    assert client.get("/api/shots/shot0/render.png", params={"intensity": 3}).status_code == 422
    assert client.patch("/api/markers/999", json={"note": "x"}).status_code == 404


def test_wrong_types_and_unknown_fields_are_a_422(client):
    """PATCH ignored mode and unknown fields (a typo such as "severty" answered 200, nothing
    changed); a severity true was stored as 1."""
    base = {"shot": "shot0", "x": 10, "y": 10, "category": "missing", "severity": 2}
    for bad in (
        {"severity": True},
        {"severity": "2"},
        {"severity": 2.0},
        {"x": "10"},
        {"note": None},
        {"severty": 3},
        {"mode": 1},
    ):
        r = client.post("/api/markers", json={**base, **bad})
        assert r.status_code == 422 and "error" in r.json(), (bad, r.text)
    m = client.post("/api/markers", json={**base, "mode": "vector"}).json()
    for bad in ({"mode": "bogus"}, {"severty": 3}, {"Note": "x"}, {"note": None}, {"severity": True}, {"x": None}):
        r = client.patch(f"/api/markers/{m['id']}", json=bad)
        assert r.status_code == 422 and "error" in r.json(), (bad, r.text)
    r = client.patch(f"/api/markers/{m['id']}", json={"mode": "ssao", "x": 12})
    assert r.status_code == 200 and (r.json()["mode"], r.json()["x"], r.json()["note"]) == ("ssao", 12.0, "")
    client.delete(f"/api/markers/{m['id']}")


@pytest.mark.slow
def test_marker_crud_and_persistence(client, outdir, tmp_path):
    r = client.post(
        "/api/markers",
        json={"shot": "shot1", "x": 160, "y": 150, "category": "moved", "severity": 3, "note": "pillar 20 cm off"},
    )
    assert r.status_code == 201
    m = r.json()
    assert m["part"] and m["distance"] > 0
    m2 = client.patch(f"/api/markers/{m['id']}", json={"note": "pillar 25 cm off", "x": 100}).json()
    assert m2["note"] == "pillar 25 cm off" and m2["x"] == 100
    gone = client.post(
        "/api/markers", json={"shot": "shot1", "x": 5, "y": 5, "category": "other", "severity": 1}
    ).json()
    assert client.delete(f"/api/markers/{gone['id']}").status_code == 200
    # a second app on the same database (another planner, or after a kill) sees the change
    app2 = create_app(open_source(outdir), db_path=tmp_path / "review.sqlite", cache_dir=outdir / ".cache", samples=4)
    with TestClient(app2) as other:
        markers = other.get("/api/markers", params={"shot": "shot1"}).json()
        assert [(x["id"], x["note"]) for x in markers] == [(m["id"], "pillar 25 cm off")]
        exported = other.get("/api/export/markers.csv")
        assert "pillar 25 cm off" in exported.text
        # a byte-order mark, so that Excel reads the UTF-8 notes as UTF-8
        assert (
            exported.content.startswith(b"\xef\xbb\xbfid,shot,") and "charset=utf-8" in exported.headers["content-type"]
        )
        report = other.get("/api/export/report.html").text
        assert "pillar 25 cm off" in report and report.count("data:image/png") == 1 + len(MODES)  # photo + every mode
    assert (tmp_path / "review.sqlite-wal").exists() or (tmp_path / "review.sqlite").stat().st_size > 0


def test_token_required(outdir, tmp_path):
    app = create_app(open_source(outdir), db_path=tmp_path / "r.sqlite", cache_dir=outdir / ".cache", token="s3cret")
    with TestClient(app) as c:
        assert c.get("/api/shots").status_code == 401
        assert c.get("/api/shots", headers={"X-Review-Token": "wrong"}).status_code == 401
        assert c.get("/api/shots", headers={"X-Review-Token": "s3cret"}).status_code == 200
        assert c.get("/?token=s3cret").status_code == 200
        assert c.get("/api/shots").status_code == 200  # the cookie set by the page


@pytest.mark.slow
def test_suggested_markers_of_a_discrepancies_run(outdir, tmp_path, monkeypatch):
    """--suggestions: a suspects.json's suggested markers become editable markers of category
    "suggested" on the shot with the same photo; a deleted one does not come back on restart."""
    from mrcheck.apps.review.suggestions import load_suggestions

    source = open_source(outdir)
    manifest = json.loads((outdir / "manifest.json").read_text())
    entry = next(e for e in manifest["shots"] if e["name"] == "shot1")
    shot_json = outdir / entry.get("folder", "shots/shot1") / "SHOT.json"
    suspects = tmp_path / "suspects.json"
    suspects.write_text(
        json.dumps(
            {
                "shot": str(shot_json),
                "suggested_markers": [
                    {
                        "x": 100.0,
                        "y": 80.5,
                        "category": "moved",
                        "severity": 3,
                        "note": "workbench: 12 % of its CAD outline found",
                        "part": "workbench",
                    },
                    {
                        "x": 200.0,
                        "y": 120.0,
                        "category": "extra",
                        "severity": 1,
                        "note": "photo structure no CAD part explains",
                        "part": None,
                    },
                ],
            }
        )
    )

    def app_with(specs):
        return create_app(
            source,
            db_path=tmp_path / "r.sqlite",
            cache_dir=outdir / ".cache",
            samples=4,
            suggestions=load_suggestions(source, specs),
        )

    with TestClient(app_with([str(suspects)])) as c:
        markers = c.get("/api/markers", params={"shot": "shot1"}).json()
        assert [(m["category"], m["x"], m["y"], m["severity"]) for m in markers] == [
            ("suggested", 100.0, 80.5, 3),
            ("suggested", 200.0, 120.0, 1),
        ]
        # the detector's part is the marker's part, whatever lies under its point (issue 22:
        # review replaced it by the pick); a marker without a part gets the CAD part under it and
        # its distance, like a marker the planner places; a distance is only ever the part's own
        for m, guess in zip(markers, ("workbench", None)):
            hit = c.get("/api/shots/shot1/pick", params={"x": m["x"], "y": m["y"]}).json()
            part = guess or hit["instance"]
            assert (m["part"], m["distance"]) == (part, hit["distance"] if hit["instance"] == part else None)
        assert markers[0]["part"] == "workbench"
        assert any(m["distance"] is not None for m in markers)
        assert (
            markers[0]["note"].startswith("moved? workbench")
            and c.get("/api/markers", params={"shot": "shot0"}).json() == []
        )
        assert "suggested" in c.get("/api/info").json()["categories"]
        kept = c.patch(f"/api/markers/{markers[0]['id']}", json={"category": "moved", "note": "confirmed"}).json()
        assert (kept["category"], kept["note"]) == ("moved", "confirmed")
        assert c.delete(f"/api/markers/{markers[1]['id']}").status_code == 200
    with TestClient(app_with([str(suspects), f"shot0={suspects}"])) as c:  # a restart, plus a named shot
        assert [m["note"] for m in c.get("/api/markers", params={"shot": "shot1"}).json()] == ["confirmed"]
        assert len(c.get("/api/markers", params={"shot": "shot0"}).json()) == 2

    def no_picker(scene):
        raise AssertionError("a restart with nothing new to import loaded the scene for the picker")

    import mrcheck.apps.review.pick

    monkeypatch.setattr(mrcheck.apps.review.pick, "Picker", no_picker)
    with TestClient(app_with([str(suspects), f"shot0={suspects}"])) as c:  # nothing new
        assert len(c.get("/api/markers").json()) == 3
    with pytest.raises(MrcheckError, match="no shot named 'nope'"):
        load_suggestions(source, [f"nope={suspects}"])
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(MrcheckError, match="suggested_markers"):
        load_suggestions(source, [str(tmp_path / "bad.json")])


@pytest.mark.slow
def test_a_rerun_of_discrepancies_does_not_add_its_parts_again(outdir, tmp_path):
    """The import key was x, y and the note, whose percentage changes with every run: a re-run
    (here: other notes, a region's centre 1 px away) added every part again."""
    from mrcheck.apps.review.storage import Store
    from mrcheck.apps.review.suggestions import load_suggestions

    source = open_source(outdir)
    shot_json = outdir / "shots" / "shot1" / "SHOT.json"

    def run(markers):
        path = tmp_path / f"suspects{len(markers)}.json"
        path.write_text(json.dumps({"shot": str(shot_json), "suggested_markers": markers}))
        app = create_app(
            source,
            db_path=tmp_path / "r.sqlite",
            cache_dir=outdir / ".cache",
            suggestions=load_suggestions(source, [str(path)]),
        )
        return app.state.imported

    first = [
        {"x": 100.0, "y": 80.0, "category": "moved", "note": "workbench: 12 % found", "part": "workbench"},
        {"x": 200.0, "y": 120.0, "category": "extra", "note": "structure (50 edge px)", "part": None},
    ]
    assert run(first) == {"shot1": 2}
    again = [
        {"x": 104.0, "y": 82.0, "category": "missing", "note": "workbench: 9 % found", "part": "workbench"},
        {"x": 201.0, "y": 120.0, "category": "extra", "note": "structure (48 edge px)", "part": None},
        {"x": 50.0, "y": 50.0, "category": "moved", "note": "shelf: 20 % found", "part": "shelf"},
    ]
    assert run(again) == {"shot1": 1}
    assert sorted(
        m["note"] for m in Store(tmp_path / "r.sqlite", source.review_name(tmp_path / "r.sqlite")).markers()
    ) == ["extra? structure (50 edge px)", "moved? shelf: 20 % found", "moved? workbench: 12 % found"]
    # a review of before recorded x, y (served pixels) and the note: not imported twice either
    legacy = Store(tmp_path / "old.sqlite", source.review_name(tmp_path / "old.sqlite"))
    legacy.import_suggestions(
        "shot1",
        [
            {
                "shot": "shot1",
                "x": 1.0,
                "y": 2.0,
                "category": "suggested",
                "severity": 2,
                "note": "moved? shelf: 20 % found",
                "key": "50.0,50.0,moved? shelf: 20 % found",
            }
        ],
    )
    app = create_app(
        source,
        db_path=tmp_path / "old.sqlite",
        cache_dir=outdir / ".cache",
        suggestions=load_suggestions(source, [str(tmp_path / "suspects3.json")]),
    )
    assert app.state.imported == {"shot1": 2}


@pytest.mark.slow
def test_one_database_keeps_the_reviews_of_two_exports_apart(outdir, tmp_path):
    """A --db given to two reviews showed the first one's markers in the second (on any shot of
    the same name, too)."""
    db = tmp_path / "team.sqlite"
    reviews = {"cell": open_source(outdir), "box": box_review(tmp_path / "box", (0.0, 0.0, 0.0))}
    for name, source in reviews.items():
        with TestClient(create_app(source, db_path=db, cache_dir=tmp_path / "cache", samples=2)) as c:
            shot = next(iter(source.shots))
            assert c.get("/api/markers").json() == []
            assert (
                c.post(
                    "/api/markers",
                    json={"shot": shot, "x": 5, "y": 5, "category": "other", "severity": 1, "note": name},
                ).status_code
                == 201
            )
    for name, source in reviews.items():
        app = create_app(source, db_path=db, cache_dir=tmp_path / "cache")
        assert [m["note"] for m in app.state.store.markers()] == [name]
    assert (source.review_name(db), app.state.store.others) == ("box/shots", [os.path.relpath(outdir, tmp_path)])
    # the name is relative to the database: an export moved or copied with its review.sqlite keeps its review
    shutil.copytree(outdir.parent, tmp_path / "one", ignore=shutil.ignore_patterns(".cache", "*.sqlite*"))
    with TestClient(create_app(open_source(tmp_path / "one" / "out"), cache_dir=tmp_path / "cache")) as c:
        c.post(
            "/api/markers", json={"shot": "shot0", "x": 5, "y": 5, "category": "other", "severity": 1, "note": "own db"}
        )
    shutil.copytree(tmp_path / "one", tmp_path / "two")
    moved = create_app(open_source(tmp_path / "two" / "out"), cache_dir=tmp_path / "cache").state.store
    assert [m["note"] for m in moved.markers()] == ["own db"] and moved.others == []


def box_review(folder, centre, size=(64, 48)):
    """A review of one 64x48 shot of a 1 m box (a single-mesh scene) at ``centre``: SCENE --shots DIR."""
    import trimesh

    from mrcheck.core.camera import Camera

    folder.mkdir(exist_ok=True)
    trimesh.creation.box(extents=(1, 1, 1), transform=trimesh.transformations.translation_matrix(centre)).export(
        folder / "box.stl"
    )
    (folder / "shots").mkdir(exist_ok=True)
    camera = Camera.from_look_at((4.0, 0.0, 0.5), (0.0, 0.0, 0.0), (0, 0, 1), 60.0, *size)
    write_image(folder / "shots" / "photo.png", np.full((size[1], size[0], 3), 128, np.uint8))
    (folder / "shots" / "a.json").write_text(json.dumps({**camera.to_dict(), "photo": "photo.png"}))
    return open_source(folder / "box.stl", folder / "shots")


BOX = Path(__file__).resolve().parent / "data" / "pose" / "box"


def test_review_of_a_job(tmp_path, capsys):
    """JOB.toml: its shots are registered at start-up as the export registers them (this crashed:
    export's _register had gained the scene's bounds); skipped shots and registration warnings
    go to stderr."""
    points = json.loads((BOX / "corners.json").read_text())
    for p in points["points"]:  # world points typed in mm for a scene in m: the far-camera warning
        p["world"] = [1000 * c for c in p["world"]]
    (tmp_path / "corners_mm.json").write_text(json.dumps(points))
    job = tmp_path / "job.toml"
    job.write_text(
        f'scene = "{BOX / "scene.toml"}"\n[[shots]]\nname = "box"\nphoto = "{BOX / "resized_IMG_3875.JPG"}"\n'
        f'intrinsics = "{BOX / "canon.json"}"\npoints = "corners_mm.json"\n'
        '[[shots]]\nname = "gone"\nshot = "gone.json"\n'
    )
    with console():  # warnings as the command shows them: lines on stderr
        source = open_source(job)
    out, err = capsys.readouterr()
    assert list(source.shots) == ["box"] and source.shots["box"].size == (718, 480)
    assert out == ""
    assert f"warning: shot gone skipped: {tmp_path / 'gone.json'}: shot file not found\n" in err
    assert "warning: shot box: " in err and "outside the scene" in err
    with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2)) as c:
        assert c.get("/api/shots/box/render.png").status_code == 200
        r = c.post("/api/markers", json={"shot": "box", "x": 300, "y": 250, "category": "other", "severity": 1})
        assert r.status_code == 201, r.text


@pytest.fixture()
def served_small(monkeypatch):
    """Images served at most 80 px wide: the 160 px photos of these tests stand for 4000 px ones."""
    import mrcheck.apps.review.source

    monkeypatch.setattr(mrcheck.apps.review.source, "MAX_SIZE", 80)


@pytest.mark.slow
def test_coordinates_are_the_photos_pixels_when_it_is_served_smaller(tmp_path, served_small):
    """Markers, picks, suggestions and both exports are in the photo's own pixels (the CSV and the
    report gave those of the downscaled copy served to the browser, suspects.json the photo's)."""
    import cv2

    from mrcheck.apps.review.suggestions import load_suggestions

    source = box_review(tmp_path, (0.0, 0.0, 0.0), size=(160, 120))
    suspects = tmp_path / "suspects.json"
    suspects.write_text(
        json.dumps(
            {
                "shot": str(tmp_path / "shots" / "a.json"),
                "suggested_markers": [
                    {"x": 80.0, "y": 60.0, "category": "moved", "severity": 2, "note": "box: 3 % found", "part": "box"}
                ],
            }
        )
    )
    app = create_app(
        source,
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "cache",
        samples=2,
        suggestions=load_suggestions(source, [str(suspects)]),
    )
    with TestClient(app) as c:
        assert [(s["width"], s["height"]) for s in c.get("/api/shots").json()] == [(160, 120)]
        photo = cv2.imdecode(np.frombuffer(c.get("/api/shots/a/photo.png").content, np.uint8), cv2.IMREAD_COLOR)
        assert photo.shape[:2] == (60, 80)  # served downscaled
        [m] = c.get("/api/markers").json()
        hit = c.get("/api/shots/a/pick", params={"x": 80, "y": 60}).json()
        assert (m["x"], m["y"]) == (80.0, 60.0) and hit["instance"] and m["part"] == hit["instance"]
        assert c.get("/api/shots/a/pick", params={"x": 150, "y": 110}).json()["instance"] is None  # beside the box
        assert (
            c.post(
                "/api/markers", json={"shot": "a", "x": 150, "y": 110, "category": "other", "severity": 1}
            ).status_code
            == 201
        )
        assert (
            c.post(
                "/api/markers", json={"shot": "a", "x": 160, "y": 110, "category": "other", "severity": 1}
            ).status_code
            == 422
        )
        assert ",a,80.0,60.0,suggested," in c.get("/api/export/markers.csv").text
        report = c.get("/api/export/report.html").text
        assert "photo pixel (80, 60)" in report and "photo pixel (150, 110)" in report


def test_a_database_of_served_pixels_is_upgraded(tmp_path, served_small):
    """A review.sqlite of before (version 0) has markers in the served pixels: scaled once."""
    import sqlite3

    from mrcheck.apps.review.storage import SCHEMA

    source = box_review(tmp_path, (0.0, 0.0, 0.0), size=(160, 120))
    with contextlib.closing(sqlite3.connect(tmp_path / "r.sqlite")) as db:
        db.executescript(SCHEMA)
        db.execute("INSERT INTO reviews(source, created) VALUES ('old', 0)")
        db.execute(
            "INSERT INTO markers(review, shot, x, y, category, severity, created, updated) "
            "VALUES (1, 'a', 40, 30.5, 'moved', 2, 0, 0)"
        )
        db.commit()
    for _ in range(2):  # once: a restart does not scale again
        with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache")) as c:
            assert [(m["x"], m["y"]) for m in c.get("/api/markers").json()] == [(80.0, 61.0)]


def test_render_cache_follows_a_changed_scene(tmp_path):
    """Re-exporting into the same folder with a changed scene must not serve the old render."""

    def render(source):
        app = create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2)
        with TestClient(app) as c:
            r = c.get("/api/shots/a/render.png")
            assert r.status_code == 200, r.text
            return r.content

    before = render(box_review(tmp_path, (0.0, 0.0, 0.0)))
    assert render(open_source(tmp_path / "box.stl", tmp_path / "shots")) == before  # a restart: the cached file
    assert len(list((tmp_path / "cache").rglob("render_*.png"))) == 1
    assert render(box_review(tmp_path, (0.0, 1.2, 0.0))) != before  # the box moved
    # the old render went at start-up (stale stamps); a vanished shot's folder and the user's
    # own files in the cache folder are handled as such: ours removed, theirs kept
    assert len(list((tmp_path / "cache").rglob("render_*.png"))) == 1
    gone = tmp_path / "cache" / "gone-shot"
    gone.mkdir()
    (gone / "render_phong_w64_x_y.png").write_bytes(b"old")
    (tmp_path / "cache" / "a" / "notes.txt").write_text("mine")
    render(open_source(tmp_path / "box.stl", tmp_path / "shots"))
    assert not gone.exists() and (tmp_path / "cache" / "a" / "notes.txt").exists()


def test_the_review_renders_anti_aliased_unless_told_not_to(tmp_path):
    """`mrcheck review --no-antialias` (create_app antialias=False) renders without anti-aliasing:
    a render of its own in the cache, so that a switch never serves the other setting's file."""
    source = box_review(tmp_path, (0.0, 0.0, 0.0))

    def render(antialias):
        app = create_app(
            source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2, antialias=antialias
        )
        with TestClient(app) as c:
            assert c.app.state.review.renders.settings(120).antialias is antialias
            r = c.get("/api/shots/a/render.png")
            assert r.status_code == 200, r.text
            return r.content

    smooth = render(True)
    plain = render(False)
    assert plain != smooth
    assert len(list((tmp_path / "cache").rglob("render_*.png"))) == 1  # the other setting's file went
    assert render(False) == plain and render(True) == smooth


@pytest.mark.parametrize("rms", [float("nan"), float("inf")])
def test_a_registration_error_that_is_no_number_is_n_a(tmp_path, rms):
    """ "rms": NaN in a SHOT.json made the shot list a 500 (invalid JSON): the page never loaded."""
    box_review(tmp_path, (0.0, 0.0, 0.0))
    shot = tmp_path / "shots" / "a.json"
    shot.write_text(json.dumps({**json.loads(shot.read_text()), "rms": rms}))
    source = open_source(tmp_path / "box.stl", tmp_path / "shots")
    with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache")) as c:
        r = c.get("/api/shots")
        assert r.status_code == 200 and r.json()[0]["error_px"] is None


def test_an_unexpected_error_has_the_apis_error_shape(client, monkeypatch, capsys):
    """A bug answered a plain-text 500 and printed a traceback."""

    def boom(*args):
        raise ZeroDivisionError("division by zero")

    monkeypatch.delenv("MRCHECK_DEBUG", raising=False)
    monkeypatch.setattr(client.app.state.store, "markers", boom)
    with console():  # the server's console, as `mrcheck review` shows it
        r = client.get("/api/markers")
    assert r.status_code == 500 and r.json() == {
        "error": "internal error, please report it: ZeroDivisionError: division by zero"
    }
    err = capsys.readouterr().err
    assert err == (
        "error: internal error in GET /api/markers, please report it: ZeroDivisionError: division by zero "
        "(MRCHECK_DEBUG=1 shows the traceback)\n"
    ), err


def test_a_photo_gone_after_start_is_a_json_404(tmp_path):
    source = box_review(tmp_path, (0.0, 0.0, 0.0))
    (tmp_path / "shots" / "photo.png").unlink()
    with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache")) as c:
        r = c.get("/api/shots/a/photo.png")
        assert r.status_code == 404 and "photo not found" in r.json()["error"]


def test_a_photo_replaced_after_start_breaks_its_shot_not_the_report(tmp_path):
    """The photo replaced by one of another size after start-up: the cached old photo was still
    served, and the HTML report failed (404) for every shot because of this one."""
    source = box_review(tmp_path, (0.0, 0.0, 0.0))
    with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2)) as c:
        assert c.get("/api/shots/a/photo.png").status_code == 200  # now in the cache
        assert (
            c.post(
                "/api/markers",
                json={"shot": "a", "x": 30, "y": 20, "category": "moved", "severity": 2, "note": "still listed"},
            ).status_code
            == 201
        )
        photo = tmp_path / "shots" / "photo.png"
        write_image(photo, np.full((24, 32, 3), 90, np.uint8))
        problem = f"{photo}: photo is 32x24 but the shot was registered at 64x48"
        for kind in ("photo", "render"):
            r = c.get(f"/api/shots/a/{kind}.png")
            assert r.status_code == 500 and r.json() == {"error": problem}, (kind, r.text)
        report = c.get("/api/export/report.html")
        assert report.status_code == 200 and "still listed" in report.text and f"no crops: {problem}" in report.text
        assert "data:image/png" not in report.text


@pytest.mark.parametrize("marker_id", [10**23, -(10**23), 2**63, 0])
def test_marker_ids_beyond_sqlite_are_404(client, marker_id):
    for method in ("patch", "delete"):
        r = client.request(method, f"/api/markers/{marker_id}", json={"note": "x"})
        assert r.status_code == 404 and r.json() == {"error": f"no marker {marker_id}"}


def test_markers_of_a_shot_the_review_no_longer_has(outdir, tmp_path):
    """An earlier review of the folder left a marker on shot wall-5, which the export no longer has."""
    from mrcheck.apps.review.storage import Store

    source = open_source(outdir)
    orphan = Store(tmp_path / "r.sqlite", source.review_name(tmp_path / "r.sqlite")).add(
        {"shot": "wall-5", "x": 10.0, "y": 10.0, "category": "moved", "severity": 2, "note": "old wall"}
    )
    with TestClient(create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=outdir / ".cache")) as c:
        r = c.patch(f"/api/markers/{orphan['id']}", json={"x": 50})
        assert r.status_code == 409 and "wall-5" in r.json()["error"]
        assert c.patch(f"/api/markers/{orphan['id']}", json={"note": "old wall, gone"}).status_code == 200
        report = c.get("/api/export/report.html")
        assert (
            report.status_code == 200 and "old wall, gone" in report.text and "no longer has this shot" in report.text
        )
        assert "wall-5" in c.get("/api/export/markers.csv").text


@pytest.mark.slow
def test_the_report_says_in_which_mode_a_marker_was_placed(client):
    m = client.post(
        "/api/markers", json={"shot": "shot0", "x": 20, "y": 20, "category": "moved", "severity": 2, "mode": "vector"}
    ).json()
    report = client.get("/api/export/report.html").text
    assert "; placed in D2 vector SSAO 20" in report and "last changed" not in report
    client.patch(f"/api/markers/{m['id']}", json={"note": "later"})
    assert "last changed 20" in client.get("/api/export/report.html").text


def test_csv_defuses_spreadsheet_formulas():
    import csv
    import io

    from mrcheck.apps.review.report import markers_csv

    notes = ['=HYPERLINK("http://x")', "+1", "-2+3", "@SUM(A1)", "\tx", "fine = ok"]
    markers = [
        {
            "id": i,
            "shot": "s",
            "x": 1.0,
            "y": 2.0,
            "category": "other",
            "severity": 1,
            "note": n,
            "part": "=cmd",
            "distance": None,
            "mode": None,
            "updated": 0.0,
            "offset": None,
        }
        for i, n in enumerate(notes)
    ]
    rows = list(csv.DictReader(io.StringIO(markers_csv(markers))))
    assert [r["note"] for r in rows] == ["'" + n for n in notes[:-1]] + ["fine = ok"]
    assert {r["part"] for r in rows} == {"'=cmd"}


def test_unknown_routes_and_methods_have_the_apps_error_shape(client):
    r = client.get("/api/nope")
    assert r.status_code == 404 and r.json() == {"error": "Not Found"}
    r = client.put("/api/markers")
    assert r.status_code == 405 and r.json() == {"error": "Method Not Allowed"} and "GET" in r.headers["allow"]


# -- end to end in a real browser -------------------------------------------------------------
def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_review(args, db, port) -> subprocess.Popen:
    """``mrcheck review ARGS --port PORT --db DB`` in a process of its own, once it answers
    (within 60 s; a process that ends or does not answer fails with its output)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrcheck.cli", "review", *map(str, args), "--port", str(port), "--db", str(db)],
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    deadline = time.monotonic() + 60
    while proc.poll() is None and time.monotonic() < deadline:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=1)
            return proc
        except OSError:
            time.sleep(0.2)
    proc.kill()
    raise AssertionError(proc.stdout.read().decode())


@contextlib.contextmanager
def served_box_review(tmp_path, max_body: str):
    """A box review (:func:`box_review`) served by a process of its own with ``--max-body``:
    yields (port, process); the process is killed at the end."""
    folder = tmp_path / "box"
    box_review(folder, (0.0, 0.0, 0.0))
    port = free_port()
    args = [folder / "box.stl", "--shots", folder / "shots", "--max-body", max_body]
    proc = start_review(args, tmp_path / "r.sqlite", port)
    try:
        yield port, proc
    finally:
        proc.kill()
        proc.wait()


@pytest.mark.slow
def test_ctrl_c_stops_the_server_quietly(outdir, tmp_path):
    import signal

    proc = start_review([outdir], tmp_path / "r.sqlite", free_port())
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0 and b"error" not in out, out


needs_chromium = pytest.mark.skipif(
    not Path(CHROMIUM).exists(), reason="needs Debian's chromium (bootstrap.sh installs it)"
)


def open_browser(pw, tmp_path, extra_args=()):
    """Headless Debian chromium driven by Playwright (a persistent profile in ``tmp_path``),
    with ``extra_args`` on its command line."""
    args = [
        *extra_args,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ]
    return pw.chromium.launch_persistent_context(
        str(tmp_path / "profile"),
        executable_path=CHROMIUM,
        args=args,
        headless=True,
        viewport={"width": 1280, "height": 720},
        accept_downloads=True,
    )


def ready_page(browser, url):
    """A page of ``browser`` at ``url``, the review started (``body[data-ready]``); and the list its
    uncaught script errors are collected in."""
    page = browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_selector("body[data-ready='1']", timeout=60000)
    return page, errors


@contextlib.contextmanager
def served_app(app):
    """``app`` served by uvicorn in a thread of this process; yields its URL."""
    import threading

    import uvicorn

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        while not server.started:
            time.sleep(0.05)
        yield f"http://127.0.0.1:{sock.getsockname()[1]}/"
    finally:
        server.should_exit = True
        thread.join(30)
        sock.close()


@contextlib.contextmanager
def _box_page(tmp_path, size=(64, 48)):
    """A box review (:func:`box_review`) served, and a page in headless chromium: (app, page, url)."""
    sync_api = pytest.importorskip("playwright.sync_api")
    app = create_app(
        box_review(tmp_path, (0.0, 0.0, 0.0), size=size),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "cache",
        samples=2,
    )
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path)
        yield app, browser.new_page(), url
        browser.close()


def _open(page, url):
    page.goto(url)
    page.wait_for_selector("body[data-loaded='a|phong|1']", timeout=30000)


@pytest.mark.slow
@needs_chromium
def test_the_page_shows_why_a_photo_failed(tmp_path):
    """A photo replaced by one of another size after start-up: the page said "render failed"."""
    with _box_page(tmp_path) as (app, page, url):
        write_image(tmp_path / "shots" / "photo.png", np.full((24, 32, 3), 90, np.uint8))
        page.goto(url)
        page.wait_for_function("document.querySelector('#status').textContent.includes('failed: ')", timeout=30000)
        assert "photo is 32x24 but the shot was registered at 64x48" in page.text_content("#status")


@pytest.mark.slow
@needs_chromium
def test_the_page_says_why_an_export_failed(tmp_path, monkeypatch):
    """The export links were plain downloads: a failed report ended as "canceled" in the
    browser's download list, with no reason on the page."""
    import mrcheck.apps.review.routes.exports as review_exports

    def broken(*args):
        raise MrcheckError("no space left on the device")

    monkeypatch.setattr(review_exports, "report_html", broken)
    with _box_page(tmp_path) as (app, page, url):
        _open(page, url)
        page.click("#export-html")
        page.wait_for_function("document.querySelector('#status').textContent.includes('failed: ')", timeout=30000)
        assert "Export report (HTML) failed: no space left on the device" in page.text_content("#status")
        with page.expect_download() as info:  # the CSV still downloads, under the server's name
            page.click("#export-csv")
        assert info.value.suggested_filename == "review.csv"


@pytest.mark.slow
@needs_chromium
def test_a_click_places_a_marker_in_the_photos_pixels(tmp_path, served_small):
    """The page shows the 80 px image served for a 160 px photo: a click in the middle is (80, 60)."""
    with _box_page(tmp_path, size=(160, 120)) as (app, page, url):
        _open(page, url)
        box = page.locator("#pane-a").bounding_box()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.wait_for_selector("#editor:not([hidden])")
        [m] = app.state.store.markers()
        assert abs(m["x"] - 80) < 1 and abs(m["y"] - 60) < 1, m


@pytest.mark.slow
@needs_chromium
def test_editing_markers_loses_nothing_and_adds_nothing_by_accident(tmp_path):
    """A typed note was dropped by a click on the image, which also placed a stray marker; another
    marker or shot dropped it too; Delete deleted at once."""
    with _box_page(tmp_path, size=(160, 120)) as (app, page, url):
        _open(page, url)
        store = app.state.store
        box = page.locator("#pane-a").bounding_box()

        def click(fx, fy):
            page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)

        click(0.5, 0.5)
        page.wait_for_selector("#editor:not([hidden])")
        page.fill("#ed-note", "unsaved note text")
        click(0.3, 0.3)  # closes the editor, saving the note; no marker
        page.wait_for_selector("#editor[hidden]", state="attached")
        page.wait_for_selector("#marker-list li:has-text('unsaved note text')")
        assert [m["note"] for m in store.markers()] == ["unsaved note text"]
        click(0.3, 0.3)  # nothing selected: this click places a marker
        page.wait_for_selector("#marker-list li:nth-child(2)")
        page.fill("#ed-note", "second")
        page.click("#marker-list li:nth-child(1)")  # another marker: the typed note is saved first
        page.wait_for_selector("#marker-list li:has-text('second')")
        assert page.input_value("#ed-note") == "unsaved note text"
        assert [m["note"] for m in store.markers()] == ["unsaved note text", "second"]
        page.fill("#ed-note", "first")
        page.click("#marker-list li:nth-child(1)")  # the same marker: the editor keeps what was typed
        page.wait_for_selector("#marker-list li:has-text('first')")
        assert page.input_value("#ed-note") == "first" and [m["note"] for m in store.markers()] == ["first", "second"]
        page.once("dialog", lambda dialog: dialog.dismiss())
        page.click("#ed-delete")
        assert len(store.markers()) == 2 and page.is_visible("#editor")
        page.once("dialog", lambda dialog: dialog.accept())
        page.click("#ed-delete")
        page.wait_for_selector("#editor[hidden]", state="attached")
        assert [m["note"] for m in store.markers()] == ["second"]


@pytest.mark.slow
@needs_chromium
def test_the_page_keeps_long_notes_in_the_sidebar(tmp_path):
    """A 2000-character note filled the whole sidebar, an unbroken URL overflowed it; the opacity
    slider stayed in side by side, where it does nothing; /favicon.ico was a 404 on every load."""
    note = "https://example.com/" + "x" * 400 + " " + "word " * 300
    with _box_page(tmp_path) as (app, page, url):
        app.state.store.add({"shot": "a", "x": 10.0, "y": 10.0, "category": "other", "severity": 1, "note": note})
        missing = []
        page.on("response", lambda r: missing.append(r.url) if r.status == 404 else None)
        _open(page, url)
        item = page.locator("#marker-list li").first
        assert item.bounding_box()["height"] < 60 and item.get_attribute("title") == note
        assert page.evaluate(
            "(() => { const s = document.querySelector('#side'); return s.scrollWidth <= s.clientWidth; })()"
        )
        assert page.is_visible("#opacity")
        page.select_option("#view", "side")
        assert not page.is_visible("#opacity")
        assert missing == []
    with TestClient(app) as c:
        assert c.get("/favicon.ico").status_code == 204


@pytest.mark.slow
@needs_chromium
def test_browser_end_to_end(outdir, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    port, db = free_port(), tmp_path / "e2e.sqlite"
    url = f"http://127.0.0.1:{port}/"
    proc = start_review([outdir], db, port)
    try:
        with sync_api.sync_playwright() as pw:
            browser = open_browser(pw, tmp_path)
            page = browser.new_page()
            page.goto(url)
            page.wait_for_selector("body[data-loaded='shot0|phong|1']", timeout=60000)
            viewport = page.locator("#viewport")
            cad_opacity = "getComputedStyle(document.querySelector('#pane-a .render')).opacity"
            # the photo is this scene's phong render: compare it with vector's AO, which differs from it
            # (with phong, photo and CAD are the same pixels once the image stays fitted)
            page.click("#modes button[data-mode='vector']")
            page.wait_for_selector("body[data-loaded='shot0|vector|1']", timeout=60000)
            page.fill("#opacity", "0")
            page.dispatch_event("#opacity", "input")
            assert page.evaluate(cad_opacity) == "0"  # the slider is the CAD's opacity: 0 shows the photo
            a = np.frombuffer(viewport.screenshot(), np.uint8).copy()
            page.evaluate("document.querySelector('#opacity').value = 100")
            page.dispatch_event("#opacity", "input")
            assert page.evaluate(cad_opacity) == "1"
            viewport.screenshot(path=str(tmp_path / "review_cad.png"))
            b = np.frombuffer(viewport.screenshot(), np.uint8).copy()
            assert a.shape != b.shape or np.any(a != b)
            latency = page.evaluate("""() => new Promise(done => {
                const s = document.querySelector('#opacity'); const t0 = performance.now();
                s.value = 30; s.dispatchEvent(new Event('input'));
                requestAnimationFrame(() => done(performance.now() - t0)); })""")
            print(f"slider latency {latency:.1f} ms")
            page.click("#modes button[data-mode='vector']")
            page.wait_for_selector("body[data-loaded='shot0|vector|1']", timeout=60000)
            # place a marker in the middle of the image, edit it
            box = page.locator("#pane-a").bounding_box()
            page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            page.wait_for_selector("#editor:not([hidden])")
            page.select_option("#ed-category", "wrong size")
            page.fill("#ed-note", "conveyor too short")
            page.click("#ed-save")
            page.wait_for_selector("#marker-list li:has-text('conveyor too short')")
            page.check("#edges")
            page.screenshot(path=str(tmp_path / "review_marker.png"))
            page.select_option("#view", "swipe")
            page.screenshot(path=str(tmp_path / "review_swipe.png"))
            page.select_option("#view", "side")
            page.screenshot(path=str(tmp_path / "review_side.png"))
            page.reload()
            page.wait_for_selector("#marker-list li:has-text('conveyor too short')", timeout=30000)
            # kill the server, start a new one on the same database: the marker is there
            proc.kill()
            proc.wait()
            proc = start_review([outdir], db, port)
            page.reload()
            page.wait_for_selector("#marker-list li:has-text('wrong size')", timeout=30000)
            with page.expect_download() as info:
                page.click("#export-html")
            report = Path(info.value.path()).read_text()
            assert "conveyor too short" in report and "wrong size" in report
            browser.close()
    finally:
        proc.kill()
        proc.wait()
