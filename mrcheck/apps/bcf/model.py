"""What a BCF topic holds, as mrcheck writes and reads it (BCF 2.1 markup.bcf / viewpoint.bcfv)."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime


@dataclass(frozen=True)
class BcfCamera:
    """A perspective camera (visinfo.xsd PerspectiveCamera): world metres, unit vectors, the
    vertical field of view in degrees (the shot's own: BCF 2.1's schema says 45..60 "currently",
    and that viewers should expect other values; BCF 3.0 allows 0..180)."""

    viewpoint: tuple
    direction: tuple
    up: tuple
    field_of_view: float


@dataclass(frozen=True)
class BcfComponent:
    """A selected element: its IFC GlobalId when it has one (``IfcGuid``), else None, and the
    id mrcheck knows it by (``AuthoringToolId``, with ``OriginatingSystem`` "mrcheck")."""

    ifc_guid: str | None
    tool_id: str


@dataclass(frozen=True)
class BcfComment:
    guid: str
    date: datetime | None  # None: a comment without a (readable) date
    author: str
    text: str


@dataclass(frozen=True)
class SharedPicture:
    """A picture several topics refer to (a run's heat map or status picture): stored once at the
    zip's root as ``name`` (its extension is replaced by the stored format's), each topic's
    markup refers to it (DocumentReference) and takes a crop of it as its own snapshot."""

    name: str  # "heatmap", "status": the entry's name without extension
    data: bytes  # PNG or JPEG, full size
    description: str


@dataclass
class BcfTopic:
    """One issue. ``status`` (TopicStatus) is free text in BCF 2.1: mrcheck writes "Open";
    other tools write "In Progress", "Resolved", "Closed", ... and the review shows them.
    ``snapshot_png``: the snapshot's bytes, PNG or JPEG; ``ifc_file``: the name of the IFC file
    the scene came from (the markup's Header), "" for none. ``shared`` / ``box``: a picture the
    run's topics share and the topic's pixel box in it (its snapshot is a crop around the box)."""

    guid: str
    title: str
    status: str = "Open"
    priority: str = ""
    description: str = ""
    topic_type: str = "Issue"
    labels: list = field(default_factory=list)
    created: datetime | None = None
    author: str = "mrcheck"
    modified: datetime | None = None
    modified_author: str = ""
    components: list = field(default_factory=list)  # BcfComponent
    camera: BcfCamera | None = None
    snapshot_png: bytes | None = None
    comments: list = field(default_factory=list)  # BcfComment
    viewpoint_guid: str | None = None
    ifc_file: str = ""
    shared: SharedPicture | None = None  # referenced, not copied: see write.bcf_bytes
    box: tuple | None = None  # (x0, y0, x1, y1) pixels of what the topic is about in ``shared``


__all__ = ["SharedPicture", "BcfTopic", "BcfComment", "BcfCamera", "BcfComponent"]
