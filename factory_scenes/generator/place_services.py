"""Pits, the mezzanine, the services overhead (cable trays, pipe runs, lights), floor markings
and bollards."""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from .equipment import bollard, control_cabinet
from .hall import AISLE_WIDTH, TINY, Hall, amount_share
from .manifest import place
from .services import cable_tray, high_bay_light, pipe_run
from .structure import floor_marking, mezzanine, stair_run


def plan_pits(hall: Hall):
    """Pits in the production zone's free east end (hall, line)."""
    n = max(1 if hall.preset.pits else 0, round(hall.preset.pits * amount_share(hall.amount, 0.3)))
    if not n:
        return
    x = (hall.xs[hall.line_bays[1]] + hall.xs[-1]) / 2
    rng = hall.rng("pits")
    span = hall.zone_y1 - hall.zone_y0 - (6.0 if hall.preset.mezzanine else 0.0)
    for m in range(n):
        y = hall.zone_y0 + span * (m + 0.5) / n
        ln, w = float(rng.uniform(3.0, min(5.0, hall.bay_w - 3.0))), float(rng.uniform(2.0, 3.0))
        hall.pits.append((float(x), float(y), round(ln, 2), round(w, 2), round(float(rng.uniform(0.9, 1.6)), 2)))


def place_mezzanine(hall: Hall):
    """Platform over the west bays at the north wall, with cabinets on it; its stair runs south."""
    x0 = hall.xs[0] + 0.6
    length = hall.xs[hall.line_bays[0]] - 0.6 - x0
    width = min(7.0, (hall.zone_y1 - hall.zone_y0) / 3)
    deck = 4.0
    y0 = hall.zone_y1 - width
    hall.add(
        "hall_mezzanine",
        "mezzanine",
        "structure",
        partial(mezzanine, length, width, deck),
        place(x0, y0, id="mezzanine-1"),
    )
    for m in range(3):
        hall.add(
            "control_cabinet",
            "cabinet",
            "machine",
            partial(control_cabinet),
            place(x0 + 1.0 + 0.85 * m, y0 + width - 0.45, deck, 180.0, id=f"mezzanine-cabinet-{m + 1}"),
        )
    hall.mezz = (x0, y0, length, width, deck)
    return y0 - stair_run(deck) - 1.0


def services(hall: Hall):
    """Cable trays over the lines outside the crane span, pipe runs along the long walls,
    high-bay lights on the trusses outside the crane span."""
    crane = hall.crane_span
    z_tray = hall.zc - 1.0
    first, last = hall.line_extent
    for li, y in enumerate(hall.line_ys, 1):
        if hall.in_crane_span(y):
            continue
        for i in range(first, last):
            hall.add(
                "ceiling_cable_tray",
                "tray",
                "services",
                partial(cable_tray, hall.bay_w, 1.0),
                place(hall.xs[i], y - 0.8, z_tray, id=f"tray-{li}-{i + 1:02d}"),
            )
    z_pipe = hall.zc - 0.6
    hang = hall.zc + hall.truss_depth - z_pipe
    walls = (("N", hall.W / 2 - 1.0), ("S", -hall.W / 2 + 1.0))
    for side, y in walls[: 0 if hall.amount < TINY else 1 if hall.amount < 0.05 else 2]:
        for i in range(hall.n_bays):
            hall.add(
                "ceiling_pipe_run",
                "pipe",
                "services",
                partial(pipe_run, hall.bay_w, hang),
                place(hall.xs[i], y, z_pipe, id=f"pipes-{side}-{i + 1:02d}"),
            )
    n = 0
    for j in range(hall.n_spans):
        if j == crane or hall.amount < TINY:
            continue
        for m in range(max(1, round(hall.span_w / 5.0))):
            y = hall.ys[j] + (m + 0.5) * hall.span_w / max(1, round(hall.span_w / 5.0))
            for x in hall.xs[1:-1]:
                n += 1
                hall.add(
                    "roof_light",
                    "light",
                    "services",
                    partial(high_bay_light, 1.0),
                    place(float(x), float(y), hall.zc, id=f"light-{n:03d}"),
                )


def markings_and_bollards(hall: Hall, cross_bays):
    L = hall.L
    n = 0
    for edge in (hall.aisle_y - AISLE_WIDTH / 2, hall.aisle_y + AISLE_WIDTH / 2):  # aisle edge lines per bay
        for i in range(hall.n_bays):
            n += 1
            hall.add(
                "floor_marking",
                "marking",
                "structure",
                partial(floor_marking, hall.bay_w - 0.2),
                place(hall.xs[i] + 0.1, edge, id=f"marking-{n:03d}"),
            )
    if hall.preset.racks:  # cross aisles through the rack zone
        length = hall.aisle_y - AISLE_WIDTH / 2 - (-hall.W / 2 + hall.e + 0.3)
        for i in cross_bays:
            for dx in (-1.6, 1.6):
                n += 1
                hall.add(
                    "floor_marking_cross",
                    "marking",
                    "structure",
                    partial(floor_marking, length),
                    place(
                        (hall.xs[i] + hall.xs[i + 1]) / 2 + dx,
                        -hall.W / 2 + hall.e + 0.3,
                        yaw_deg=90.0,
                        id=f"marking-{n:03d}",
                    ),
                )
    spots = []
    for x, y, yaw in hall.doors:  # both sides of every door, inside
        inward = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw))])
        along = np.array([inward[1], -inward[0]])
        for s in (-1.0, 1.0):
            spots.append(np.array([x, y]) + inward * 0.6 + along * s * (hall.door_w / 2 + 0.35))
    north = hall.aisle_y + AISLE_WIDTH / 2 + 0.35  # the production side of the aisle
    for x in hall.xs[1:-1] if hall.amount >= TINY else []:
        spots.append(np.array([x, north]))
    # the aisle's north edge past the west door, in line with the door's own bollards
    spots.append(np.array([-L / 2 + 2.0, hall.aisle_y + hall.door_w / 2 + 0.35]))
    for m, (x, y) in enumerate(spots, 1):
        hall.add("bollard", "bollard", "equipment", partial(bollard), place(float(x), float(y), id=f"bollard-{m:03d}"))


__all__ = ["plan_pits", "place_mezzanine", "services", "markings_and_bollards"]
