"""The written tables of ``mrcheck regress diff``: ``changes.csv`` and ``changes.json`` (every
element with its kind) and ``changes.bcfzip`` (one BCF 2.1 topic per change, through
:mod:`mrcheck.apps.bcf`)."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import asdict

from mrcheck.apps.bcf import BcfComponent, BcfTopic, SharedPicture, bcf_bytes, bcf_camera, topic_guid
from mrcheck.apps.modeldiff.compare import ModelDiff

CHANGES_CSV, CHANGES_JSON, CHANGES_BCF = "changes.csv", "changes.json", "changes.bcfzip"
CSV_FIELDS = (
    "id",
    "ifc_globalid",
    "kind",
    "label",
    "part_old",
    "part_new",
    "offset_x_m",
    "offset_y_m",
    "offset_z_m",
    "distance_m",
    "rotation_deg",
    "axis_x",
    "axis_y",
    "axis_z",
    "old_x",
    "old_y",
    "old_z",
    "new_x",
    "new_y",
    "new_z",
)
PRIORITY = {"removed": "High", "added": "Normal", "moved": "Normal", "changed geometry": "Normal"}


def changes_json(diff: ModelDiff, views: dict) -> str:
    """The revisions, tolerances, counts, every row and, per view, the changes it shows."""
    data = {
        "old": diff.old,
        "new": diff.new,
        "tolerance_m": diff.tolerance_m,
        "tolerance_deg": diff.tolerance_deg,
        "counts": diff.counts,
        "views": views,
        "elements": [asdict(r) | {"distance_m": r.distance_m} for r in diff.rows],
    }
    return json.dumps(data, indent=2, ensure_ascii=False) + "\n"


def changes_csv(diff: ModelDiff) -> str:
    """One line per element, changes first; empty cells where a figure does not apply."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_FIELDS)
    none3 = (None, None, None)
    for r in diff.rows:
        distance = None if r.distance_m is None else round(r.distance_m, 6)
        values = (
            r.id,
            r.global_id,
            r.kind,
            r.label,
            r.part_old,
            r.part_new,
            *(r.offset_m or none3),
            distance,
            r.rotation_deg,
            *(r.axis or none3),
            *(r.old_centre or none3),
            *(r.new_centre or none3),
        )
        writer.writerow(["" if v is None else v for v in values])
    return buffer.getvalue()


def _description(change) -> str:
    text = f"{change.kind}: {change.label} (id {change.id})"
    if change.kind == "moved":
        offset = ", ".join(f"{v:+.3f}" for v in change.offset_m)
        text += f"; offset ({offset}) m, {change.distance_m:.3f} m; rotation {change.rotation_deg:.2f} deg"
    if change.kind == "changed geometry":
        text += f"; size {_size(change.size_old_m)} m -> {_size(change.size_new_m)} m"
    return text + "."


def _size(size) -> str:
    return " x ".join(f"{v:.3f}" for v in size)


def change_topics(
    diff: ModelDiff, pictures, pngs: dict, key: str, project_ifc: str = "", author: str = "mrcheck"
) -> list:
    """One topic per change, in the diff's order. Its viewpoint and snapshot are the first of
    ``pictures`` (:class:`~mrcheck.apps.modeldiff.picture.ViewPicture`, their PNG bytes in
    ``pngs`` by view name) that shows it: the view's picture is shared, the snapshot a crop
    around the change; a change no view shows has neither. ``key`` (the output folder) keeps
    topic ids stable."""
    shared = {
        p.name: SharedPicture(f"view-{p.name}", pngs[p.name], f"the changes seen from {p.name}") for p in pictures
    }
    topics = []
    for change in diff.changes:
        picture = next((p for p in pictures if change.id in p.boxes), None)
        topics.append(
            BcfTopic(
                guid=topic_guid("regress diff", key, change.id),
                title=f"{change.kind}: {change.label}",
                author=author,
                ifc_file=project_ifc,
                priority=PRIORITY[change.kind],
                description=_description(change),
                labels=["model diff", change.kind],
                components=[BcfComponent(change.global_id, change.id)],
                camera=None if picture is None else bcf_camera(picture.camera),
                shared=None if picture is None else shared[picture.name],
                box=None if picture is None else picture.boxes[change.id],
            )
        )
    return topics


def changes_bcf(diff: ModelDiff, pictures, pngs: dict, key: str, project: str, project_ifc: str = "") -> bytes:
    return bcf_bytes(change_topics(diff, pictures, pngs, key, project_ifc), project=project)


__all__ = ["changes_csv", "changes_json", "change_topics", "changes_bcf", "CHANGES_CSV", "CHANGES_JSON", "CHANGES_BCF"]
