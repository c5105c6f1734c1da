"""BCF round trips that lose nothing: the review's own export imports back at the default limits,
BCF 2.1 and 3.0 files another tool wrote (IfcOpenShell's ``bcf`` library where installed) import
with status, priority and every comment, an import never deletes what an earlier one brought,
new topics become markers, and viewpoints carry the shot's true field of view, stable dates, an
author and the IFC file."""

from __future__ import annotations

import io
import json
import math
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from mrcheck.apps.bcf import BcfTopic, bcf_bytes, bcf_camera, read_bcf_bytes  # noqa: E402
from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .mr_helpers import make_camera  # noqa: E402
from .test_bcf import validate_bcfzip  # noqa: E402

OCTETS = {"Content-Type": "application/octet-stream"}
EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
W, H, F = 2400, 1800, 6600.0  # a long lens: a vertical field of view of some 15.5 degrees
XSD30 = Path(__file__).parent / "data" / "bcf30"


def _photo_like(width: int, height: int, seed: int = 3) -> np.ndarray:
    """An image that compresses like a photo: smooth shapes and sensor noise."""
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 255, (height // 40, width // 40, 3), dtype=np.uint8)
    image = cv2.resize(small, (width, height), interpolation=cv2.INTER_CUBIC).astype(np.int16)
    image += rng.integers(-6, 7, image.shape, dtype=np.int16)
    return np.clip(image, 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    root = tmp_path_factory.mktemp("bcf_roundtrip")
    cam = make_camera(W, H, F, eye=EYE, target=TARGET)
    write_image(root / "p1.png", _photo_like(W, H))
    (root / "p1.json").write_text(json.dumps({**cam.to_dict(), "photo": "p1.png"}))
    return root


@pytest.fixture()
def client(shots, tmp_path):
    app = create_app(open_source(sample_scene_path(), shots), db_path=tmp_path / "r.sqlite", samples=1)
    with TestClient(app) as c:
        yield c


def _add(client, n: int) -> list:
    return [
        client.post(
            "/api/markers",
            json={"shot": "p1", "x": 100 + 130 * i, "y": 200 + 80 * i, "category": "moved", "severity": 2},
        ).json()
        for i in range(n)
    ]


@pytest.mark.parametrize("count", [3, 16])
def test_the_review_export_imports_back_at_the_default_limits(client, count):
    _add(client, count)
    data = client.get("/api/bcf/markers.bcfzip").content
    # a 2400x1800 photo per marker: some 95 kB a topic (it was 1.4 MB, a 1024 px PNG)
    assert len(data) < 120_000 * count, f"{count} markers: {len(data)} bytes"
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        snaps = [n for n in archive.namelist() if "snapshot" in n]
        assert len(snaps) == count
        image = cv2.imdecode(np.frombuffer(archive.read(snaps[0]), np.uint8), cv2.IMREAD_COLOR)
        assert image.shape[1] <= 800
    got = client.post("/api/bcf/import", content=data, headers=OCTETS)
    assert got.status_code == 200 and got.json()["matched"] == count


def test_the_import_takes_a_file_larger_than_the_body_limit(client):
    """A BIM tool's file with full-size snapshots (a few MB) is not refused by --max-body."""
    (m,) = _add(client, 1)
    data = client.get("/api/bcf/markers.bcfzip").content
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(data)) as src, zipfile.ZipFile(out, "w") as dst:
        for name in src.namelist():
            dst.writestr(name, src.read(name))
        dst.writestr("padding/readme.txt", np.random.default_rng(1).bytes(3 << 20))
    got = client.post("/api/bcf/import", content=out.getvalue(), headers=OCTETS)
    assert got.status_code == 200, got.text


def test_a_bcf_file_over_max_upload_is_refused(shots, tmp_path):
    app = create_app(
        open_source(sample_scene_path(), shots), db_path=tmp_path / "r.sqlite", samples=1, max_upload=256 << 10
    )
    with TestClient(app) as c:
        r = c.post("/api/bcf/import", content=b"x" * (300 << 10), headers=OCTETS)
    assert r.status_code == 413 and "(--max-upload)" in r.json()["error"]


def _comment_xml(guid: str, text: str) -> str:
    return f'<Comment Guid="{guid}"><Date>2026-02-01T10:00:00Z</Date><Author>a@b</Author><Comment>{text}</Comment></Comment>'


def _zip(entries: dict) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        for name, body in entries.items():
            archive.writestr(name, body)
    return out.getvalue()


def _markup30(guid: str, comments, status="Resolved", priority="High", viewpoint="") -> str:
    return (
        f'<Markup><Topic Guid="{guid}" TopicType="Issue" TopicStatus="{status}"><Title>t</Title>'
        f"<Priority>{priority}</Priority><CreationDate>2026-01-01T00:00:00Z</CreationDate>"
        f"<CreationAuthor>x</CreationAuthor><Comments>{''.join(comments)}</Comments>{viewpoint}</Topic></Markup>"
    )


def test_bcf30_comments_are_read_and_an_import_deletes_none(client):
    (m,) = _add(client, 1)
    guid = next(t.guid for t in read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content))
    version = '<Version VersionId="3.0"/>'
    first = _zip({"bcf.version": version, f"{guid}/markup.bcf": _markup30(guid, [_comment_xml("c1", "one")])})
    assert client.post("/api/bcf/import", content=first, headers=OCTETS).json()["matched"] == 1
    marker = client.get("/api/markers").json()[0]
    assert marker["status"] == "Resolved" and marker["severity"] == 3
    assert [c["text"] for c in marker["comments"]] == ["one"]
    # a later file without the first comment (another tool's export of its own comments only)
    later = _zip({"bcf.version": version, f"{guid}/markup.bcf": _markup30(guid, [_comment_xml("c2", "two")])})
    assert client.post("/api/bcf/import", content=later, headers=OCTETS).status_code == 200
    assert [c["text"] for c in client.get("/api/markers").json()[0]["comments"]] == ["one", "two"]


