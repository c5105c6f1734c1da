"""The building zone: floor and pits, columns, roof, walls with their doors, and the cranes."""

from __future__ import annotations

from functools import partial

import numpy as np

from .geometry import box_between
from .hall import Hall, amount_share
from .manifest import place
from .structure import (
    DECK_DEPTH,
    PURLIN_DEPTH,
    RAIL_HEIGHT,
    RUNWAY_DEPTH,
    WALL_THICKNESS,
    bridge_crane,
    crane_runway,
    floor_slab,
    pit,
    purlins,
    roof_deck,
    roof_truss,
    steel_column,
    wall_module,
)


def building(hall: Hall):
    """Floor, columns, roof, walls (the pits must be known: they cut the floor)."""
    L, W, k, e = hall.L, hall.W, hall.k, hall.e
    d = hall.truss_depth
    out = e + WALL_THICKNESS  # the slab reaches under the walls
    outer = (-L / 2 - out, -W / 2 - out, L / 2 + out, W / 2 + out)
    pits = tuple((x - ln / 2, y - w / 2, x + ln / 2, y + w / 2) for x, y, ln, w, _ in hall.pits)
    hall.add("floor", "floor", "structure", partial(floor_slab, outer, pits), place(0.0, 0.0, id="floor"))
    for n, (x, y, ln, w, depth) in enumerate(hall.pits, 1):
        hall.add(f"floor_pit_{n}", "pit", "structure", partial(pit, ln, w, depth), place(x, y, id=f"pit-{n}"))
    crane = hall.crane_span
    bracket = hall.rail_z - RAIL_HEIGHT - RUNWAY_DEPTH
    for j, y in enumerate(hall.ys):
        for i, x in enumerate(hall.xs):
            cid = f"column-{chr(65 + j)}{i + 1:02d}"
            if crane is not None and j in (crane, crane + 1):
                hall.add(
                    "column_crane",
                    "steel",
                    "structure",
                    partial(steel_column, hall.zc, scale=k, bracket_z=bracket),
                    place(x, y, yaw_deg=0.0 if j == crane else 180.0, id=cid),
                )
            else:
                hall.add("column", "steel", "structure", partial(steel_column, hall.zc, scale=k), place(x, y, id=cid))
    for side, x in (("W", hall.xs[0]), ("E", hall.xs[-1])):  # gable wind columns
        n = 0
        for j in range(hall.n_spans):
            for m in range(1, hall.gable_n):
                n += 1
                hall.add(
                    "column",
                    "steel",
                    "structure",
                    partial(steel_column, hall.zc, scale=k),
                    place(x, hall.ys[j] + m * hall.gable_w, id=f"windcolumn-{side}{n:02d}"),
                )
    # roof: a truss on every column line and span, purlins and deck per bay and span
    for j in range(hall.n_spans):
        yc = (hall.ys[j] + hall.ys[j + 1]) / 2
        for i, x in enumerate(hall.xs):
            hall.add(
                "roof_truss",
                "galvanised",
                "structure",
                partial(roof_truss, hall.span_w, d, scale=k),
                place(x, yc, hall.zc, id=f"truss-{chr(65 + j)}{i + 1:02d}"),
            )
        for i in range(hall.n_bays):
            hall.add(
                "roof_purlins",
                "galvanised",
                "structure",
                partial(purlins, hall.bay_w, hall.span_w),
                place(hall.xs[i], yc, hall.zc + d, id=f"purlins-{chr(65 + j)}{i + 1:02d}"),
            )
            hall.add(
                "roof_deck",
                "deck",
                "structure",
                partial(roof_deck, hall.bay_w, hall.span_w),
                place(
                    (hall.xs[i] + hall.xs[i + 1]) / 2,
                    yc,
                    hall.zc + d + PURLIN_DEPTH,
                    id=f"deck-{chr(65 + j)}{i + 1:02d}",
                ),
            )
    _walls(hall)


