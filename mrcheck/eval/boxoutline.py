"""How far a pose's outline of a box lies from the box's outline in a real photo (the box of
``tests/data/pose/box``: a printed biscuit box on a table), measured on the photo's edges.

The photo's outline is located independently of the edge registration's own matching (which
takes gradient maxima of a blurred image): on the raw grey values, along the outward normal of
each silhouette segment of a *reference* pose (the clicked one), as the outermost crossing of
the half-contrast level between the table (the profile's outer end) and the box -- where the
box's light rim meets the table, not the printed border inside it. One line per segment is
fitted to those crossings (least squares after dropping crossings more than 1.5 px off a first
fit). A segment whose step is weak (below :data:`MIN_CONTRAST` grey levels) gets no line; the
segments beside the box's own contact shadow get one, but there the outermost step is the
shadow's, so the tests do not measure them.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera

# grey levels between the table and the box's rim at a profile. Why 8: on the photo's table
# beside the three lit segments the grey level varies by a standard deviation of at most 1.3
# and a peak-to-peak of at most 4.1 over 6 px, and on CD the rim is only 10-12 levels brighter
# than the table. At 20 the rim is skipped there and the reference takes the printed border 3-5
# px inside it (the registration's fit would read 2.8 px "off" while lying on the rim's step).
MIN_CONTRAST = 8.0
PROFILE_PX = 14.0  # the profile reaches this far each side of the reference outline
PROFILE_STEP = 0.25  # px between the samples of a profile across the outline


@dataclass
class OutlineLine:
    """One silhouette segment's photo outline: a point, its unit direction, how many crossings."""

    name: str
    point: np.ndarray
    direction: np.ndarray
    count: int

    def distance(self, uv: np.ndarray) -> np.ndarray:
        d = uv - self.point
        return np.abs(d[:, 0] * self.direction[1] - d[:, 1] * self.direction[0])


def profile_crossing(profile: np.ndarray) -> float | None:
    """The outermost half-contrast crossing (index into ``profile``, outward increasing): the
    table level is the profile's outer end; the box's level the extremum within 3 px inside
    the outermost sample that differs from it by :data:`MIN_CONTRAST` (the rim, not the print
    further in)."""
    background = float(np.median(profile[-8:]))
    excess = profile - background
    strong = np.flatnonzero(np.abs(excess) >= MIN_CONTRAST)
    if len(strong) == 0:
        return None
    outer = int(strong[-1])
    sign = np.sign(excess[outer])
    window = excess[max(0, outer - int(3 / PROFILE_STEP)) : outer + 1] * sign
    half = 0.5 * float(window.max())
    above = np.flatnonzero(excess[: outer + 1] * sign > half)
    i = int(above[-1])
    if i + 1 >= len(profile):
        return None
    a, b = excess[i] * sign, excess[i + 1] * sign
    return i + (a - half) / max(a - b, 1e-9)


def photo_outline(grey: np.ndarray, reference: Camera, segments: dict) -> list[OutlineLine]:
    """The photo's outline lines of the silhouette ``segments`` (name -> (2, 3) world end
    points) located around their projection by ``reference``."""
    image = grey.astype(np.float32)
    centre = reference.project(np.concatenate(list(segments.values())))
    centre = centre.mean(axis=0)
    steps = np.arange(-PROFILE_PX, PROFILE_PX + 1e-9, PROFILE_STEP)
    out = []
    for name, ends in segments.items():
        a, b = reference.project(np.asarray(ends, np.float64))
        d = (b - a) / np.linalg.norm(b - a)
        n = np.array([-d[1], d[0]])
        n = n if np.dot(n, 0.5 * (a + b) - centre) > 0 else -n
        hits = []
        for f in np.linspace(0.15, 0.85, 15):
            p = a + f * (b - a)
            pts = (p + steps[:, None] * n).astype(np.float32)
            profile = cv2.remap(image, pts[:, 0:1], pts[:, 1:2], cv2.INTER_LINEAR).ravel()
            i = profile_crossing(profile)
            if i is not None:
                hits.append(p + (steps[0] + i * PROFILE_STEP) * n)
        if len(hits) >= 5:
            out.append(_fit_line(name, np.array(hits)))
    return out


def _fit_line(name: str, hits: np.ndarray) -> OutlineLine:
    for _ in range(2):
        point = hits.mean(axis=0)
        direction = np.linalg.svd(hits - point)[2][0]
        line = OutlineLine(name, point, direction, len(hits))
        keep = line.distance(hits) <= 1.5
        if keep.sum() < 5 or keep.all():
            break
        hits = hits[keep]
    return line


def box_segments(size) -> dict:
    """The outline segments of a box ``size`` (x, y, z, metres, corner at the origin) seen from
    above the (0, 0) corner side, as in the tutorial photo: name -> (2, 3) end points."""
    x, y, z = size
    corner = {
        "A": (0, 0, z),
        "B": (0, y, z),
        "C": (x, y, z),
        "D": (x, 0, z),
        "E": (0, 0, 0),
        "F": (0, y, 0),
        "G": (x, 0, 0),
    }
    pairs = ("BC", "CD", "DG", "GE", "EF", "FB")
    return {p: np.array([corner[p[0]], corner[p[1]]], np.float64) for p in pairs}


def outline_distances(lines: list[OutlineLine], camera: Camera, segments: dict) -> dict:
    """Per measured segment, the median distance (px) of ``camera``'s projection of the
    segment's middle 70 % to the photo's outline line."""
    out = {}
    for line in lines:
        a, b = segments[line.name]
        uv = camera.project(a + np.linspace(0.15, 0.85, 30)[:, None] * (b - a))
        out[line.name] = float(np.median(line.distance(uv)))
    return out


__all__ = [
    "OutlineLine",
    "photo_outline",
    "box_segments",
    "outline_distances",
    "profile_crossing",
    "MIN_CONTRAST",
    "PROFILE_PX",
    "PROFILE_STEP",
]
