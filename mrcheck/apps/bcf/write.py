"""A ``.bcfzip`` (BCF 2.1) from :class:`~mrcheck.apps.bcf.model.BcfTopic` s: ``bcf.version``,
``project.bcfp`` and per topic ``<guid>/markup.bcf``, ``viewpoint.bcfv`` and ``snapshot.png``
(or ``snapshot.jpg``). Elements in the order the schemas' sequences demand (a validator refuses
any other).

A snapshot is what a BIM tool shows beside the topic, some hundreds of pixels wide: one wider
than :data:`SNAPSHOT_WIDTH` is downscaled to it and stored as JPEG, and a snapshot several topics
share (the heat map of a discrepancies run, the status picture of a deviation run) is
downscaled once. A picture all of a run's topics share (the heat map of a discrepancies run,
the status picture of a deviation run: :class:`~mrcheck.apps.bcf.model.SharedPicture`) is
stored once, downscaled, at the zip's root (``heatmap.jpg``), each topic referring to it by a
DocumentReference; the topic's own snapshot is a crop of it around the topic's pixel box, at
most :data:`CROP_WIDTH` wide (no box: no snapshot). So a run's file grows by a few kB per topic,
not by a picture per topic.

The field of view is the shot's own (BCF 2.1's visinfo.xsd restricts it to 45..60 degrees
"currently" and tells viewers to expect other values; BCF 3.0 allows 0..180): a 15 degree photo
written as 45 degrees opens a three times wider view in the BIM tool."""

from __future__ import annotations

import io
import uuid
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import replace
from datetime import datetime, timezone

import cv2
import numpy as np

from mrcheck.apps.bcf.model import BcfCamera, BcfTopic, SharedPicture

VERSION = "2.1"
VIEWPOINT = "viewpoint.bcfv"
SNAPSHOT_WIDTH = 800  # pixels: what BIM tools show beside a topic
CROP_WIDTH = 400  # pixels: a topic's crop of a shared picture
CROP_PAD = 0.5  # the crop's margin around the box, as a share of the box's larger side
MIN_CROP = 96  # pixels: a smaller box is shown with this much around it
JPEG_QUALITY = 85
PNG_MAGIC, JPEG_MAGIC = b"\x89PNG", b"\xff\xd8\xff"
# a fixed time stamp for the zip entries: the same topics give the same bytes
ZIP_TIME = (2020, 1, 1, 0, 0, 0)


def shown(value) -> str:
    """Text as XML can carry it: a file name's undecodable bytes (surrogate escapes) as U+FFFD."""
    return str(value).encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def _text(parent, tag: str, value) -> ET.Element:
    element = ET.SubElement(parent, tag)
    element.text = shown(value)
    return element


def _date(value: datetime | None) -> str:
    value = value or datetime.now(timezone.utc)
    if value.tzinfo is None:
        value = value.replace(tzinfo=timezone.utc)
    return value.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _xml(root: ET.Element) -> bytes:
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def snapshot_name(data: bytes) -> str:
    """The snapshot's entry name: BCF tools take PNG and JPEG, told apart by the name."""
    return "snapshot.jpg" if data.startswith(JPEG_MAGIC) else "snapshot.png"


def small_snapshot(data: bytes) -> bytes:
    """``data`` at most :data:`SNAPSHOT_WIDTH` wide: a wider PNG or JPEG downscaled (area
    averaging) and stored as JPEG; a narrower one, or bytes that do not decode, as they are."""
    if not data.startswith((PNG_MAGIC, JPEG_MAGIC)):
        return data
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if image is None or image.shape[1] <= SNAPSHOT_WIDTH:
        return data
    scale = SNAPSHOT_WIDTH / image.shape[1]
    small = cv2.resize(image, (SNAPSHOT_WIDTH, max(1, round(image.shape[0] * scale))), interpolation=cv2.INTER_AREA)
    ok, encoded = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    return encoded.tobytes() if ok else data


def _jpeg(image: np.ndarray, width: int) -> bytes:
    if image.shape[1] > width:
        height = max(1, round(image.shape[0] * width / image.shape[1]))
        image = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return encoded.tobytes()