def test_viewpoint_has_the_true_field_of_view_stable_dates_and_an_author(client):
    (m,) = _add(client, 1)
    first = client.get("/api/bcf/markers.bcfzip").content
    (topic,) = read_bcf_bytes(first)
    vertical = math.degrees(2 * math.atan(H / (2 * F)))
    assert topic.camera.field_of_view == pytest.approx(vertical, abs=0.01) and vertical < 20
    assert abs(topic.created.timestamp() - m["created"]) < 1.0 and topic.modified is None
    assert topic.author  # the OS user by default
    validate_bcfzip(first)
    (again,) = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)
    assert again.created == topic.created
    client.patch(f"/api/markers/{m['id']}", json={"note": "changed"})
    (changed,) = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)
    # BCF dates are whole seconds: a change within the marker's first second has modified == created
    assert changed.created == topic.created and changed.modified is not None and changed.modified >= topic.created


def test_the_author_option(shots, tmp_path):
    app = create_app(open_source(sample_scene_path(), shots), db_path=tmp_path / "r.sqlite", samples=1, author="ana")
    with TestClient(app) as c:
        _add(c, 1)
        c.post(f"/api/markers/{c.get('/api/markers').json()[0]['id']}/comments", json={"text": "seen"})
        (topic,) = read_bcf_bytes(c.get("/api/bcf/markers.bcfzip").content)
    assert topic.author == "ana" and topic.comments[0].author == "ana" and topic.comments[0].text == "seen"


def test_the_ifc_file_is_named_in_the_header():
    topic = BcfTopic(guid="0b3c6a7e-5f0e-4f7e-9c53-1f0d3b9a7c11", title="t", ifc_file="house.ifc")
    data = bcf_bytes([topic])
    validate_bcfzip(data)
    assert read_bcf_bytes(data)[0].ifc_file == "house.ifc"


