"""The review's "Add photo" through its API (FastAPI TestClient): a photo of the sample cell
registered from clicks on it and on a CAD view, snapped with the edges, saved as a shot; the
planner's mistakes as one-line 422s with nothing saved; the upload's limit and guards."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import ADDED_SHOTS, open_source  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.camerafiles import load_shot  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .addphoto_helpers import VIEW, make_folder, median_error_px, project, scene_points, truth_camera  # noqa: E402


@pytest.fixture(scope="module")
def folder(ctx, tmp_path_factory):
    return make_folder(ctx, tmp_path_factory.mktemp("addphoto") / "shots")


@pytest.fixture()
def shots(folder, tmp_path):
    """A fresh copy of the folder per test: saving adds files to it."""
    return shutil.copytree(folder, tmp_path / "shots")


def _app(shots, tmp_path, **options):
    return create_app(
        open_source(sample_scene_path(), shots),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "cache",
        samples=2,
        **options,
    )


@pytest.fixture()
def client(shots, tmp_path):
    with TestClient(_app(shots, tmp_path)) as c:
        yield c


@pytest.fixture(scope="module")
def clicks():
    """(scene points, photo pixels with up to 0.7 px of click noise, CAD pixels of the view)."""
    from mrcheck.scene.model import load_scene

    scene = load_scene(sample_scene_path())
    view = scene.camera("robot", 800)
    world = scene_points(scene, view)
    noise = np.random.default_rng(3).uniform(-0.7, 0.7, (len(world), 2))
    return world, project(truth_camera(), world) + noise, project(view, world)


def _upload(client, kind, filename, data):
    """POST an upload as the page does (the file's bytes as application/octet-stream)."""
    return client.post(
        "/api/addphoto/upload",
        params={"kind": kind, "filename": filename},
        content=data,
        headers={"Content-Type": "application/octet-stream"},
    )


def _pairs(photo, cad):
    return [{"photo": list(map(float, p)), "cad": list(map(float, q))} for p, q in zip(photo, cad)]


def _solve(client, pairs, photo="folder:photo.png", intrinsics="folder:cam.json", snap=True, view=VIEW):
    return client.post(
        "/api/addphoto/solve",
        json={"photo": photo, "intrinsics": intrinsics, "view": view, "pairs": pairs, "snap": snap},
    )


@pytest.mark.slow
def test_clicks_snapped_and_saved_as_a_shot(client, shots, clicks):
    world, photo, cad = clicks
    listed = client.get("/api/addphoto/files").json()
    assert listed["photos"] == ["photo.png"] and "cam.json" in listed["cameras"]
    assert VIEW in [v["name"] for v in client.get("/api/addphoto/views").json()]
    assert client.get(f"/api/addphoto/views/{VIEW}/render.png").content[:4] == b"\x89PNG"
    r = _solve(client, _pairs(photo, cad))
    assert r.status_code == 200, r.text
    result = r.json()
    assert result["snapped"] and result["method"] == "edges", result
    assert len(result["residuals_px"]) == len(world) and max(result["residuals_px"]) < 2.5
    assert client.get(f"/api/addphoto/results/{result['id']}/overlay.png").content[:4] == b"\x89PNG"
    saved = client.post(f"/api/addphoto/results/{result['id']}/save")
    assert saved.status_code == 201, saved.text
    name = saved.json()["name"]
    assert name == "photo" and name in [s["name"] for s in client.get("/api/shots").json()]
    data = json.loads((shots / "photo.json").read_text())
    assert data["method"] == "edges" and data["start"] == "points" and data["photo"] == "photo.png"
    assert len(data["clicks"]) == len(world)
    camera, photo_path = load_shot(shots / "photo.json")
    assert photo_path == shots / "photo.png"
    # the truth is known: the saved pose within 0.5 px (median) of it on the clicked scene points
    assert median_error_px(camera, world) < 0.5
    assert client.get(f"/api/shots/{name}/render.png").status_code == 200
    assert client.post(f"/api/addphoto/results/{result['id']}/save").status_code == 422  # saved once
    assert "photo" in open_source(sample_scene_path(), shots).shots  # and at the next start


@pytest.mark.slow
def test_without_the_snap_the_click_pose_is_saved(client, clicks):
    world, photo, cad = clicks
    result = _solve(client, _pairs(photo, cad), snap=False).json()
    assert not result["snapped"] and result["method"] == "points"
    assert result["residuals_px"] == result["click_residuals_px"]
    assert median_error_px(Camera.from_dict(json.loads(json.dumps(_saved(client, result)))), world) < 1.5


def _saved(client, result):
    name = client.post(f"/api/addphoto/results/{result['id']}/save").json()["name"]
    return client.app.state.source.shots[name].camera.to_dict()


@pytest.mark.slow
def test_a_snap_that_fails_keeps_the_click_pose_and_says_so(client, shots, clicks):
    """A photo without the CAD's edges (a plain grey one): too little support."""
    world, photo, cad = clicks
    write_image(shots / "grey.png", np.full((360, 480, 3), 120, np.uint8))
    result = _solve(client, _pairs(photo, cad), photo="folder:grey.png").json()
    assert not result["snapped"] and result["method"] == "points"
    assert result["note"].startswith("edge snap failed (") and result["note"].endswith("the pose of the clicks is kept")
    assert result["note"] in result["warnings"]


def test_the_planners_mistakes_are_one_line_errors_and_nothing_is_saved(client, shots, clicks):
    world, photo, cad = clicks
    before = sorted(p.name for p in shots.iterdir())

    def error(pairs, **kwargs):
        r = _solve(client, pairs, **kwargs)
        assert r.status_code == 422 and "\n" not in r.json()["error"], r.text
        return r.json()["error"]

    assert "3 pair(s) of clicks: at least 4 are needed" in error(_pairs(photo[:3], cad[:3]))
    sky = [3.0, 2.0]  # the top left of the overview: above the hall's wall, nothing
    assert "CAD click 1 at (3, 2) hits no CAD part" in error(_pairs(photo[:5], [sky] * 5), view="view:overview")
    line = [[100.0 + 40 * i, 200.0] for i in range(5)]
    assert "collinear" in error(_pairs(line, cad[:5]))
    assert "outside the 480x360 photo" in error(_pairs([[500.0, 10.0], *photo[1:5]], cad[:5]))
    (shots / "wide.json").write_text(json.dumps({**truth_camera().to_dict(pose=False), "width": 640}))
    assert "another aspect ratio" in error(_pairs(photo, cad), intrinsics="folder:wide.json")
    assert "no photo file 'nope.png'" in error(_pairs(photo, cad), photo="folder:nope.png")
    assert "unknown photo reference" in error(_pairs(photo, cad), photo="../../etc/passwd")
    # an upload that is no image, or no camera file
    r = _upload(client, "photo", "notes.jpg", b"these are notes")
    assert r.status_code == 422 and r.json()["error"].startswith("notes.jpg: cannot read photo"), r.text
    r = _upload(client, "intrinsics", "cam.json", b"{}")
    assert r.status_code == 422 and r.json()["error"] == "cam.json: camera JSON is missing width, height, K", r.text
    assert sorted(p.name for p in shots.iterdir()) == sorted([*before, "wide.json"])
    assert list(client.app.state.source.shots) == ["other"]


@pytest.mark.slow
def test_an_uploaded_photo_is_copied_under_a_new_name(client, shots, clicks):
    """Photo and intrinsics uploaded: the photo copied beside its shot, never over a file."""
    world, photo, cad = clicks
    data = (shots / "photo.png").read_bytes()
    up = _upload(client, "photo", "photo.png", data)
    cam = _upload(client, "intrinsics", "C:\\calib\\cam.json", (shots / "cam.json").read_bytes())
    assert up.status_code == 201 and cam.status_code == 201 and cam.json()["name"] == "cam.json"
    info = client.get("/api/addphoto/photo", params={"photo": up.json()["ref"], "intrinsics": cam.json()["ref"]}).json()
    assert (info["width"], info["height"]) == (480, 360) and info["warnings"] == []
    result = _solve(client, _pairs(photo, cad), photo=up.json()["ref"], intrinsics=cam.json()["ref"]).json()
    saved = client.post(f"/api/addphoto/results/{result['id']}/save").json()
    assert saved["name"] == "photo-2" and saved["photo"] == "photo-2.png"
    assert (shots / "photo.png").read_bytes() == data and (shots / "photo-2.png").read_bytes() == data
    assert json.loads((shots / "photo-2.json").read_text())["photo"] == "photo-2.png"
    assert not (shots / "photo.json").exists()
    staged = client.app.state.review.addphoto.uploads
    assert len(list(staged.iterdir())) == 2
    _app(shots, client.app.state.review.renders.cache.parent)  # the next start: the staged uploads are gone
    assert list(staged.iterdir()) == []


@pytest.mark.slow
def test_the_upload_has_its_own_limit_and_the_guards(shots, tmp_path):
    small = _app(shots, tmp_path, max_body=64 << 10, max_upload=256 << 10)
    with TestClient(small) as c:
        r = _upload(c, "photo", "big.png", b"x" * (300 << 10))
        assert r.status_code == 413 and "over the limit of 256 KiB (--max-upload)" in r.json()["error"]
        chunked = c.post(
            "/api/addphoto/upload?kind=photo&filename=big.png",
            content=iter([b"x" * (100 << 10)] * 3),
            headers={"Content-Type": "application/octet-stream"},
        )
        assert chunked.status_code == 413 and "256 KiB (--max-upload)" in chunked.json()["error"], chunked.text
        r = c.post("/api/markers", content=b"x" * (80 << 10), headers={"Content-Type": "application/json"})
        assert r.status_code == 413 and "(--max-body)" in r.json()["error"]
        ok = _upload(c, "photo", "p.png", (shots / "photo.png").read_bytes())
        assert ok.status_code == 201, ok.text
    with TestClient(_app(shots, tmp_path, token="s3cret")) as c:
        assert _upload(c, "photo", "p.png", b"x").status_code == 401
        assert c.get("/api/addphoto/files").status_code == 401
    with TestClient(_app(shots, tmp_path, host="127.0.0.1")) as c:  # TestClient's Host is "testserver"
        assert _upload(c, "photo", "p.png", b"x").status_code == 403


@pytest.mark.slow
def test_a_shot_added_to_a_job_review_is_kept_beside_the_job(tmp_path, folder, clicks):
    world, photo, cad = clicks
    shutil.copytree(folder, tmp_path / "data")
    job = tmp_path / "job.toml"
    job.write_text(f'scene = "{sample_scene_path()}"\n[[shots]]\nname = "other"\nshot = "data/other.json"\n')
    app = create_app(open_source(job), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2)
    with TestClient(app) as c:
        up = _upload(c, "photo", "new.png", (folder / "photo.png").read_bytes())
        cam = _upload(c, "intrinsics", "cam.json", (folder / "cam.json").read_bytes())
        result = _solve(c, _pairs(photo, cad), photo=up.json()["ref"], intrinsics=cam.json()["ref"]).json()
        assert c.post(f"/api/addphoto/results/{result['id']}/save").json()["name"] == "new"
    assert sorted(p.name for p in (tmp_path / ADDED_SHOTS).iterdir()) == ["new.json", "new.png"]
    assert list(open_source(job).shots) == ["other", "new"]


@pytest.mark.slow
def test_a_mis_click_is_left_out_and_named(client, clicks):
    """One of eight pairs clicked on another point: the pose solver leaves it out, the result
    names it (0-based) with its residual, and the pose stays on the truth."""
    world, photo, cad = clicks
    wrong = photo.copy()
    wrong[2] += (60.0, -40.0)
    result = _solve(client, _pairs(wrong, cad)).json()
    assert result["rejected"] == [2] and result["residuals_px"][2] > 40 and result["snapped"], result
    assert median_error_px(Camera.from_dict(_saved(client, result)), world) < 0.5


@pytest.mark.slow
def test_intrinsics_of_the_same_aspect_ratio_are_rescaled_with_a_warning(client, shots):
    """As ``mrcheck register`` does: a calibration at half the photo's size is rescaled, and said."""
    (shots / "half.json").write_text(json.dumps(truth_camera().resized(240, 180).to_dict(pose=False)))
    info = client.get("/api/addphoto/photo", params={"photo": "folder:photo.png", "intrinsics": "folder:half.json"})
    assert info.status_code == 200 and "K rescaled" in info.json()["warnings"][0], info.text


@pytest.mark.slow
def test_a_forgotten_upload_is_a_one_line_error_at_save(client, shots, clicks, monkeypatch):
    import mrcheck.apps.review.addphoto as addphoto

    monkeypatch.setattr(addphoto, "MAX_KEPT", 2)
    world, photo, cad = clicks
    up = _upload(client, "photo", "new.png", (shots / "photo.png").read_bytes()).json()
    result = _solve(client, _pairs(photo, cad), photo=up["ref"], snap=False).json()
    for _ in range(2):  # two more uploads: the photo's is the oldest of three, forgotten
        _upload(client, "intrinsics", "cam.json", (shots / "cam.json").read_bytes())
    r = client.post(f"/api/addphoto/results/{result['id']}/save")
    assert r.status_code == 422 and "the uploaded photo new.png is no longer kept: upload it again" in r.json()["error"]
    assert not (shots / "new.json").exists() and not (shots / "new.png").exists()
