"""The written results of a detection: ``suspects.json``, ``suspects.md`` and the console line.

``suspects.json``: ``shot``, ``scene``, ``tolerance_px``, ``threshold``, ``warnings``,
``suspects`` (every scored instance: id, part, name, score, support, best_shift_support,
best_shift, edge_pixels, thin, discriminative_score / discriminative_pixels, bbox [x0, y0, x1,
y1], centre, suspect), ``regions`` (bbox, edge_pixels) and ``suggested_markers`` for the review
tool (``mrcheck review --suggestions``).
"""

from __future__ import annotations

import json
from pathlib import Path

from mrcheck.apps.discrepancies.detector import Detection
from mrcheck.apps.discrepancies.thresholds import (
    DISCRIMINATIVE_FLOOR,
    DISCRIMINATIVE_THRESHOLD,
)

HEATMAP, SUSPECTS_JSON, SUSPECTS_MD = "heatmap.png", "suspects.json", "suspects.md"  # written into OUTDIR
SUSPECTS_BCF = "suspects.bcfzip"
OUTPUT_NAMES = (HEATMAP, SUSPECTS_JSON, SUSPECTS_MD, SUSPECTS_BCF)


def suspects_json(detection: Detection, shot, scene) -> str:
    """The text of ``suspects.json`` (the shot and the scene as absolute paths)."""
    doc = {"shot": str(Path(shot).resolve()), "scene": str(Path(scene).resolve()), **detection.to_dict()}
    return json.dumps(doc, indent=2) + "\n"


def markdown(detection: Detection, shot) -> str:
    """The text of ``suspects.md``: the suspects ranked, the warnings, the unexplained regions."""
    lines = [
        f"# Suspect parts: {shot}",
        "",
        f"Support = share of a part's visible CAD outline pixels with a photo edge of the same direction "
        f"within {detection.tolerance_px:g} px; score = 1 - support^2 / (best support of the outline "
        f"shifted); suspects score >= {detection.threshold:g}, or >= {DISCRIMINATIVE_FLOOR:g} with the same "
        f"score >= {DISCRIMINATIVE_THRESHOLD:g} on the outline the scene without the part would not show "
        f"(thin parts never).",
        "",
        "| rank | id | part | score | support | edge px | bbox (x0, y0, x1, y1) |",
        "|---|---|---|---|---|---|---|",
    ]
    flagged = detection.flagged
    for rank, s in enumerate(flagged, 1):
        lines.append(
            f"| {rank} | {s.id}{s.element_label} | {s.part} | {s.score:.2f} | {s.support:.2f} | "
            f"{s.edge_pixels} | {', '.join(map(str, s.bbox))} |"
        )
    if not flagged:
        lines.append("| - | no suspects | | | | | |")
    checked = len(detection.suspects)
    lines += ["", f"Checked {checked} part instance(s) in view; {checked - len(flagged)} supported as planned."]
    lines += [f"**Warning:** {w}" for w in detection.warnings]
    lines += ["", f"Unexplained photo structure: {len(detection.regions)} region(s).", ""]
    for r in detection.regions:
        lines.append(f"- bbox {', '.join(map(str, r.bbox))}: {r.edge_pixels} edge px")
    return "\n".join(lines) + "\n"


def summary_line(detection: Detection, labels: dict | None = None) -> str:
    """One line for the console: what was checked and what stands out; ``labels``: {instance id:
    its name, class and storey} to show instead of the id (an IFC GlobalId)."""
    flagged, labels = detection.flagged, labels or {}
    top = ", ".join(f"{labels.get(s.id, s.id)} {s.score:.2f}" for s in flagged[:5]) + (
        ", ..." if len(flagged) > 5 else ""
    )
    return (
        f"checked {len(detection.suspects)} part instance(s): {len(flagged)} suspect(s)"
        f"{f' ({top})' if flagged else ''}, {len(detection.regions)} unexplained structure region(s)"
    )


__all__ = [
    "suspects_json",
    "markdown",
    "summary_line",
    "HEATMAP",
    "SUSPECTS_JSON",
    "SUSPECTS_MD",
    "SUSPECTS_BCF",
    "OUTPUT_NAMES",
]
