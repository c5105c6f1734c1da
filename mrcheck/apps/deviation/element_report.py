"""The written per-element results of ``mrcheck deviation --per-element``: ``elements.csv``,
``elements.json`` (:class:`ElementReport`) and ``elements.bcfzip`` (one BCF topic per element
out of tolerance)."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import asdict, dataclass

from mrcheck.apps.bcf import (
    BcfTopic,
    SharedPicture,
    bcf_bytes,
    bcf_camera,
    element_component,
    element_label,
    ifc_file_of,
    topic_guid,
)
from mrcheck.apps.deviation.elements import STATUSES

ELEMENTS_CSV, ELEMENTS_JSON, ELEMENTS_PNG, ELEMENTS_BCF = (
    "elements.csv",
    "elements.json",
    "elements.png",
    "elements.bcfzip",
)
CSV_FIELDS = (
    "id",
    "ifc_globalid",
    "part",
    "status",
    "points",
    "coverage",
    "visible_samples",
    "median_mm",
    "p95_abs_mm",
    "offset_x_mm",
    "offset_y_mm",
    "offset_z_mm",
    "offset_norm_mm",
    "residual_mm",
)


@dataclass
class ElementReport:
    """``elements.json``: the settings, the counts per status and every instance's row."""

    scan: str
    scene: str
    tolerance_mm: float
    search_mm: float
    scanners: list | None  # the scanner positions coverage used (None: the open surface)
    counts: dict  # status: number of instances
    elements: list  # ElementStatus rows, scene order

    def to_dict(self) -> dict:
        return asdict(self)


def make_element_report(rows, scan, scene, tolerance_mm: float, search_mm: float, scanners) -> ElementReport:
    counts = {status: sum(r.status == status for r in rows) for status in STATUSES}
    return ElementReport(
        str(scan),
        str(scene),
        tolerance_mm,
        search_mm,
        None if scanners is None else [[round(float(v), 4) for v in s] for s in scanners],
        counts,
        rows,
    )


def elements_json(report: ElementReport) -> str:
    return json.dumps(report.to_dict(), indent=2, ensure_ascii=False) + "\n"


def elements_csv(rows) -> str:
    """One line per instance; empty cells where there is no figure."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_FIELDS)
    for r in rows:
        offset = r.offset_mm or (None, None, None)
        values = (
            r.id,
            r.ifc_globalid,
            r.part,
            r.status,
            r.points,
            r.coverage,
            r.visible_samples,
            r.median_mm,
            r.p95_abs_mm,
            *offset,
            r.offset_norm_mm,
            r.residual_mm,
        )
        writer.writerow(["" if v is None else v for v in values])
    return buffer.getvalue()


def _description(row, tolerance_mm: float) -> str:
    offset = ", ".join(f"{v:+.1f}" for v in row.offset_mm)
    return (
        f"{row.id} ({row.part}) is out of the {tolerance_mm:g} mm tolerance: estimated offset ({offset}) mm, "
        f"|offset| {row.offset_norm_mm:.1f} mm, median |residual| {row.residual_mm:.1f} mm; "
        f"{row.points} scan points, coverage {row.coverage:.0%}, median signed distance {row.median_mm:+.1f} mm."
    )


def element_topics(
    rows, scene, tolerance_mm: float, key: str, camera=None, snapshot_png=None, author: str = "mrcheck", boxes=None
) -> list[BcfTopic]:
    """One topic per element out of tolerance, worst first; priority High at 3x the tolerance or
    more, else Normal. ``key`` (the output folder) makes the topic ids stable; the title names
    the element (:func:`element_label`), the component carries its GlobalId. ``snapshot_png``,
    the status picture, is shared: once in the file, each topic's snapshot a crop of it around
    the element's box in ``boxes`` (per row, None: not seen)."""
    boxes = boxes if boxes is not None else [None] * len(rows)
    status = None if snapshot_png is None else SharedPicture("status", snapshot_png, "status picture of the elements")
    out = [(r, box) for r, box in zip(rows, boxes) if r.status == "out of tolerance"]
    out.sort(key=lambda rb: -max(rb[0].offset_norm_mm or 0.0, rb[0].residual_mm or 0.0))
    topics = []
    for r, box in out:
        worst = max(r.offset_norm_mm or 0.0, r.residual_mm or 0.0)
        topics.append(
            BcfTopic(
                guid=topic_guid("deviation", key, r.id),
                title=f"out of tolerance: {element_label(scene, r.id)}",
                author=author,
                ifc_file=ifc_file_of(scene),
                priority="High" if worst >= 3 * tolerance_mm else "Normal",
                description=_description(r, tolerance_mm),
                labels=["deviation", "out of tolerance"],
                components=element_component(scene, r.id),
                camera=None if camera is None else bcf_camera(camera),
                shared=status,
                box=box,
            )
        )
    return topics


def elements_bcf(
    rows, scene, tolerance_mm: float, key: str, camera=None, snapshot_png=None, author: str = "mrcheck", boxes=None
) -> bytes:
    topics = element_topics(rows, scene, tolerance_mm, key, camera, snapshot_png, author, boxes)
    return bcf_bytes(topics, project=scene.name)


__all__ = [
    "ElementReport",
    "make_element_report",
    "elements_json",
    "elements_csv",
    "element_topics",
    "elements_bcf",
    "ELEMENTS_CSV",
    "ELEMENTS_JSON",
    "ELEMENTS_PNG",
    "ELEMENTS_BCF",
    "CSV_FIELDS",
]
