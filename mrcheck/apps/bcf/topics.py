"""The BCF topic of one finding (a review marker, a discrepancy suspect): title, status,
priority from the severity, description = the note, the element as a component, the shot's
camera and a snapshot."""

from __future__ import annotations

from dataclasses import dataclass

from mrcheck.apps.bcf.findings import bcf_camera, element_component, priority
from mrcheck.apps.bcf.model import BcfTopic


@dataclass(frozen=True)
class Finding:
    """What every mrcheck finding has (the review's markers and the detector's suggestions)."""

    guid: str
    category: str  # missing, moved, extra, wrong size, other, suggested
    severity: int  # 1..3
    note: str
    part: str | None  # the instance id, None for a region of the photo
    shot: str = ""


def finding_title(finding: Finding) -> str:
    what = finding.part or "unexplained structure"
    return f"{finding.category}: {what}" + (f" ({finding.shot})" if finding.shot else "")


def finding_topic(
    finding: Finding, scene=None, camera=None, snapshot_png: bytes | None = None, status: str = "Open", comments=()
) -> BcfTopic:
    """The topic of ``finding``; ``camera`` the shot's, ``snapshot_png`` its picture."""
    return BcfTopic(
        guid=finding.guid,
        title=finding_title(finding),
        status=status,
        priority=priority(finding.severity),
        description=finding.note,
        labels=[finding.category],
        components=element_component(scene, finding.part),
        camera=None if camera is None else bcf_camera(camera),
        snapshot_png=snapshot_png,
        comments=list(comments),
    )


__all__ = ["Finding", "finding_topic", "finding_title"]