def crop_snapshot(image: np.ndarray, box) -> bytes | None:
    """A JPEG of ``image`` around ``box`` (x0, y0, x1, y1 pixels), padded by :data:`CROP_PAD`,
    at most :data:`CROP_WIDTH` wide; None when the box lies outside the image."""
    x0, y0, x1, y1 = (float(v) for v in box)
    half = max(x1 - x0, y1 - y0, MIN_CROP / (1 + 2 * CROP_PAD)) * (0.5 + CROP_PAD)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    h, w = image.shape[:2]
    left, right = max(0, int(cx - half)), min(w, int(np.ceil(cx + half)) + 1)
    top, bottom = max(0, int(cy - half)), min(h, int(np.ceil(cy + half)) + 1)
    if right <= left or bottom <= top:
        return None
    return _jpeg(image[top:bottom, left:right], CROP_WIDTH)


def _decoded(data: bytes) -> np.ndarray | None:
    if not data.startswith((PNG_MAGIC, JPEG_MAGIC)):
        return None
    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)


def _shared_name(shared: SharedPicture, data: bytes) -> str:
    return shared.name + (".jpg" if data.startswith(JPEG_MAGIC) else ".png")


def _header(root, ifc_file: str) -> None:
    header = ET.SubElement(root, "Header")
    file = ET.SubElement(header, "File", isExternal="true")
    _text(file, "Filename", ifc_file)


def markup_xml(topic: BcfTopic, shared_entry: str = "") -> bytes:
    """``markup.bcf``; ``shared_entry``: the root entry of ``topic.shared`` ("" for none)."""
    root = ET.Element("Markup")
    if topic.ifc_file:
        _header(root, topic.ifc_file)
    t = ET.SubElement(
        root, "Topic", Guid=topic.guid, TopicType=shown(topic.topic_type), TopicStatus=shown(topic.status)
    )
    _text(t, "Title", topic.title)
    if topic.priority:
        _text(t, "Priority", topic.priority)
    for label in topic.labels:
        _text(t, "Labels", label)
    _text(t, "CreationDate", _date(topic.created))
    _text(t, "CreationAuthor", topic.author)
    if topic.modified is not None:
        _text(t, "ModifiedDate", _date(topic.modified))
        _text(t, "ModifiedAuthor", topic.modified_author or topic.author)
    if topic.description:
        _text(t, "Description", topic.description)
    if topic.shared is not None and shared_entry:
        # the shared picture at the zip's root, one folder up from the topic's
        reference = ET.SubElement(t, "DocumentReference", isExternal="false")
        _text(reference, "ReferencedDocument", "../" + shared_entry)
        _text(reference, "Description", topic.shared.description)
    for comment in topic.comments:
        c = ET.SubElement(root, "Comment", Guid=comment.guid)
        _text(c, "Date", _date(comment.date))
        _text(c, "Author", comment.author)
        _text(c, "Comment", comment.text)
    if topic.viewpoint_guid:
        v = ET.SubElement(root, "Viewpoints", Guid=topic.viewpoint_guid)
        _text(v, "Viewpoint", VIEWPOINT)
        if topic.snapshot_png is not None:
            _text(v, "Snapshot", snapshot_name(topic.snapshot_png))
    return _xml(root)


def _vector(parent, tag: str, values) -> None:
    element = ET.SubElement(parent, tag)
    for axis, value in zip("XYZ", values):
        _text(element, axis, repr(float(value)))


def _camera(parent, camera: BcfCamera) -> None:
    c = ET.SubElement(parent, "PerspectiveCamera")
    _vector(c, "CameraViewPoint", camera.viewpoint)
    _vector(c, "CameraDirection", camera.direction)
    _vector(c, "CameraUpVector", camera.up)
    _text(c, "FieldOfView", repr(float(camera.field_of_view)))


def visinfo_xml(topic: BcfTopic) -> bytes:
    root = ET.Element("VisualizationInfo", Guid=topic.viewpoint_guid)
    components = ET.SubElement(root, "Components")
    if topic.components:
        selection = ET.SubElement(components, "Selection")
        for comp in topic.components:
            e = ET.SubElement(selection, "Component", **({"IfcGuid": shown(comp.ifc_guid)} if comp.ifc_guid else {}))
            _text(e, "OriginatingSystem", "mrcheck")
            _text(e, "AuthoringToolId", comp.tool_id)
    ET.SubElement(components, "Visibility", DefaultVisibility="true")
    if topic.camera is not None:
        _camera(root, topic.camera)
    return _xml(root)


