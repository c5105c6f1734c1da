"""The HTML report of ``mrcheck export``: one self-contained file, ``OUTDIR/report.html``.

Thumbnails of every shot's study sheet are inline (base64 JPEG), so the file works on its own;
links to the full-size images are relative and stay inside OUTDIR. Shots are sorted by
registration error (best first; shots without one after them, failures last).
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

import cv2

from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, read_image
from mrcheck.core.output import write_text

THUMB_WIDTH = 480
REPORT = "report.html"   # in OUTDIR


def _thumbnail(path: Path) -> str | None:
    try:
        image = read_image(path, "sheet")
    except MrcheckError:   # removed or damaged since the shot was written: the report goes without it
        return None
    if image.shape[1] > THUMB_WIDTH:
        height = max(1, round(image.shape[0] * THUMB_WIDTH / image.shape[1]))
        image = cv2.resize(image, (THUMB_WIDTH, height), interpolation=cv2.INTER_AREA)
    return "data:image/jpeg;base64," + base64.b64encode(encode_image(".jpg", image, quality=80)).decode()


def sort_key(entry: dict):
    """Done/skipped by registration error (unknown after known), failures last."""
    error = entry.get("registration_error_px")
    known = isinstance(error, (int, float)) and math.isfinite(error)
    return (entry["status"] == "failed", not known, error if known else 0.0, entry["name"])


def _num(value, digits=3) -> str:
    return "&ndash;" if value is None else f"{value:.{digits}f}"


def _job_value(value) -> str:
    """A setting as the job file writes it (TOML), not as Python prints it; unset = default."""
    if value is None:
        return "(default)"
    if isinstance(value, (bool, int, float, str, list)):
        return json.dumps(value)
    return str(value)


def render_report(manifest: dict, outdir: Path) -> str:
    e = html.escape
    summary, settings = manifest["summary"], manifest["settings"]
    rows, cards = [], []
    for entry in sorted(manifest["shots"], key=sort_key):
        name, status = entry["name"], entry["status"]
        registration = entry.get("registration") or {}
        rows.append(f'<tr class="{e(status)}"><td><a href="#shot-{e(name)}">{e(name)}</a></td><td>{e(status)}</td>'
                    f'<td>{_num(entry.get("registration_error_px"))}</td>'
                    f'<td>{_num(registration.get("expected_overlay_error_px"), 2)}</td>'
                    f'<td>{e(entry.get("error") or "")}</td></tr>')
        body = []
        if status == "failed":
            body.append(f'<p class="error">failed: {e(entry.get("error") or "")}</p>')
        sheet = next((o for o in entry.get("outputs", []) if o.get("kind") == "sheet"), None)
        if sheet is not None:
            thumb = _thumbnail(outdir / sheet["path"])
            if thumb:
                body.append(f'<a href="{e(sheet["path"])}"><img src="{thumb}" alt="study sheet of {e(name)}"></a>')
        if registration.get("rejected"):
            rejected = ", ".join(str(r) for r in registration["rejected"])
            body.append(f'<p class="warning">rejected by the registration ({e(str(registration.get("method")))}): '
                        f'{e(rejected)}</p>')
        for warning in registration.get("warnings") or []:
            body.append(f'<p class="warning">warning: {e(warning)}</p>')
        links = [f'<a href="{e(o["path"])}">{e(o["file"])}</a>' for o in entry.get("outputs", [])]
        if links:
            body.append('<p class="files">' + " &middot; ".join(links) + "</p>")
        timings = entry.get("timings_s") or {}
        if timings:
            body.append('<p class="timings">' + ", ".join(f"{e(k)} {v:.2f} s" for k, v in timings.items()) + "</p>")
        cards.append(f'<section id="shot-{e(name)}"><h2>{e(name)} <small>{e(status)}, registration error '
                     f'{_num(entry.get("registration_error_px"))} px</small></h2>{"".join(body)}</section>')
    params = ", ".join(f"{e(k)} = {e(_job_value(v))}" for k, v in settings.items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>mrcheck export report</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }}
tr.failed td {{ background: #fdd; }} .error {{ color: #a00; }} .warning {{ color: #a60; }}
section {{ margin: 1.5em 0; }} img {{ max-width: 100%; border: 1px solid #ccc; }}
.files, .timings {{ font-size: 0.85em; color: #555; }}
</style></head><body>
<h1>mrcheck export report</h1>
<p>Job <code>{e(manifest["job"])}</code>: {summary["shots"]} shots, {summary["done"]} done, {summary["skipped"]} skipped,
{summary["failed"]} failed. Total {manifest["timings_s"]["total"]:.1f} s ({e(manifest["executor"])}).</p>
<p class="timings">{params}</p>
<h2>Shots by registration error</h2>
<table><thead><tr><th>shot</th><th>status</th><th>registration RMS (px)</th><th>expected overlay error (px)</th>
<th>error</th></tr></thead><tbody>
{chr(10).join(rows)}
</tbody></table>
{chr(10).join(cards)}
</body></html>
"""


def write_report(manifest: dict, outdir) -> Path:
    outdir = Path(outdir)
    text = render_report(manifest, outdir)
    path = outdir / REPORT
    write_text(path, text)
    return path


__all__ = ["write_report", "render_report", "sort_key"]
