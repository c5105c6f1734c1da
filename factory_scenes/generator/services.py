"""Building services under the roof: cable trays, pipe runs, high-bay lights.

Units and frames: metres, Z up. Runs go along +x from x = 0 to ``length`` (one segment per
column bay, repeated by the layout); their support hangs from the truss bottom chords,
``hang`` metres above the run's origin.
"""

from __future__ import annotations

import numpy as np
import trimesh

from .detail import Detail
from .geometry import box_between, combine, cylinder_between


def _trapeze(x, half_width, z_under, hang, sections) -> list[trimesh.Trimesh]:
    """Trapeze hanger at ``x``: a strut channel under the run at ``z_under`` on two threaded rods."""
    pieces = [box_between((x - 0.02, -half_width - 0.08, z_under - 0.04), (x + 0.02, half_width + 0.08, z_under))]
    for s in (-1.0, 1.0):
        pieces.append(
            cylinder_between(
                (x, s * (half_width + 0.05), z_under - 0.06),
                (x, s * (half_width + 0.05), hang),
                0.006,
                max(6, sections // 2),
            )
        )
    return pieces


def cable_tray(length, hang, detail: Detail) -> trimesh.Trimesh:
    """Ladder-type cable tray 0.5 m wide: side rails, rungs every 0.3 m, a bundle of cables,
    and a trapeze hanger at x = 0. Origin at the tray's bottom centre."""
    hw = 0.25
    pieces = _trapeze(0.0, hw, 0.0, hang, detail.sections)
    for s in (-1.0, 1.0):  # side rails (C-shaped)
        pieces.append(box_between((0.0, s * hw, 0.0), (length, s * (hw - 0.002), 0.1)))
        pieces.append(box_between((0.0, s * hw, 0.0), (length, s * (hw - 0.02), 0.002)))
    for x in np.arange(0.15, length, 0.3):  # rungs
        pieces.append(box_between((x - 0.015, -hw, 0.0), (x + 0.015, hw, 0.02)))
    rng_y = np.linspace(-hw + 0.05, hw - 0.05, 7)
    for i, y in enumerate(rng_y):  # cables, two layers
        r = 0.012 + 0.004 * (i % 3)
        pieces.append(cylinder_between((0.0, y, 0.02 + r), (length, y, 0.02 + r), r, detail.sections))
        if i % 2:
            pieces.append(cylinder_between((0.0, y + 0.03, 0.06 + r), (length, y + 0.03, 0.06 + r), r, detail.sections))
    return combine(pieces)


def pipe_run(length, hang, detail: Detail) -> trimesh.Trimesh:
    """Two parallel pipes (DN 150 and DN 80, 0.4 m apart) with bolted flanges at x = 0, a
    trapeze hanger with U-bolt clamps at x = ``length`` / 2. Origin on the run's centre line
    at the strut top (z = 0), where the pipes rest."""
    r_sec = detail.sections
    pipes = ((-0.2, 0.084), (0.2, 0.045))  # (y, outside radius)
    mid = length / 2.0
    pieces = _trapeze(mid, 0.3, 0.0, hang, r_sec)
    for y, r in pipes:
        z = r + 0.005
        pieces.append(cylinder_between((0.0, y, z), (length, y, z), r, r_sec))
        pieces.append(cylinder_between((0.0, y, z), (0.03, y, z), r * 1.6, r_sec))  # flange pair
        pieces.append(box_between((mid - 0.025, y - r - 0.008, 0.0), (mid + 0.025, y - r, z)))  # clamp
        pieces.append(box_between((mid - 0.025, y + r, 0.0), (mid + 0.025, y + r + 0.008, z)))
        pieces.append(
            box_between((mid - 0.025, y - r - 0.008, 2 * r + 0.005), (mid + 0.025, y + r + 0.008, 2 * r + 0.013))
        )
        if detail.bolts:  # flange bolts round the pitch circle
            for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False):
                by, bz = y + 1.3 * r * np.cos(a), z + 1.3 * r * np.sin(a)
                pieces.append(cylinder_between((-0.02, by, bz), (0.05, by, bz), 0.008, 6))
    return combine(pieces)


def high_bay_light(drop, detail: Detail) -> trimesh.Trimesh:
    """LED high-bay light: housing 0.6 x 0.35 x 0.1 m with cooling fins, on two wire ropes
    ``drop`` long (the ropes with ``detail.bolts``, the fins with ``detail.rib_pitch``).
    Origin at the top of the ropes (the truss bottom chord)."""
    pieces = [box_between((-0.3, -0.175, -drop - 0.1), (0.3, 0.175, -drop))]
    if detail.bolts:
        for x in (-0.25, 0.25):
            pieces.append(cylinder_between((x, 0.0, -drop), (x, 0.0, 0.0), 0.003, 4))
    if detail.rib_pitch is not None:
        for x in np.arange(-0.25, 0.26, 0.05):  # fins on top
            pieces.append(box_between((x - 0.005, -0.15, -drop), (x + 0.005, 0.15, -drop + 0.04)))
    return combine(pieces)


__all__ = ["cable_tray", "pipe_run", "high_bay_light"]