def version_xml() -> bytes:
    root = ET.Element("Version", VersionId=VERSION)
    _text(root, "DetailedVersion", VERSION)
    return _xml(root)


def project_xml(name: str, project_id: str) -> bytes:
    root = ET.Element("ProjectExtension")
    project = ET.SubElement(root, "Project", ProjectId=shown(project_id))
    _text(project, "Name", name)
    ET.SubElement(root, "ExtensionSchema")
    return _xml(root)


def _add(archive: zipfile.ZipFile, name: str, data: bytes, compress: bool = True) -> None:
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    archive.writestr(zipfile.ZipInfo(name, ZIP_TIME), data, compress_type=method)


def _shared_entries(archive: zipfile.ZipFile, topics: list[BcfTopic]) -> dict[int, tuple[str, np.ndarray | None]]:
    """Every shared picture of ``topics`` written once at the root, downscaled
    and as JPEG: id -> (its entry name, the full-size image to crop from)."""
    entries: dict[int, tuple[str, np.ndarray | None]] = {}
    for shared in {id(t.shared): t.shared for t in topics if t.shared is not None}.values():
        image = _decoded(shared.data)
        # JPEG even when narrow enough: a heat map's PNG is some 400 kB, its JPEG a sixth of that
        small = shared.data if image is None else _jpeg(image, SNAPSHOT_WIDTH)
        name = _shared_name(shared, small)
        _add(archive, name, small, compress=False)
        entries[id(shared)] = (name, image)
    return entries


def bcf_bytes(topics: list[BcfTopic], project: str = "mrcheck") -> bytes:
    """The ``.bcfzip`` of ``topics``. A topic with a camera or components gets a viewpoint (its
    ``viewpoint_guid``, made from the topic's when None); snapshots at most
    :data:`SNAPSHOT_WIDTH` wide (:func:`small_snapshot`, once per shared snapshot); a topic's
    shared picture once at the root, its snapshot a crop of it (:func:`crop_snapshot`)."""
    small: dict[int, tuple[bytes, bytes]] = {}  # id of a snapshot -> (it, kept alive; its small copy)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        _add(archive, "bcf.version", version_xml())
        _add(
            archive,
            "project.bcfp",
            project_xml(project, str(uuid.uuid5(uuid.NAMESPACE_URL, "mrcheck:" + shown(project)))),
        )
        shared = _shared_entries(archive, topics)
        for topic in topics:
            if topic.viewpoint_guid is None and (topic.camera is not None or topic.components):
                topic.viewpoint_guid = str(uuid.uuid5(uuid.UUID(topic.guid), "viewpoint"))
            entry, image = shared.get(id(topic.shared), ("", None))
            if image is not None and topic.box is not None and topic.snapshot_png is None:
                topic = replace(topic, snapshot_png=crop_snapshot(image, topic.box))
            elif topic.snapshot_png is not None:
                if id(topic.snapshot_png) not in small:
                    small[id(topic.snapshot_png)] = (topic.snapshot_png, small_snapshot(topic.snapshot_png))
                topic = replace(topic, snapshot_png=small[id(topic.snapshot_png)][1])
            _add(archive, f"{topic.guid}/markup.bcf", markup_xml(topic, entry))
            if topic.viewpoint_guid:
                _add(archive, f"{topic.guid}/{VIEWPOINT}", visinfo_xml(topic))
                if topic.snapshot_png is not None:
                    # stored: PNG and JPEG are compressed already (deflating again took 8 s for 218 topics)
                    name = snapshot_name(topic.snapshot_png)
                    _add(archive, f"{topic.guid}/{name}", topic.snapshot_png, compress=False)
    return buffer.getvalue()


__all__ = [
    "bcf_bytes",
    "markup_xml",
    "visinfo_xml",
    "version_xml",
    "project_xml",
    "VERSION",
    "SNAPSHOT_WIDTH",
    "small_snapshot",
    "crop_snapshot",
    "CROP_WIDTH",
]