def _visinfo(guid: str, eye, direction, up, components=()) -> str:
    def vec(tag, v):
        return f"<{tag}><X>{v[0]}</X><Y>{v[1]}</Y><Z>{v[2]}</Z></{tag}>"

    comps = "".join(
        f'<Component IfcGuid="{g}"><AuthoringToolId>{t}</AuthoringToolId></Component>' for g, t in components
    )
    return (
        f'<VisualizationInfo Guid="{guid}"><Components><Selection>{comps}</Selection>'
        f'<Visibility DefaultVisibility="true"/></Components><PerspectiveCamera>'
        f"{vec('CameraViewPoint', eye)}{vec('CameraDirection', direction)}{vec('CameraUpVector', up)}"
        f"<FieldOfView>60</FieldOfView></PerspectiveCamera></VisualizationInfo>"
    )


def _foreign(guid: str, eye, direction, up, components=()) -> dict:
    vp = "9f0d3b9a-7c11-4f7e-9c53-0b3c6a7e5f0e"
    markup = (
        f'<Markup><Topic Guid="{guid}" TopicType="Issue" TopicStatus="Open"><Title>crack in the wall</Title>'
        f"<Priority>High</Priority><CreationDate>2026-01-01T00:00:00Z</CreationDate>"
        f"<CreationAuthor>bim@x</CreationAuthor><Description>see photo</Description></Topic>"
        f"{_comment_xml('c9', 'from the BIM tool')}"
        f'<Viewpoints Guid="{vp}"><Viewpoint>{vp}.bcfv</Viewpoint></Viewpoints></Markup>'
    )
    return {f"{guid}/markup.bcf": markup, f"{guid}/{vp}.bcfv": _visinfo(vp, eye, direction, up, components)}


def test_a_topic_of_another_tool_becomes_a_marker(client, shots):
    cam = Camera.from_dict(json.loads((shots / "p1.json").read_text()))
    direction = (TARGET - EYE) / np.linalg.norm(TARGET - EYE)
    up = cam.R.T @ np.array([0.0, -1.0, 0.0])
    # the shot's own camera (a BIM tool rounds it) and, far away, a camera that sees an element
    scene = load_scene(sample_scene_path())
    seen = None
    for part in scene.parts:
        for k, box in enumerate(part.instance_bounds()):
            x, y = cam.project(box.mean(axis=0)[None])[0]
            if 0 < x < W and 0 < y < H and (cam.R @ box.mean(axis=0) + cam.t)[2] > 0:
                seen = part.instance_ids[k], (x, y)
    assert seen is not None
    entries = {"bcf.version": '<Version VersionId="2.1"><DetailedVersion>2.1</DetailedVersion></Version>'}
    entries |= _foreign("aaaaaaaa-1111-4111-8111-000000000001", EYE + 0.01, direction, up)
    entries |= _foreign("aaaaaaaa-1111-4111-8111-000000000002", (50, 50, 50), (0, 0, -1), (0, 1, 0), [("", seen[0])])
    entries |= _foreign("aaaaaaaa-1111-4111-8111-000000000003", (50, 50, 50), (0, 0, -1), (0, 1, 0))
    got = client.post("/api/bcf/import", content=_zip(entries), headers=OCTETS).json()
    assert got == {"matched": 0, "added": 2, "unknown": 1}
    markers = sorted(client.get("/api/markers").json(), key=lambda m: m["id"])
    first, second = markers
    assert first["shot"] == "p1" and abs(first["x"] - W / 2) < 50 and abs(first["y"] - H / 2) < 50
    assert first["severity"] == 3 and "crack in the wall" in first["note"]
    assert first["comments"][0]["text"] == "from the BIM tool"
    assert second["part"] == seen[0] and abs(second["x"] - seen[1][0]) < 2 and abs(second["y"] - seen[1][1]) < 2
    # imported again: matched, not added twice
    again = client.post("/api/bcf/import", content=_zip(entries), headers=OCTETS).json()
    assert again == {"matched": 2, "added": 0, "unknown": 1}


