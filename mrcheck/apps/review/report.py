"""The review's export: a self-contained HTML report (a crop of every marker in every mode) and CSV."""

from __future__ import annotations

import base64
import csv
import html
import io
import time

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.images import encode_image
from mrcheck.render.renderer import MODES, STUDY_LABELS

CROP = 96  # half-size of a marker crop, px
FORMULA = ("=", "+", "-", "@", "\t", "\r")  # a spreadsheet runs a cell starting with these as a formula


def _crop(image: np.ndarray, x: float, y: float) -> np.ndarray:
    h, w = image.shape[:2]
    cx, cy = int(round(x)), int(round(y))
    x0, y0 = max(0, cx - CROP), max(0, cy - CROP)
    crop = image[y0:min(h, cy + CROP), x0:min(w, cx + CROP)].copy()
    cv2.circle(crop, (cx - x0, cy - y0), 9, (255, 0, 0), 2)
    return crop


def _data_url(image: np.ndarray) -> str:
    return "data:image/png;base64," + base64.b64encode(encode_image(".png", image)).decode()


def _text(value: str | None) -> str:
    """A free-text CSV cell, defused against formula injection as OWASP recommends (a leading ')."""
    value = value or ""
    return "'" + value if value.startswith(FORMULA) else value


def _when(seconds: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(seconds))


def markers_csv(markers: list) -> str:
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(["id", "shot", "x", "y", "category", "severity", "note", "part", "distance_m", "mode", "updated"])
    for m in markers:
        writer.writerow([m["id"], m["shot"], f"{m['x']:.1f}", f"{m['y']:.1f}", m["category"], m["severity"],
                         _text(m["note"]), _text(m["part"]), "" if m["distance"] is None else f"{m['distance']:.3f}",
                         m["mode"] or "", _when(m["updated"])])
    return out.getvalue()


def _shot_images(source, renders, shot: str, intensity: float):
    """[(label, image)] of the photo and every mode of ``shot``, or why there are none: the shot
    is not in the review (markers left by an earlier review of this folder), or its photo broke
    since start-up. One broken shot loses its own crops, not the report."""
    if shot not in source.shots:
        return "the review no longer has this shot"
    try:
        return [("photo", renders.image(shot, "photo"))] + [
            (STUDY_LABELS[mode], renders.image(shot, "render", mode, intensity)) for mode in MODES]
    except MrcheckError as exc:
        return str(exc)


def report_html(source, renders, markers: list, intensity: float = 1.0) -> str:
    """Every marker with its note, part, shot and a crop of the photo and of every mode."""
    e = html.escape
    images = {}
    rows = []
    for m in markers:
        if m["shot"] not in images:
            images[m["shot"]] = _shot_images(source, renders, m["shot"], intensity)
        crops = images[m["shot"]]
        if isinstance(crops, str):
            figures = f"<i>no crops: {e(crops)}</i>"
        else:  # the marker is in the photo's pixels, the images are the served ones
            sx, sy = source.shots[m["shot"]].served_scale()
            figures = "".join(f'<figure><img src="{_data_url(_crop(img, m["x"] * sx, m["y"] * sy))}" alt="{e(label)}">'
                              f"<figcaption>{e(label)}</figcaption></figure>" for label, img in crops)
        distance = "" if m["distance"] is None else f" at {m['distance']:.2f} m"
        placed = f" in {STUDY_LABELS.get(m['mode'], m['mode'])}" if m["mode"] else ""
        changed = "" if m["updated"] == m["created"] else f", last changed {_when(m['updated'])}"
        rows.append(f'<section class="marker" id="marker-{m["id"]}"><h2>#{m["id"]} {e(m["category"])} '
                    f'(severity {m["severity"]}) -- shot {e(m["shot"])}</h2>'
                    f'<p class="meta">photo pixel ({m["x"]:.0f}, {m["y"]:.0f}); CAD part: '
                    f'<b>{e(m["part"] or "none")}</b>{distance}; placed{e(placed)} {_when(m["created"])}{changed}</p>'
                    f'<p class="note">{e(m["note"]) or "<i>no note</i>"}</p>'
                    f'<div class="crops">{figures}</div></section>')
    body = "".join(rows) or "<p>No markers.</p>"
    return f"""<!doctype html><html><head><meta charset="utf-8"><title>mrcheck review</title><style>
body{{font-family:sans-serif;margin:2em;color:#222}} .marker{{border-top:1px solid #ccc;padding:.5em 0}}
.crops{{display:flex;flex-wrap:wrap;gap:6px}} figure{{margin:0}} figcaption{{font-size:12px;color:#555}}
.note{{white-space:pre-wrap}} h2{{font-size:1.1em}}</style></head><body>
<h1>mrcheck review: {e(source.label)}</h1><p>{len(markers)} marker(s), scene {e(display(source.scene))},
exported {_when(time.time())}. Crops: photo and every mode (AO intensity {intensity:g}).
Positions are pixels of the original photo (from its top-left corner).</p>
{body}</body></html>"""
