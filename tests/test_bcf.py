"""BCF 2.1 export / import (mrcheck.apps.bcf): every file mrcheck writes validates against the
buildingSMART BCF 2.1 schemas (tests/data/bcf21/, see its LICENSE.md) and reads back unchanged."""

from __future__ import annotations

import io
import zipfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

from mrcheck.apps.bcf import (
    BcfComment,
    BcfComponent,
    BcfTopic,
    bcf_bytes,
    bcf_camera,
    element_component,
    priority,
    read_bcf_bytes,
    severity_of,
    topic_guid,
)
from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError

XSD = Path(__file__).parent / "data" / "bcf21"
SCHEMAS = {
    "markup.bcf": "markup.xsd",
    "viewpoint.bcfv": "visinfo.xsd",
    "bcf.version": "version.xsd",
    "project.bcfp": "project.xsd",
}
PNG = b"\x89PNG\r\n\x1a\n" + b"\x00" * 16


def _documented_exception(error) -> bool:
    """visinfo.xsd (2.1) limits FieldOfView to 45..60 degrees and says, in the same element's
    annotation, "This limitation will be dropped in the next release and viewers should be
    expect values outside this range" (BCF 3.0: 0..180): mrcheck writes the shot's true field
    of view, so that one range is checked as 3.0's, every other rule as 2.1's."""
    path = error.path or ""
    if not path.endswith("/PerspectiveCamera/FieldOfView"):
        return False
    value = getattr(error.obj, "text", error.obj)  # the failed facet's value, or its element
    try:
        return 0.0 < float(value) < 180.0
    except (TypeError, ValueError):
        return False


def validate_bcfzip(data: bytes) -> list[str]:
    """Validate every XML entry of a .bcfzip against its BCF 2.1 schema; returns the entry names.
    A viewpoint may be named ``viewpoint.bcfv`` or anything ending in ``.bcfv``."""
    xmlschema = pytest.importorskip("xmlschema")
    schemas = {name: xmlschema.XMLSchema10(str(XSD / xsd)) for name, xsd in SCHEMAS.items()}
    checked = []
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        for name in archive.namelist():
            base = name.rsplit("/", 1)[-1]
            base = "viewpoint.bcfv" if base.endswith(".bcfv") else base
            if base in schemas:
                errors = schemas[base].iter_errors(io.BytesIO(archive.read(name)))
                problems = [e for e in errors if not _documented_exception(e)]
                if problems:
                    raise problems[0]
                checked.append(name)
    return checked


def _topic(**extra) -> BcfTopic:
    camera = Camera.from_look_at((4.0, -6.0, 2.5), (0.0, 0.0, 0.8), (0, 0, 1), 50.0, 640, 480)
    values = dict(
        guid=topic_guid("db", 7),
        title="moved? conveyor",
        priority=priority(3),
        description="moved 3 cm towards the aisle; Übergang prüfen",
        labels=["moved"],
        created=datetime(2026, 1, 2, 3, 4, 5, tzinfo=timezone.utc),
        components=[BcfComponent("2O2Fr$t4X7Zf8NOew3FLOH", "2O2Fr$t4X7Zf8NOew3FLOH")],
        camera=bcf_camera(camera),
        snapshot_png=PNG,
    )
    values.update(extra)
    return BcfTopic(**values)


def test_written_file_validates_against_the_bcf21_schemas():
    data = bcf_bytes(
        [
            _topic(),
            _topic(
                guid=topic_guid("db", 8), components=[BcfComponent(None, "pallet#3")], camera=None, snapshot_png=None
            ),
        ]
    )
    checked = validate_bcfzip(data)
    assert "bcf.version" in checked and "project.bcfp" in checked
    assert sum(n.endswith("markup.bcf") for n in checked) == 2
    assert sum(n.endswith("viewpoint.bcfv") for n in checked) == 2


def test_a_schema_violation_is_caught():
    """The validation can fail: a topic without its required CreationAuthor is refused."""
    xmlschema = pytest.importorskip("xmlschema")
    data = bcf_bytes([_topic()])
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        markup = next(n for n in archive.namelist() if n.endswith("markup.bcf"))
        broken = archive.read(markup).replace(b"<CreationAuthor>mrcheck</CreationAuthor>", b"")
    with pytest.raises(xmlschema.XMLSchemaValidationError):
        xmlschema.XMLSchema10(str(XSD / "markup.xsd")).validate(io.BytesIO(broken))


