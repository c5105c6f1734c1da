"""The review's markers as BCF 2.1 and back (``/api/bcf``): one topic per marker (title from
category and part, priority from severity, description = note, the part's IFC GlobalId where
the scene has one, the shot's camera, the photo with the marker as snapshot). Importing a BCF
file another tool changed matches its topics to the markers by Guid (stable: made from the
review database and marker id) and shows their status and comments on the markers; a changed
priority becomes the marker's severity."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.bcf import BcfComment, Finding, bcf_bytes, finding_topic, read_bcf_bytes, severity_of, topic_guid
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, read_image

SNAPSHOT_WIDTH = 1024
DEFAULT_STATUS = "Open"


def marker_guid(review, marker_id: int) -> str:
    return topic_guid("review", review.store.path.resolve(), review.store.review, marker_id)


def _snapshot(shot, marker: dict) -> bytes | None:
    """The shot's photo with a ring at the marker, at most SNAPSHOT_WIDTH wide."""
    try:
        photo = read_image(shot.photo, "photo")
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
    states = review.store.bcf_states()
    topics = []
    for m in review.store.markers():
        shot = review.source.shots.get(m["shot"])
        state = states.get(m["id"], {})
        finding = Finding(marker_guid(review, m["id"]), m["category"], m["severity"], m["note"], m["part"], m["shot"])
        topics.append(
            finding_topic(
                finding,
                review.source.loaded,
                shot.camera if shot else None,
                _snapshot(shot, m) if shot else None,
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


def import_bcf(review, data: bytes) -> BcfImport:
    """Statuses, comments and priorities of a ``.bcfzip`` onto the markers whose topics it holds."""
    by_guid = {marker_guid(review, m["id"]): m for m in review.store.markers()}
    matched = unknown = 0
    for topic in read_bcf_bytes(data, "the uploaded BCF file"):
        marker = by_guid.get(topic.guid)
        if marker is None:
            unknown += 1
            continue
        matched += 1
        comments = [
            {"guid": c.guid, "date": c.date.isoformat() if c.date else "", "author": c.author, "text": c.text}
            for c in topic.comments
        ]
        review.store.set_bcf_state(marker["id"], topic.status or DEFAULT_STATUS, comments)
        severity = severity_of(topic.priority)
        if severity is not None and severity != marker["severity"]:
            review.store.update(marker["id"], {"severity": severity})
    return BcfImport(matched, unknown)


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


__all__ = ["export_bcf", "import_bcf", "with_bcf_state", "marker_guid", "BcfImport"]
