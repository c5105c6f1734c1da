"""Topics back from a ``.bcfzip``, BCF 2.0, 2.1 and 3.0: the topic's status, priority, title,
description, labels, dates, every comment, the IFC file of its header, its first viewpoint's
camera and components. The versions differ in where they keep these: 2.x has the comments and
viewpoints beside the topic (``Markup/Comment``, ``Markup/Viewpoints``), the header's files
and the labels directly (``Header/File``, ``Topic/Labels``); 3.0 nests them
(``Topic/Comments/Comment``, ``Topic/Viewpoints/ViewPoint``, ``Header/Files/File``,
``Topic/Labels/Label``). Both are read, whichever a file holds.
A file that is no zip, a topic without a readable ``markup.bcf``, and a file over the limits of
:mod:`.archive` (or of :data:`MAX_TOPICS` topics, XML entries of :data:`MAX_XML` bytes) is a
one-line error. Snapshots are read only when asked for (``snapshots=True``)."""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
from datetime import datetime
from pathlib import Path

from mrcheck.apps.bcf.archive import BcfArchive
from mrcheck.apps.bcf.model import BcfCamera, BcfComment, BcfComponent, BcfTopic
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input

MAX_SNAPSHOT = 64 << 20  # bytes: a larger snapshot is refused
MAX_XML = 16 << 20  # bytes of one markup or viewpoint: a topic's hundreds of comments fit in 1 MB
MAX_TOPICS = 5000  # topics read from one file


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


def _xml(archive: BcfArchive, name: str):
    try:
        return ET.fromstring(archive.read(name, MAX_XML))
    except ET.ParseError as exc:
        raise MrcheckError(f"malformed BCF entry {name} ({exc})", archive.path) from None


def _viewpoint(topic: BcfTopic, markup, archive: BcfArchive, folder: str, snapshots: bool) -> None:
    view = markup.find("Viewpoints")  # 2.x
    if view is None:
        view = markup.find("Topic/Viewpoints/ViewPoint")  # 3.0
    if view is None:
        return
    topic.viewpoint_guid = view.get("Guid")
    names = archive.infos
    visinfo = folder + (_child(view, "Viewpoint") or "viewpoint.bcfv")
    if visinfo in names:
        root = _xml(archive, visinfo)
        try:
            topic.camera = _camera(root)
        except (TypeError, ValueError):
            topic.camera = None  # a camera another tool wrote without numbers: none
        topic.components = _components(root)
    snapshot = folder + _child(view, "Snapshot")
    if snapshots and _child(view, "Snapshot") and snapshot in names:
        topic.snapshot_png = archive.read(snapshot, MAX_SNAPSHOT)


def _topic(archive: BcfArchive, name: str, snapshots: bool) -> BcfTopic:
    markup = _xml(archive, name)
    node = markup.find("Topic")
    if node is None or not node.get("Guid"):
        raise MrcheckError(f"BCF entry {name} has no Topic with a Guid", archive.path)
    topic = BcfTopic(
        guid=node.get("Guid"),
        title=_child(node, "Title"),
        status=node.get("TopicStatus", ""),
        priority=_child(node, "Priority"),
        description=_child(node, "Description"),
        topic_type=node.get("TopicType", ""),
        labels=[t for e in node.findall("Labels") + node.findall("Labels/Label") if (t := (e.text or "").strip())],
        created=_date(_child(node, "CreationDate")),
        author=_child(node, "CreationAuthor"),
        modified=_date(_child(node, "ModifiedDate")),
        modified_author=_child(node, "ModifiedAuthor"),
    )
    topic.comments = [
        BcfComment(c.get("Guid", ""), _date(_child(c, "Date")), _child(c, "Author"), _child(c, "Comment"))
        for c in markup.findall("Comment") + markup.findall("Topic/Comments/Comment")
    ]
    files = markup.findall("Header/File") + markup.findall("Header/Files/File")
    topic.ifc_file = next((_child(f, "Filename") for f in files if _child(f, "Filename")), "")
    _viewpoint(topic, markup, archive, name[: -len("markup.bcf")], snapshots)
    return topic


def read_bcf_file(file, path="the BCF file", snapshots: bool = False) -> list[BcfTopic]:
    """The topics of a ``.bcfzip`` in the binary file object ``file``, in the archive's order;
    their ``snapshot_png`` only with ``snapshots``."""
    with BcfArchive(file, path) as archive:
        names = [n for n in archive.names() if n.endswith("/markup.bcf") and n.count("/") == 1]
        if not names and "bcf.version" not in archive.infos:
            raise MrcheckError("not a BCF file (no bcf.version and no topic folders)", path)
        if len(names) > MAX_TOPICS:
            raise MrcheckError(f"BCF file has {len(names)} topics (at most {MAX_TOPICS} are read)", path)
        return [_topic(archive, name, snapshots) for name in names]


def read_bcf_bytes(data: bytes, path="the BCF file", snapshots: bool = True) -> list[BcfTopic]:
    """The topics of a ``.bcfzip``'s bytes, with their snapshots (``snapshots``)."""
    return read_bcf_file(io.BytesIO(data), path, snapshots)


def read_bcf(path, snapshots: bool = True) -> list[BcfTopic]:
    """The topics of the ``.bcfzip`` at ``path``."""
    path = Path(path)
    return read_bcf_bytes(read_input(path, "BCF file"), path, snapshots)


__all__ = ["read_bcf", "read_bcf_bytes", "read_bcf_file", "MAX_TOPICS", "MAX_XML"]
