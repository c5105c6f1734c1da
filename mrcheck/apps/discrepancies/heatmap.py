"""The heat map of a detection: where the photo supports the planned CAD edges and where not.

``heatmap.png`` is the 50 % photo / CAD overlay with supported CAD edges dim green, unsupported
CAD edges red, unexplained photo edges cyan and suspect boxes yellow, over a legend strip that
names the colours (the photo's pixel coordinates stay the image's).
"""

from __future__ import annotations

import cv2
import numpy as np

from mrcheck.apps.discrepancies.detector import Detection
from mrcheck.mr.overlay import blend

# colours of the heat map (RGB) and what they mean, drawn as a legend under it
FOUND, NOT_FOUND, UNEXPLAINED, SUSPECT = (0, 200, 0), (255, 0, 0), (0, 255, 255), (255, 255, 0)
LEGEND = (
    (FOUND, "CAD edge found"),
    (NOT_FOUND, "CAD edge not found"),
    (UNEXPLAINED, "photo edge, no CAD"),
    (SUSPECT, "suspect"),
)


def heatmap(photo: np.ndarray, detection: Detection) -> np.ndarray:
    """The 50 % overlay with supported CAD edges dim green, unsupported red, unexplained photo
    edges cyan and the suspects' boxes yellow, over a legend strip."""
    out = blend(photo, detection.planned.render, 0.5)
    cad, sup = detection.planned.cad, detection.supported
    out[sup] = (out[sup] * 0.5 + np.array(FOUND) * 0.5).astype(np.uint8)
    out[cad & ~sup] = NOT_FOUND
    out[detection.unexplained] = UNEXPLAINED
    for s in detection.flagged:
        x0, y0, x1, y1 = s.bbox
        cv2.rectangle(out, (x0, y0), (x1, y1), SUSPECT, 1)
    for r in detection.regions:
        x0, y0, x1, y1 = r.bbox
        cv2.rectangle(out, (x0, y0), (x1, y1), UNEXPLAINED, 1)
    return np.vstack([out, _legend(out.shape[1])])


def _legend(width: int) -> np.ndarray:
    """A dark strip under the photo (its pixel coordinates stay the photo's) naming the colours:
    one row when the photo is wide enough for legible text, else two or four."""
    font, thickness = cv2.FONT_HERSHEY_SIMPLEX, 1
    for per_row in (4, 2, 1):
        rows = [LEGEND[i : i + per_row] for i in range(0, len(LEGEND), per_row)]
        need = max(sum(cv2.getTextSize(label, font, 1.0, thickness)[0][0] + 44 for _, label in row) for row in rows)
        scale = min(0.5, 0.95 * width / need)  # 44 px: swatch and gaps at scale 1
        if scale >= 0.35:
            break
    line = max(10, int(36 * scale))
    strip = np.full((line * len(rows), width, 3), 32, np.uint8)
    swatch = max(3, int(16 * scale))
    for r, row in enumerate(rows):
        x, y = int(6 * scale) + 2, r * line
        for colour, label in row:
            cv2.rectangle(strip, (x, y + (line - swatch) // 2), (x + swatch, y + (line + swatch) // 2), colour, -1)
            x += swatch + max(2, int(8 * scale))
            cv2.putText(strip, label, (x, y + int(line * 0.7)), font, scale, (235, 235, 235), thickness, cv2.LINE_AA)
            x += cv2.getTextSize(label, font, scale, thickness)[0][0] + max(4, int(20 * scale))
    return strip


__all__ = ["heatmap", "LEGEND"]