def test_status_and_comments_are_edited_in_the_review(client):
    (m,) = _add(client, 1)
    r = client.patch(f"/api/markers/{m['id']}", json={"status": "In Progress"})
    assert r.status_code == 200 and r.json()["status"] == "In Progress"
    r = client.post(f"/api/markers/{m['id']}/comments", json={"text": "welder booked"})
    assert r.status_code == 201
    marker = client.get("/api/markers").json()[0]
    assert marker["status"] == "In Progress" and marker["comments"][0]["text"] == "welder booked"
    assert client.post(f"/api/markers/{m['id']}/comments", json={"text": "x" * 2001}).status_code == 422
    (topic,) = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)
    assert topic.status == "In Progress" and topic.comments[0].text == "welder booked"


def test_names_not_globalids_where_a_person_reads():
    from mrcheck.apps.bcf import element_label
    from mrcheck.scene.elements import ElementInfo

    class Part:
        instance_ids = ["2O2Fr$t4X7Zf8NOew3FLOH"]
        instance_info = [ElementInfo("Basic Wall:Interior 138mm", "IfcWallStandardCase", "Level 1")]

    class Scene:
        def element(self, instance_id):
            return (Part, 0, Part.instance_info[0]) if instance_id == Part.instance_ids[0] else None

    assert (
        element_label(Scene(), "2O2Fr$t4X7Zf8NOew3FLOH") == "Basic Wall:Interior 138mm (IfcWallStandardCase, Level 1)"
    )
    assert element_label(Scene(), "conveyor") == "conveyor"  # no name known: the id
    assert element_label(None, None) == ""


# -- files written by IfcOpenShell's bcf library ----------------------------------------------------


def validate_bcf30(data: bytes) -> list[str]:
    """Validate the XML entries of a BCF 3.0 file against the BCF 3.0 schemas (tests/data/bcf30)."""
    xmlschema = pytest.importorskip("xmlschema")
    schemas = {
        "markup.bcf": "markup.xsd",
        ".bcfv": "visinfo.xsd",
        "bcf.version": "version.xsd",
        "project.bcfp": "project.xsd",
        "extensions.xml": "extensions.xsd",
    }
    loaded = {k: xmlschema.XMLSchema10(str(XSD30 / v)) for k, v in schemas.items()}
    checked = []
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        for name in archive.namelist():
            for ending, schema in loaded.items():
                if name.endswith(ending):
                    schema.validate(io.BytesIO(archive.read(name)))
                    checked.append(name)
    return checked


def _library_file(version: str, tmp_path: Path, guid_of=None, eye=None, direction=None, up=None) -> bytes:
    """A BCF file as IfcOpenShell's bcf library writes it: a topic In Progress, High, two
    comments; with ``guid_of`` (the review's topic GUID) that topic, else a new one with a
    perspective camera."""
    pytest.importorskip("bcf")
    import datetime

    from xsdata.models.datatype import XmlDateTime

    if version == "2.1":
        import bcf.v2.model as mdl
        from bcf.v2.bcfxml import BcfXml
    else:
        import bcf.v3.model as mdl
        from bcf.v3.bcfxml import BcfXml
    bcfxml = BcfXml.create_new("site")
    topic = bcfxml.add_topic("wall moved", "checked on site", "bim@example.com", "Issue", "In Progress")
    topic.topic.priority = "High"
    stamp = XmlDateTime.from_datetime(datetime.datetime(2026, 3, 1, 9, 0, tzinfo=datetime.timezone.utc))
    topic.comments = [
        mdl.Comment(date=stamp, author="a@example.com", comment="first", guid="11111111-1111-4111-8111-111111111111"),
        mdl.Comment(date=stamp, author="b@example.com", comment="second", guid="11111111-1111-4111-8111-111111111112"),
    ]
    if eye is not None:
        eye, direction, up = ([float(v) for v in vector] for vector in (eye, direction, up))
        handler = topic.add_viewpoint_from_point_and_guids(np.array(eye) + 5 * np.array(direction))
        camera = handler.visualization_info.perspective_camera
        camera.camera_view_point = mdl.Point(x=eye[0], y=eye[1], z=eye[2])
        camera.camera_direction = mdl.Direction(x=direction[0], y=direction[1], z=direction[2])
        camera.camera_up_vector = mdl.Direction(x=up[0], y=up[1], z=up[2])
    if guid_of is not None:  # the review's topic, as the library keeps it after reading our file
        bcfxml.topics.pop(topic.guid)
        topic.topic.guid = guid_of
        bcfxml.topics[guid_of] = topic
        topic._topic_dir = Path(guid_of)
    path = tmp_path / f"lib{version}.bcf"
    bcfxml.save(path)
    return path.read_bytes()