def test_round_trip_keeps_every_field():
    topic = _topic(
        comments=[BcfComment(topic_guid("c", 1), datetime(2026, 1, 3, tzinfo=timezone.utc), "anna", "checked on site")]
    )
    back = read_bcf_bytes(bcf_bytes([topic]))
    assert len(back) == 1
    got = back[0]
    for name in (
        "guid",
        "title",
        "status",
        "priority",
        "description",
        "labels",
        "created",
        "author",
        "components",
        "snapshot_png",
    ):
        assert getattr(got, name) == getattr(topic, name), name
    assert got.comments == topic.comments
    assert np.allclose(got.camera.viewpoint, topic.camera.viewpoint)
    assert np.allclose(got.camera.direction, topic.camera.direction)
    assert np.allclose(got.camera.up, topic.camera.up)


def test_the_camera_looks_where_the_shot_looks():
    camera = Camera.from_look_at((4.0, -6.0, 2.5), (0.0, 0.0, 0.8), (0, 0, 1), 50.0, 640, 480)
    bcf = bcf_camera(camera)
    expect = np.array([-4.0, 6.0, -1.7]) / np.linalg.norm([-4.0, 6.0, -1.7])
    assert np.allclose(bcf.viewpoint, (4.0, -6.0, 2.5))
    assert np.allclose(bcf.direction, expect)
    assert bcf.up[2] > 0.9 and abs(np.dot(bcf.up, bcf.direction)) < 1e-9
    assert bcf.field_of_view == pytest.approx(50.0)


def test_same_topics_give_the_same_bytes():
    assert bcf_bytes([_topic()]) == bcf_bytes([_topic()])


def test_priorities_and_severities():
    assert [priority(s) for s in (1, 2, 3)] == ["Low", "Normal", "High"]
    assert severity_of("High") == 3 and severity_of("critical") == 3 and severity_of("whatever") is None


def test_globalid_only_for_ifc_elements():
    from mrcheck.scene.elements import ElementInfo
    from mrcheck.scene.model import Part, Scene

    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    ifc = Part(
        "wall",
        Path("w"),
        tri,
        np.array([[0, 1, 2]], np.uint32),
        np.eye(4)[None],
        instance_ids=["2O2Fr$t4X7Zf8NOew3FLOH"],
        instance_info=[ElementInfo("W1", "IfcWall", "EG")],
    )
    plain = Part(
        "pallet",
        Path("p"),
        tri,
        np.array([[0, 1, 2]], np.uint32),
        np.eye(4)[None],
        instance_ids=["2O2Fr$t4X7Zf8NOew3FLOX"],
    )  # 22 characters, but no IFC class
    scene = Scene("s", Path("s"), [ifc, plain])
    assert element_component(scene, "2O2Fr$t4X7Zf8NOew3FLOH")[0].ifc_guid == "2O2Fr$t4X7Zf8NOew3FLOH"
    assert element_component(scene, "2O2Fr$t4X7Zf8NOew3FLOX")[0].ifc_guid is None
    assert element_component(scene, None) == []


@pytest.mark.parametrize("data, message", [(b"not a zip", "not a BCF file"), (b"", "not a BCF file")])
def test_bad_files_are_one_line_errors(data, message):
    with pytest.raises(MrcheckError, match=message):
        read_bcf_bytes(data)


def test_undecodable_file_names_still_give_a_valid_file():
    """A shot or folder name of non-UTF-8 bytes (surrogate escapes) in a title and a Guid key."""
    name = b"Halle_S\xfcd".decode("utf-8", "surrogateescape")
    topic = _topic(guid=topic_guid("discrepancies", f"/tmp/{name}", 0), title=f"moved: conveyor ({name})")
    data = bcf_bytes([topic])
    assert validate_bcfzip(data)
    assert read_bcf_bytes(data)[0].title == "moved: conveyor (Halle_S\ufffdd)"
