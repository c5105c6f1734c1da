"""The HTML report of ``mrcheck export``: one self-contained file, ``OUTDIR/report.html``, from
the template ``templates/report.html.j2`` (every value escaped).

Thumbnails of every shot's study sheet are inline (base64 JPEG), so the file works on its own;
links to the full-size images are relative and stay inside OUTDIR. Shots are sorted by
registration error (best first; shots without one after them, failures last).
"""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import cv2
from markupsafe import Markup

from mrcheck.apps.names import REPORT
from mrcheck.apps.templating import render
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, read_image
from mrcheck.core.output import write_text

THUMB_WIDTH = 480


def _thumbnail(path: Path) -> Markup | None:
    """The sheet at ``path`` as an inline JPEG (a data URL), at most THUMB_WIDTH wide."""
    try:
        image = read_image(path, "sheet")
    except MrcheckError:  # removed or damaged since the shot was written: the report goes without it
        return None
    if image.shape[1] > THUMB_WIDTH:
        height = max(1, round(image.shape[0] * THUMB_WIDTH / image.shape[1]))
        image = cv2.resize(image, (THUMB_WIDTH, height), interpolation=cv2.INTER_AREA)
    return Markup("data:image/jpeg;base64," + base64.b64encode(encode_image(".jpg", image, quality=80)).decode())


def sort_key(entry: dict):
    """Done/skipped by registration error (unknown after known), failures last."""
    error = entry.get("registration_error_px")
    known = isinstance(error, (int, float)) and math.isfinite(error)
    return (entry["status"] == "failed", not known, error if known else 0.0, entry["name"])


def _job_value(value) -> str:
    """A setting as the job file writes it (TOML), not as Python prints it; unset = default."""
    if value is None:
        return "(default)"
    if isinstance(value, (bool, int, float, str, list)):
        return json.dumps(value)
    return str(value)


def _shot(entry: dict, outdir: Path) -> dict:
    """What the report shows of one manifest entry."""
    registration = entry.get("registration") or {}
    outputs = entry.get("outputs", [])
    sheet = next((o for o in outputs if o.get("kind") == "sheet"), None)
    return {
        "name": entry["name"],
        "status": entry["status"],
        "error": entry.get("error") or "",
        "rms": entry.get("registration_error_px"),
        "expected": registration.get("expected_overlay_error_px"),
        "sheet": sheet and sheet["path"],
        "thumb": sheet and _thumbnail(outdir / sheet["path"]),
        "method": str(registration.get("method")),
        "rejected": ", ".join(str(r) for r in registration.get("rejected") or []),
        "warnings": registration.get("warnings") or [],
        "outputs": outputs,
        "timings": list((entry.get("timings_s") or {}).items()),
    }


def render_report(manifest: dict, outdir: Path) -> str:
    return render(
        "mrcheck.apps.export",
        "report.html.j2",
        job=manifest["job"],
        summary=manifest["summary"],
        total=manifest["timings_s"]["total"],
        executor=manifest["executor"],
        settings=[(k, _job_value(v)) for k, v in manifest["settings"].items()],
        shots=[_shot(e, outdir) for e in sorted(manifest["shots"], key=sort_key)],
    )


def write_report(manifest: dict, outdir) -> Path:
    outdir = Path(outdir)
    path = outdir / REPORT
    write_text(path, render_report(manifest, outdir))
    return path


__all__ = ["write_report", "render_report", "sort_key"]
