"""The review's markers as BCF 2.1 and back (``/api/bcf``): one topic per marker (title from
category and part, priority from severity, description = note, the part's IFC GlobalId where
the scene has one, the shot's camera, the photo with the marker as snapshot). Importing a BCF
file another tool changed matches its topics to the markers by Guid (the marker's own, random
and kept in the database: :meth:`.storage.Store.guids`) and shows their status and comments on
the markers; a changed priority becomes the marker's severity.

An import is refused, with its reason and nothing changed, when the file is over the limits of
:mod:`mrcheck.apps.bcf.archive` and :mod:`mrcheck.apps.bcf.read`, holds a topic twice, or a
comment longer than a note (:data:`.storage.MAX_NOTE`), more than :data:`MAX_COMMENTS` comments
on a topic, or a status or author longer than :data:`MAX_FIELD` characters (every marker list
would carry them)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.bcf import BcfComment, BcfTopic, Finding, bcf_bytes, finding_topic, read_bcf_file, severity_of
from mrcheck.apps.review.storage import MAX_NOTE, BcfChange
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, read_image

SNAPSHOT_WIDTH = 1024
DEFAULT_STATUS = "Open"
MAX_COMMENTS = 200  # on one topic: 400 kB of comments at most on every marker list
MAX_FIELD = 200  # characters of a status or a comment's author
UPLOADED = "the uploaded BCF file"


def _snapshot(shot, marker: dict, max_pixels: int) -> bytes | None:
    """The shot's photo with a ring at the marker, at most SNAPSHOT_WIDTH wide."""
    try:
        photo = read_image(shot.photo, "photo", max_pixels=max_pixels)
    except MrcheckError:  # a photo gone since start-up: the topic goes without a snapshot
        return None
    scale = min(1.0, SNAPSHOT_WIDTH / photo.shape[1])
    image = cv2.resize(photo, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) if scale < 1.0 else photo.copy()
    centre = (int(round(marker["x"] * scale)), int(round(marker["y"] * scale)))
    cv2.circle(image, centre, max(8, image.shape[1] // 60), (255, 0, 0), 3)
    return encode_image(".png", np.ascontiguousarray(image))


def _comments(state: dict) -> list:
    from datetime import datetime

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
        finding = Finding(guids[m["id"]], m["category"], m["severity"], m["note"], m["part"], m["shot"])
        topics.append(
            finding_topic(
                finding,
                review.source.loaded,
                shot.camera if shot else None,
                _snapshot(shot, m, review.source.max_pixels) if shot else None,
                state.get("status", DEFAULT_STATUS),
                _comments(state),
            )
        )
    return bcf_bytes(topics, project=review.source.label)


@dataclass
class BcfImport:
    """What an import changed: markers matched, and topics of no marker of this review."""

    matched: int
    unknown: int

    def to_dict(self) -> dict:
        return {"matched": self.matched, "unknown": self.unknown}


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


def import_bcf(review, file) -> BcfImport:
    """Statuses, comments and priorities of the ``.bcfzip`` in the binary file object ``file``
    onto the markers whose topics it holds: every topic checked first, then one transaction."""
    topics = read_bcf_file(file, UPLOADED)
    _unique(topics)
    for topic in topics:
        _check_topic(topic)
    by_guid = {guid: marker for marker, guid in review.store.guids().items()}
    changes = [
        BcfChange(
            by_guid[topic.guid],
            topic.status or DEFAULT_STATUS,
            [
                {"guid": c.guid, "date": c.date.isoformat() if c.date else "", "author": c.author, "text": c.text}
                for c in topic.comments
            ],
            severity_of(topic.priority),
        )
        for topic in topics
        if topic.guid in by_guid
    ]
    review.store.set_bcf_states(changes)
    return BcfImport(len(changes), len(topics) - len(changes))


def with_bcf_state(review, markers: list) -> list:
    """The markers with their BCF ``status`` and ``comments`` (Open and none until an import)."""
    states = review.store.bcf_states()
    return [
        {
            **m,
            "status": states.get(m["id"], {}).get("status", DEFAULT_STATUS),
            "comments": states.get(m["id"], {}).get("comments", []),
        }
        for m in markers
    ]


__all__ = ["export_bcf", "import_bcf", "with_bcf_state", "BcfImport", "MAX_COMMENTS", "MAX_FIELD"]