@pytest.mark.parametrize("version", ["2.1", "3.0"])
def test_library_files_import_with_status_priority_and_every_comment(client, tmp_path, version):
    (m,) = _add(client, 1)
    (ours,) = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)
    data = _library_file(version, tmp_path, guid_of=ours.guid)
    if version == "3.0":
        assert validate_bcf30(data)
    else:
        assert validate_bcfzip(data)
    got = client.post("/api/bcf/import", content=data, headers=OCTETS)
    assert got.status_code == 200 and got.json()["matched"] == 1, got.text
    marker = client.get("/api/markers").json()[0]
    assert marker["status"] == "In Progress" and marker["severity"] == 3
    assert [c["text"] for c in marker["comments"]] == ["first", "second"]


@pytest.mark.parametrize("version", ["2.1", "3.0"])
def test_a_library_topic_with_the_shots_camera_becomes_a_marker(client, shots, tmp_path, version):
    cam = Camera.from_dict(json.loads((shots / "p1.json").read_text()))
    direction = (TARGET - EYE) / np.linalg.norm(TARGET - EYE)
    up = cam.R.T @ np.array([0.0, -1.0, 0.0])
    data = _library_file(version, tmp_path, eye=tuple(EYE), direction=tuple(direction), up=tuple(up))
    got = client.post("/api/bcf/import", content=data, headers=OCTETS)
    assert got.status_code == 200 and got.json()["added"] == 1, got.text
    (marker,) = client.get("/api/markers").json()
    assert marker["shot"] == "p1" and marker["status"] == "In Progress" and len(marker["comments"]) == 2


def test_the_review_export_is_read_by_the_library(client, tmp_path):
    pytest.importorskip("bcf")
    from bcf.v2.bcfxml import BcfXml

    _add(client, 2)
    path = tmp_path / "review.bcfzip"
    path.write_bytes(client.get("/api/bcf/markers.bcfzip").content)
    with BcfXml.load(path) as bcfxml:
        topics = list(bcfxml.topics.values())
        assert len(topics) == 2 and all(t.topic.creation_author for t in topics)
        assert all(len(t.viewpoints) == 1 for t in topics)


def test_camera_of_a_shot_is_its_true_vertical_field_of_view():
    cam = Camera.from_look_at((0, -5, 1), (0, 0, 1), (0, 0, 1), 15.4, 640, 480)
    assert bcf_camera(cam).field_of_view == pytest.approx(15.4, abs=0.01)
    data = bcf_bytes([BcfTopic(guid="0b3c6a7e-5f0e-4f7e-9c53-1f0d3b9a7c11", title="t", camera=bcf_camera(cam))])
    assert read_bcf_bytes(data)[0].camera.field_of_view == pytest.approx(15.4, abs=0.01)


