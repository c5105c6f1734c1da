"""The null a part's move must stand out from: the shift the parts around it show on the same
photo (issue 41).

Why: a pose a few px off (a registration's error, a calibration's) moves every outline alike,
and each part judged against its unshifted outline then reads as moved: the sample cell's
conveyor, overview and robot views photographed 2 px off flagged 3, 5 and 3 unchanged parts,
about 20 each at 4 px. Each part is judged again against the shift its
:data:`~mrcheck.apps.discrepancies.thresholds.CONSENSUS_PARTS` nearest other parts match best at
(:func:`expected_shifts`); a shift they share is the pose's, not a move
(:func:`~mrcheck.apps.discrepancies.detector.detect`).
"""

from __future__ import annotations

import numpy as np

from mrcheck.apps.discrepancies.thresholds import CONSENSUS_PARTS


def expected_shifts(boxes: list, shifts: list) -> list[tuple[int, int]]:
    """Per part (``boxes``: [x0, y0, x1, y1], ``shifts``: its best (dx, dy)), the component-wise
    median of the best shifts of its :data:`CONSENSUS_PARTS` nearest other parts (by their boxes'
    centres), rounded; (0, 0) for every part when there are fewer than four."""
    if len(boxes) < 4:
        return [(0, 0)] * len(boxes)
    centres = np.array([[(b[0] + b[2]) / 2, (b[1] + b[3]) / 2] for b in boxes], float)
    best = np.array(shifts, float).reshape(-1, 2)
    out = []
    for i in range(len(boxes)):
        d = np.hypot(*(centres - centres[i]).T)
        d[i] = np.inf
        near = np.argsort(d)[: min(CONSENSUS_PARTS, len(boxes) - 1)]
        ex, ey = np.rint(np.median(best[near], axis=0)).astype(int)
        out.append((int(ex), int(ey)))
    return out


__all__ = ["expected_shifts"]
