"""The BCF topic of one finding (a review marker, a discrepancy suspect): title, status,
priority from the severity, description = the note, the element as a component, the shot's
camera and a snapshot; its dates and author, and the IFC file the scene came from."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

from mrcheck.apps.bcf.findings import bcf_camera, element_component, element_label, ifc_file_of, priority
from mrcheck.apps.bcf.model import BcfTopic


@dataclass(frozen=True)
class Finding:
    """What every mrcheck finding has (the review's markers and the detector's suggestions).
    ``created`` / ``modified``: when it was made and last changed (None: now / never)."""

    guid: str
    category: str  # missing, moved, extra, wrong size, other, suggested
    severity: int  # 1..3
    note: str
    part: str | None  # the instance id, None for a region of the photo
    shot: str = ""
    created: datetime | None = None
    modified: datetime | None = None


def finding_title(finding: Finding, scene=None) -> str:
    """ "moved: Basic Wall:Interior 138mm (IfcWallStandardCase, Level 1) (p1)": the element by
    its name where the scene knows it (:func:`element_label`), the GlobalId in the component."""
    what = element_label(scene, finding.part) or "unexplained structure"
    return f"{finding.category}: {what}" + (f" ({finding.shot})" if finding.shot else "")


def finding_topic(
    finding: Finding,
    scene=None,
    camera=None,
    snapshot_png: bytes | None = None,
    status: str = "Open",
    comments=(),
    author: str = "mrcheck",
) -> BcfTopic:
    """The topic of ``finding``; ``camera`` the shot's, ``snapshot_png`` its picture (PNG or
    JPEG), ``author`` who made it (the ``--author`` of the command)."""
    return BcfTopic(
        guid=finding.guid,
        title=finding_title(finding, scene),
        status=status,
        priority=priority(finding.severity),
        description=finding.note,
        labels=[finding.category],
        created=finding.created,
        author=author,
        modified=finding.modified,
        modified_author=author if finding.modified is not None else "",
        components=element_component(scene, finding.part),
        camera=None if camera is None else bcf_camera(camera),
        snapshot_png=snapshot_png,
        comments=list(comments),
        ifc_file=ifc_file_of(scene) if scene is not None else "",
    )


__all__ = ["Finding", "finding_topic", "finding_title"]
