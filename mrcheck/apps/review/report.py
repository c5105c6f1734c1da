"""The review's export: a self-contained HTML report (a crop of every marker in every mode, from
the template ``templates/report.html.j2``, every value escaped) and CSV."""

from __future__ import annotations

import base64
import csv
import io
import time

import cv2
import numpy as np
from markupsafe import Markup

from mrcheck.apps.review.measure import offset_line
from mrcheck.apps.templating import render
from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.images import encode_image
from mrcheck.render.renderer import MODES, STUDY_LABELS

CROP = 96  # half-size of a marker crop, px
FORMULA = ("=", "+", "-", "@", "\t", "\r")  # a spreadsheet runs a cell starting with these as a formula


def _crop(image: np.ndarray, x: float, y: float) -> np.ndarray:
    h, w = image.shape[:2]
    cx, cy = int(round(x)), int(round(y))
    x0, y0 = max(0, cx - CROP), max(0, cy - CROP)
    crop = image[y0 : min(h, cy + CROP), x0 : min(w, cx + CROP)].copy()
    cv2.circle(crop, (cx - x0, cy - y0), 9, (255, 0, 0), 2)
    return crop


def _data_url(image: np.ndarray) -> Markup:
    return Markup("data:image/png;base64," + base64.b64encode(encode_image(".png", image)).decode())


def _text(value: str | None) -> str:
    """A free-text CSV cell, defused against formula injection as OWASP recommends (a leading ')."""
    value = value or ""
    return "'" + value if value.startswith(FORMULA) else value


def _when(seconds: float) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(seconds))


def markers_csv(markers: list) -> str:
    out = io.StringIO()
    writer = csv.writer(out)
    # the offset's columns last: a spreadsheet reading the earlier ones by position still does
    writer.writerow(
        ["id", "shot", "x", "y", "category", "severity", "note", "part", "distance_m", "mode", "updated"]
        + ["offset_m", "offset_x_m", "offset_y_m", "offset_z_m"]
    )
    for m in markers:
        writer.writerow(
            [
                m["id"],
                m["shot"],
                f"{m['x']:.1f}",
                f"{m['y']:.1f}",
                m["category"],
                m["severity"],
                _text(m["note"]),
                _text(m["part"]),
                "" if m["distance"] is None else f"{m['distance']:.3f}",
                m["mode"] or "",
                _when(m["updated"]),
                *_offset_cells(m["offset"]),
            ]
        )
    return out.getvalue()


def _offset_cells(offset: dict | None) -> list[str]:
    if offset is None:
        return ["", "", "", ""]
    return [f"{offset['distance_m']:.4f}", *(f"{c:.4f}" for c in offset["offset_m"])]


def _shot_images(source, renders, shot: str, intensity: float):
    """[(label, image)] of the photo and every mode of ``shot``, or why there are none: the shot
    is not in the review (markers left by an earlier review of this folder), or its photo broke
    since start-up. One broken shot loses its own crops, not the report."""
    if shot not in source.shots:
        return "the review no longer has this shot"
    try:
        return [("photo", renders.image(shot, "photo"))] + [
            (STUDY_LABELS[mode], renders.image(shot, "render", mode, intensity)) for mode in MODES
        ]
    except MrcheckError as exc:
        return str(exc)


def _marker(m: dict, crops, served_scale) -> dict:
    """What the report shows of one marker: its fields as text, and its crops (label, data URL)
    or why there are none."""
    if isinstance(crops, str):
        problem, figures = crops, []
    else:  # the marker is in the photo's pixels, the images are the served ones
        sx, sy = served_scale
        problem, figures = None, [(label, _data_url(_crop(img, m["x"] * sx, m["y"] * sy))) for label, img in crops]
    return {
        "id": m["id"],
        "category": m["category"],
        "severity": m["severity"],
        "shot": m["shot"],
        "x": f"{m['x']:.0f}",
        "y": f"{m['y']:.0f}",
        "part": m["part"] or "none",
        "distance": "" if m["distance"] is None else f" at {m['distance']:.2f} m",
        "placed": f" in {STUDY_LABELS.get(m['mode'], m['mode'])}" if m["mode"] else "",
        "created": _when(m["created"]),
        "changed": "" if m["updated"] == m["created"] else f", last changed {_when(m['updated'])}",
        "note": m["note"],
        "offset": offset_line(m["offset"]) if m["offset"] else "",
        "problem": problem,
        "crops": figures,
    }


def report_html(source, renders, markers: list, intensity: float = 1.0) -> str:
    """Every marker with its note, part, shot and a crop of the photo and of every mode."""
    images, shown = {}, []
    for m in markers:
        if m["shot"] not in images:
            images[m["shot"]] = _shot_images(source, renders, m["shot"], intensity)
        crops = images[m["shot"]]
        shown.append(_marker(m, crops, None if isinstance(crops, str) else source.shots[m["shot"]].served_scale()))
    return render(
        "mrcheck.apps.review",
        "report.html.j2",
        label=source.label,
        scene=display(source.scene),
        exported=_when(time.time()),
        intensity=f"{intensity:g}",
        markers=shown,
    )
