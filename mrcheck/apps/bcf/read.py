"""Topics back from a ``.bcfzip`` (BCF 2.1, also what 2.0 and 3.0 files share: the topic's
status, priority, title, description, comments, first viewpoint's camera and components).
A file that is no zip, or a topic without a readable ``markup.bcf``, is a one-line error."""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
import zipfile
from datetime import datetime
from pathlib import Path

from mrcheck.apps.bcf.model import BcfCamera, BcfComment, BcfComponent, BcfTopic
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input

MAX_ENTRY = 64 << 20  # bytes: a larger entry is refused (a zip bomb, not a BCF)


def _date(text: str | None) -> datetime | None:
    if not text:
        return None
    try:
        return datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        return None


def _child(element, tag: str) -> str:
    found = element.find(tag) if element is not None else None
    return (found.text or "").strip() if found is not None else ""


def _vector(element, tag: str) -> tuple:
    node = element.find(tag)
    return tuple(float(_child(node, axis)) for axis in "XYZ")


def _camera(root) -> BcfCamera | None:
    node = root.find("PerspectiveCamera")
    if node is None:
        return None
    return BcfCamera(
        _vector(node, "CameraViewPoint"),
        _vector(node, "CameraDirection"),
        _vector(node, "CameraUpVector"),
        float(_child(node, "FieldOfView")),
    )


def _components(root) -> list[BcfComponent]:
    return [
        BcfComponent(c.get("IfcGuid"), _child(c, "AuthoringToolId"))
        for c in root.findall("Components/Selection/Component")
    ]


def _entry(archive: zipfile.ZipFile, name: str, path) -> bytes:
    info = archive.getinfo(name)
    if info.file_size > MAX_ENTRY:
        raise MrcheckError(f"BCF entry {name} is {info.file_size} bytes (more than {MAX_ENTRY})", path)
    return archive.read(name)


def _xml(archive, name: str, path):
    try:
        return ET.fromstring(_entry(archive, name, path))
    except ET.ParseError as exc:
        raise MrcheckError(f"malformed BCF entry {name} ({exc})", path) from None


def _viewpoint(topic: BcfTopic, markup, archive, folder: str, path) -> None:
    view = markup.find("Viewpoints")
    if view is None:
        return
    topic.viewpoint_guid = view.get("Guid")
    names = set(archive.namelist())
    visinfo = folder + (_child(view, "Viewpoint") or "viewpoint.bcfv")
    if visinfo in names:
        root = _xml(archive, visinfo, path)
        try:
            topic.camera = _camera(root)
        except (TypeError, ValueError):
            topic.camera = None  # a camera another tool wrote without numbers: none
        topic.components = _components(root)
    snapshot = folder + _child(view, "Snapshot")
    if _child(view, "Snapshot") and snapshot in names:
        topic.snapshot_png = _entry(archive, snapshot, path)


def _topic(archive, name: str, path) -> BcfTopic:
    markup = _xml(archive, name, path)
    node = markup.find("Topic")
    if node is None or not node.get("Guid"):
        raise MrcheckError(f"BCF entry {name} has no Topic with a Guid", path)
    topic = BcfTopic(
        guid=node.get("Guid"),
        title=_child(node, "Title"),
        status=node.get("TopicStatus", ""),
        priority=_child(node, "Priority"),
        description=_child(node, "Description"),
        topic_type=node.get("TopicType", ""),
        labels=[(e.text or "").strip() for e in node.findall("Labels")],
        created=_date(_child(node, "CreationDate")),
        author=_child(node, "CreationAuthor"),
        modified=_date(_child(node, "ModifiedDate")),
        modified_author=_child(node, "ModifiedAuthor"),
    )
    topic.comments = [
        BcfComment(c.get("Guid", ""), _date(_child(c, "Date")), _child(c, "Author"), _child(c, "Comment"))
        for c in markup.findall("Comment")
    ]
    _viewpoint(topic, markup, archive, name[: -len("markup.bcf")], path)
    return topic


def read_bcf_bytes(data: bytes, path="the BCF file") -> list[BcfTopic]:
    """The topics of a ``.bcfzip``'s bytes, in the archive's order."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
    except zipfile.BadZipFile:
        raise MrcheckError("not a BCF file (.bcfzip is a zip archive)", path) from None
    with archive:
        names = [n for n in archive.namelist() if n.endswith("/markup.bcf") and n.count("/") == 1]
        if not names and "bcf.version" not in archive.namelist():
            raise MrcheckError("not a BCF file (no bcf.version and no topic folders)", path)
        return [_topic(archive, name, path) for name in names]


def read_bcf(path) -> list[BcfTopic]:
    """The topics of the ``.bcfzip`` at ``path``."""
    path = Path(path)
    return read_bcf_bytes(read_input(path, "BCF file"), path)


__all__ = ["read_bcf", "read_bcf_bytes"]
