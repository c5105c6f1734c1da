"""A ``.bcfzip`` (BCF 2.1) from :class:`~mrcheck.apps.bcf.model.BcfTopic` s: ``bcf.version``,
``project.bcfp`` and per topic ``<guid>/markup.bcf``, ``viewpoint.bcfv`` and ``snapshot.png``.
Elements in the order the schemas' sequences demand (a validator refuses any other)."""

from __future__ import annotations

import io
import uuid
import xml.etree.ElementTree as ET
import zipfile
from datetime import datetime, timezone

from mrcheck.apps.bcf.model import BcfCamera, BcfTopic

VERSION = "2.1"
VIEWPOINT, SNAPSHOT = "viewpoint.bcfv", "snapshot.png"
FOV_RANGE = (45.0, 60.0)  # visinfo.xsd (2.1): FieldOfView between 45 and 60 degrees
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


def markup_xml(topic: BcfTopic) -> bytes:
    root = ET.Element("Markup")
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
    for comment in topic.comments:
        c = ET.SubElement(root, "Comment", Guid=comment.guid)
        _text(c, "Date", _date(comment.date))
        _text(c, "Author", comment.author)
        _text(c, "Comment", comment.text)
    if topic.viewpoint_guid:
        v = ET.SubElement(root, "Viewpoints", Guid=topic.viewpoint_guid)
        _text(v, "Viewpoint", VIEWPOINT)
        if topic.snapshot_png is not None:
            _text(v, "Snapshot", SNAPSHOT)
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
    _text(c, "FieldOfView", repr(min(max(float(camera.field_of_view), FOV_RANGE[0]), FOV_RANGE[1])))


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


def bcf_bytes(topics: list[BcfTopic], project: str = "mrcheck") -> bytes:
    """The ``.bcfzip`` of ``topics``. A topic with a camera or components gets a viewpoint (its
    ``viewpoint_guid``, made from the topic's when None)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        _add(archive, "bcf.version", version_xml())
        _add(
            archive,
            "project.bcfp",
            project_xml(project, str(uuid.uuid5(uuid.NAMESPACE_URL, "mrcheck:" + shown(project)))),
        )
        for topic in topics:
            if topic.viewpoint_guid is None and (topic.camera is not None or topic.components):
                topic.viewpoint_guid = str(uuid.uuid5(uuid.UUID(topic.guid), "viewpoint"))
            _add(archive, f"{topic.guid}/markup.bcf", markup_xml(topic))
            if topic.viewpoint_guid:
                _add(archive, f"{topic.guid}/{VIEWPOINT}", visinfo_xml(topic))
                if topic.snapshot_png is not None:
                    # stored: a PNG is deflated already (deflating it again took 8 s for 218 topics)
                    _add(archive, f"{topic.guid}/{SNAPSHOT}", topic.snapshot_png, compress=False)
    return buffer.getvalue()


__all__ = ["bcf_bytes", "markup_xml", "visinfo_xml", "version_xml", "project_xml", "VERSION", "FOV_RANGE"]