def _walls(hall: Hall):
    """Wall fields with window bands; sectional doors where :func:`plan_doors` put them."""
    L, W, e, H = hall.L, hall.W, hall.e, hall.H + 0.3  # walls rise 0.3 m above the deck
    doors = {(round(x, 3), round(y, 3)) for x, y, _ in hall.doors}
    fields = []  # (x, y, yaw, width, kind prefix)
    for i in range(hall.n_bays):
        xm = (hall.xs[i] + hall.xs[i + 1]) / 2
        fields += [(xm, -W / 2 - e, 0.0, hall.bay_w, "side"), (xm, W / 2 + e, 180.0, hall.bay_w, "side")]
    for j in range(hall.n_spans):
        for m in range(hall.gable_n):
            ym = hall.ys[j] + (m + 0.5) * hall.gable_w
            fields += [(-L / 2 - e, ym, -90.0, hall.gable_w, "gable"), (L / 2 + e, ym, 90.0, hall.gable_w, "gable")]
    for n, (x, y, yaw, width, kind) in enumerate(fields, 1):
        door = (round(x, 3), round(y, 3)) in doors
        name = f"wall_{kind}_door" if door else f"wall_{kind}"
        hall.add(
            name,
            "wall",
            "structure",
            partial(wall_module, width, H, window=hall.window, door=(hall.door_w, hall.door_h) if door else None),
            place(x, y, 0.0, yaw, id=f"wall-{n:03d}"),
        )
    t = WALL_THICKNESS
    ce = (e + t) / 2
    for n, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1)), 1):  # corner closers
        hall.add(
            "wall_corner",
            "wall",
            "structure",
            partial(box_between, (-ce, -ce, 0.0), (ce, ce, H)),
            place(sx * (L / 2 + ce), sy * (W / 2 + ce), id=f"corner-{n}"),
        )
    top = hall.H - DECK_DEPTH
    for n, (x, y, yaw, length) in enumerate(
        ((0.0, -W / 2, 0.0, L), (0.0, W / 2, 180.0, L), (-L / 2, 0.0, -90.0, W), (L / 2, 0.0, 90.0, W)), 1
    ):
        hall.add(
            f"roof_edge_{'x' if n <= 2 else 'y'}",
            "deck",
            "structure",
            partial(box_between, (-length / 2 - e, -e, 0.0), (length / 2 + e, 0.0, DECK_DEPTH)),
            place(x, y, top, yaw, id=f"roof-edge-{n}"),
        )


def plan_doors(hall: Hall, cross_bays):
    """Doors: both gables at the main aisle, the south wall at rack cross aisles, the
    north wall in the last bay (hall). Each gets a bollard either side, inside."""
    L, W, e = hall.L, hall.W, hall.e
    hall.doors = [(-L / 2 - e, hall.aisle_y, -90.0), (L / 2 + e, hall.aisle_y, 90.0)]
    for i in cross_bays:
        hall.doors.append(((hall.xs[i] + hall.xs[i + 1]) / 2, -W / 2 - e, 0.0))
    if hall.preset.mezzanine:
        hall.doors.append(((hall.xs[-2] + hall.xs[-1]) / 2, W / 2 + e, 180.0))


def cranes(hall: Hall):
    j = hall.crane_span
    if j is None:
        return
    off = 0.15 * hall.k + 0.35  # runway axis off the column row
    y0, y1 = hall.ys[j] + off, hall.ys[j + 1] - off
    z = hall.rail_z - RAIL_HEIGHT - RUNWAY_DEPTH
    for n, y in enumerate((y0, y1)):
        for i in range(hall.n_bays):
            hall.add(
                "crane_runway_beam",
                "steel",
                "structure",
                partial(crane_runway, hall.bay_w, scale=hall.k),
                place(hall.xs[i], y, z, id=f"runway-{n + 1}-{i + 1:02d}"),
            )
    count = max(1, round(hall.preset.cranes * amount_share(hall.amount, 0.5)))
    rng = hall.rng("cranes")
    lo, hi = hall.xs[0] + 4.0, hall.xs[-1] - 4.0
    xs = np.sort(lo + (hi - lo) * (np.arange(count) + rng.uniform(0.2, 0.8, count)) / count)
    span = y1 - y0
    hook, pendant = hall.rail_z - 3.7, hall.rail_z - 1.55
    for n, x in enumerate(xs, 1):
        hall.add(
            "hall_crane",
            "crane",
            "structure",
            partial(bridge_crane, span, hook, pendant),
            place(float(x), (y0 + y1) / 2, hall.rail_z, id=f"crane-{n}"),
        )


__all__ = ["building", "plan_doors", "cranes"]