def test_the_validation_excuses_only_a_true_field_of_view():
    """validate_bcfzip accepts a field of view outside 2.1's 45..60 (see its docstring) and still
    refuses one outside 0..180 and every other violation of visinfo.xsd."""
    xmlschema = pytest.importorskip("xmlschema")
    cam = Camera.from_look_at((0, -5, 1), (0, 0, 1), (0, 0, 1), 15.4, 640, 480)
    data = bcf_bytes([BcfTopic(guid="0b3c6a7e-5f0e-4f7e-9c53-1f0d3b9a7c11", title="t", camera=bcf_camera(cam))])
    assert validate_bcfzip(data)

    def changed(old: bytes, new: bytes) -> bytes:
        out = io.BytesIO()
        with zipfile.ZipFile(io.BytesIO(data)) as src, zipfile.ZipFile(out, "w") as dst:
            for name in src.namelist():
                body = src.read(name)
                dst.writestr(name, body.replace(old, new) if name.endswith(".bcfv") else body)
        return out.getvalue()

    fov = f"<FieldOfView>{bcf_camera(cam).field_of_view!r}</FieldOfView>".encode()
    for bad in (changed(fov, b"<FieldOfView>200.0</FieldOfView>"), changed(b"CameraDirection>", b"CameraDirectio>")):
        with pytest.raises(xmlschema.XMLSchemaValidationError):
            validate_bcfzip(bad)


@pytest.mark.slow
def test_deviation_names_elements_and_writes_author_and_ifc_file(tmp_path, capsys):
    """An IFC scene's elements by name (class, storey) on the console's ``top:`` line and in the
    BCF titles; the GlobalId stays in the component; --author and the IFC file in the topics."""
    import re

    o3d = pytest.importorskip("open3d")
    from factory_scenes.generator.ifc import STOREY, generate_ifc
    from mrcheck.cli import main

    ifc = generate_ifc("cell", tmp_path / "ifc", seed=2, target_triangles=50_000, progress=False)
    scene = load_scene(ifc)
    clouds, rng = [], np.random.default_rng(4)
    for i, part in enumerate(scene.parts):
        corners = part.vertices[part.faces]  # (f, 3, 3): points spread over every triangle
        a, b = rng.random((2, len(corners), 8, 1))
        a, b = np.where(a + b > 1, 1 - a, a), np.where(a + b > 1, 1 - b, b)
        local = (corners[:, None, 0] + a * (corners[:, None, 1] - corners[:, None, 0])).reshape(-1, 3)
        local += (b * (corners[:, None, 2] - corners[:, None, 0])).reshape(-1, 3)
        for matrix in part.transforms:
            points = local @ matrix[:3, :3].T + matrix[:3, 3] + rng.normal(0, 0.001, local.shape)
            clouds.append(points + ([0.06, 0.0, 0.0] if i == 0 else 0.0))  # the first part moved 6 cm
    scan = tmp_path / "scan.ply"
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.concatenate(clouds)))
    o3d.io.write_point_cloud(str(scan), cloud)
    out = tmp_path / "out"
    args = ["deviation", str(scan), "--scene", str(ifc), "--per-element", "--author", "ana", "-o", str(out)]
    assert main(args) == 0
    err = capsys.readouterr().err
    top = re.search(r"top: (.*?)(;|$)", err, re.M)[1]
    assert STOREY in top and "(Ifc" in top and not re.fullmatch(r"[0-9A-Za-z_$]{22}", top), err
    topics = read_bcf_bytes((out / "elements.bcfzip").read_bytes())
    assert topics and all(t.author == "ana" and t.ifc_file == Path(ifc).name for t in topics)
    assert all(STOREY in t.title and len(t.components[0].ifc_guid) == 22 for t in topics)
    assert all(t.components[0].ifc_guid not in t.title for t in topics)


@pytest.mark.slow
def test_discrepancies_author_option(ctx, tmp_path):
    from mrcheck.cli import main
    from mrcheck.render.renderer import Renderer
    from mrcheck.scene.asbuilt import make_asbuilt

    from .test_discrepancies import SAMPLE, sample_camera, synthetic_photo, write_shot_files

    make_asbuilt(SAMPLE, tmp_path / "built", seed=2)
    built = load_scene(tmp_path / "built" / "scene.toml")
    camera = sample_camera(load_scene(SAMPLE))
    shot = write_shot_files(tmp_path, built, camera, synthetic_photo(built, camera, Renderer(built, ctx=ctx)))
    out = tmp_path / "out"
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out), "--author", "ana"]) == 0
    topics = read_bcf_bytes((out / "suspects.bcfzip").read_bytes())
    assert topics and {t.author for t in topics} == {"ana"}
