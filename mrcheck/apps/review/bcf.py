"""The review's markers as BCF 2.1 and back (``/api/bcf``): one topic per marker (title from
category and the part's name, priority from severity, description = note, the part's IFC
GlobalId where the scene has one, the shot's camera, the photo with the marker as a snapshot
:data:`SNAPSHOT_WIDTH` wide, the marker's creation and change times, the review's author, the
IFC file the scene came from). Importing a BCF file (2.x or 3.0) another tool changed matches
its topics to the markers by Guid (the marker's own, random and kept in the database:
:meth:`.storage.Store.guids`): their status is set, their comments are added to the marker's
(an import never removes one), a changed priority becomes the marker's severity. A topic of no
marker becomes a marker where its viewpoint or element is seen (:mod:`.bcf_place`).

An import is refused, with its reason and nothing changed, when the file is over the limits of
:mod:`mrcheck.apps.bcf.archive` and :mod:`mrcheck.apps.bcf.read`, holds a topic twice, or a
comment longer than a note (:data:`.storage.MAX_NOTE`), more than :data:`MAX_COMMENTS` comments
on a topic, or a status or author longer than :data:`MAX_FIELD` characters (every marker list
would carry them)."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone

import cv2
import numpy as np

from mrcheck.apps.bcf import (
    BcfComment,
    BcfTopic,
    Finding,
    bcf_bytes,
    element_label,
    finding_topic,
    read_bcf_file,
    severity_of,
)
from mrcheck.apps.bcf.write import JPEG_QUALITY, SNAPSHOT_WIDTH
from mrcheck.apps.review.bcf_place import place_topic
from mrcheck.apps.review.measure import offset_line
from mrcheck.apps.review.storage import DEFAULT_STATUS, MAX_NOTE, BcfChange, BcfMarker
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, read_image

MAX_COMMENTS = 200  # on one topic: 400 kB of comments at most on every marker list
MAX_FIELD = 200  # characters of a status or a comment's author
UPLOADED = "the uploaded BCF file"


def _snapshot(shot, marker: dict, max_pixels: int) -> bytes | None:
    """The shot's photo with a ring at the marker, at most SNAPSHOT_WIDTH wide, as JPEG (of a
    2400x1800 photo some 95 kB, where a 1024 px PNG was 1.4 MB)."""
    try:
        photo = read_image(shot.photo, "photo", max_pixels=max_pixels)
    except MrcheckError:  # a photo gone since start-up: the topic goes without a snapshot
        return None
    scale = min(1.0, SNAPSHOT_WIDTH / photo.shape[1])
    image = cv2.resize(photo, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) if scale < 1.0 else photo.copy()
    centre = (int(round(marker["x"] * scale)), int(round(marker["y"] * scale)))
    cv2.circle(image, centre, max(8, image.shape[1] // 60), (255, 0, 0), 3)
    return encode_image(".jpg", np.ascontiguousarray(image), quality=JPEG_QUALITY)


def _time(seconds: float) -> datetime:
    return datetime.fromtimestamp(seconds, timezone.utc).replace(microsecond=0)


def _finding(m: dict, guid: str) -> Finding:
    """The marker as a finding: created when it was made, modified when changed since (told from
    the stored times, not the whole seconds BCF writes: a change within the first second counts)."""
    created, updated = _time(m["created"]), _time(m["updated"])
    return Finding(
        guid,
        m["category"],
        m["severity"],
        "\n".join(filter(None, [m["note"], offset_line(m["offset"]) if m["offset"] else ""])),
        m["part"],
        m["shot"],
        created,
        updated if m["updated"] > m["created"] else None,
    )


def _comments(state: dict) -> list:
    return [
        BcfComment(c["guid"], datetime.fromisoformat(c["date"]) if c.get("date") else None, c["author"], c["text"])
        for c in state.get("comments", [])
    ]


def export_bcf(review) -> bytes:
    """The ``.bcfzip`` of every marker of the review."""
    states, guids = review.store.bcf_states(), review.store.guids()
    topics = []
    for m in review.store.markers():
        shot = review.source.shots.get(m["shot"])
        state = states.get(m["id"], {})
        topics.append(
            finding_topic(
                _finding(m, guids[m["id"]]),
                review.source.loaded,
                shot.camera if shot else None,
                _snapshot(shot, m, review.source.max_pixels) if shot else None,
                state.get("status", DEFAULT_STATUS),
                _comments(state),
                review.author,
            )
        )
    return bcf_bytes(topics, project=review.source.label)


@dataclass
class BcfImport:
    """What an import changed: markers matched, markers added for topics another tool made, and
    topics neither (no shot sees their viewpoint or element)."""

    matched: int
    added: int
    unknown: int

    def to_dict(self) -> dict:
        return {"matched": self.matched, "added": self.added, "unknown": self.unknown}


def _check_topic(topic: BcfTopic) -> None:
    """A topic whose comments, status or authors are over the limits (see the module): refused."""

    def refuse(problem: str):
        raise MrcheckError(f"topic {topic.guid} ({topic.title[:60]!r}): {problem}", UPLOADED)

    if len(topic.comments) > MAX_COMMENTS:
        refuse(f"{len(topic.comments)} comments (at most {MAX_COMMENTS})")
    if len(topic.status) > MAX_FIELD:
        refuse(f"a status of {len(topic.status)} characters (at most {MAX_FIELD})")
    for c in topic.comments:
        if len(c.text) > MAX_NOTE:
            refuse(f"a comment of {len(c.text)} characters (at most {MAX_NOTE}, as a note)")
        if len(c.author) > MAX_FIELD:
            refuse(f"a comment's author of {len(c.author)} characters (at most {MAX_FIELD})")


def _unique(topics: list[BcfTopic]) -> None:
    """Each topic once: two topics of one GUID would both be matched to its marker."""
    seen = set()
    for topic in topics:
        if topic.guid in seen:
            raise MrcheckError(
                f"the topic {topic.guid} is in the file twice (a BCF file has each topic once)", UPLOADED
            )
        seen.add(topic.guid)


def _stored(comments: list) -> list:
    return [
        {"guid": c.guid, "date": c.date.isoformat() if c.date else "", "author": c.author, "text": c.text}
        for c in comments
    ]


def _new_marker(review, topic: BcfTopic) -> BcfMarker | None:
    """The marker of a topic another tool made, where :func:`.bcf_place.place_topic` puts it;
    the part under it picked as for a marker placed here when the topic selects none."""
    place = place_topic(review.source.shots, review.source.loaded, topic)
    if place is None:
        return None
    cad = {"part": place.part, "distance": None}
    if place.part is None:
        cad = review.cad_under(review.source.shots[place.shot], place.x, place.y)
    note = topic.title + (f": {topic.description}" if topic.description else "")
    values = {
        "shot": place.shot,
        "x": place.x,
        "y": place.y,
        "category": "other",
        "severity": severity_of(topic.priority) or 2,
        "note": note[:MAX_NOTE],
        **cad,
    }
    created = topic.created.timestamp() if topic.created else None
    return BcfMarker(values, topic.guid, topic.status or DEFAULT_STATUS, _stored(topic.comments), created)


def import_bcf(review, file) -> BcfImport:
    """Statuses, comments and priorities of the ``.bcfzip`` in the binary file object ``file``
    onto the markers whose topics it holds, and markers for the topics another tool made:
    every topic checked first, then one transaction."""
    topics = read_bcf_file(file, UPLOADED)
    _unique(topics)
    for topic in topics:
        _check_topic(topic)
    by_guid = {guid: marker for marker, guid in review.store.guids().items()}
    changes = [
        BcfChange(by_guid[t.guid], t.status or DEFAULT_STATUS, _stored(t.comments), severity_of(t.priority))
        for t in topics
        if t.guid in by_guid
    ]
    new = [m for t in topics if t.guid not in by_guid and (m := _new_marker(review, t)) is not None]
    review.store.apply_bcf(changes, new)
    return BcfImport(len(changes), len(new), len(topics) - len(changes) - len(new))


def with_bcf_state(review, markers: list) -> list:
    """The markers with their BCF ``status`` and ``comments`` (Open and none until one is set)
    and ``part_label``, their part as a person reads it (:func:`element_label`: the element's
    name, class and storey; ``part`` keeps the id, an IFC GlobalId)."""
    states = review.store.bcf_states()
    return [
        {
            **m,
            "part_label": element_label(review.source.loaded, m["part"]),
            "status": states.get(m["id"], {}).get("status", DEFAULT_STATUS),
            "comments": states.get(m["id"], {}).get("comments", []),
        }
        for m in markers
    ]


__all__ = ["export_bcf", "import_bcf", "with_bcf_state", "BcfImport", "MAX_COMMENTS", "MAX_FIELD"]
