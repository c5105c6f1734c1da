"""The storage zone: pallet racks in rows south of the main aisle, block storage on the floor,
and what stands on each pallet place."""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from .hall import RACK_PITCH_MIN, RACK_SHARE, SLOT_TRIANGLES, Hall
from .manifest import place
from .plan import LOAD_WEIGHTS, Slot
from .storage import RACK_BAY_PITCH, RACK_DEPTH, RACK_SLOTS, rack_beams, rack_frame, rack_guard


def draw_load(rng) -> str | None:
    """What stands on a pallet, drawn with LOAD_WEIGHTS (None: the pallet is empty)."""
    names = list(LOAD_WEIGHTS)
    return names[int(rng.choice(len(names), p=list(LOAD_WEIGHTS.values())))]


def racks(hall: Hall) -> list[int]:
    """Pallet racking in the rack zone; returns the column bays left free as cross aisles."""
    if not hall.preset.racks or not hall.beam_levels:
        return []
    W = hall.W
    centres = []  # double rows, aisle side first
    pitch = hall.span_w / max(1, math.floor(hall.span_w / RACK_PITCH_MIN))
    y = hall.ys[hall.aisle_row]
    wall_row = -W / 2 + hall.e + 0.1 + RACK_DEPTH / 2  # single row against the south wall
    while y - RACK_DEPTH - 0.15 - 3.0 >= wall_row + RACK_DEPTH / 2:
        centres.append(y)
        y -= pitch
    rows = []  # (y of the row axis, facing north?)
    for c in centres:
        rows += [(c + RACK_DEPTH / 2 + 0.15, True), (c - RACK_DEPTH / 2 - 0.15, False)]
    if centres and centres[-1] - RACK_DEPTH - 0.15 - wall_row - RACK_DEPTH / 2 >= 3.0:
        rows.append((wall_row, True))
    cross = [i for i in range(hall.n_bays) if hall.n_bays >= 5 and i % 5 == 2] or [hall.n_bays // 2]
    bays = [i for i in range(hall.n_bays) if i not in cross]
    per_bay = max(1, math.floor((hall.bay_w - 1.2) / RACK_BAY_PITCH))
    levels = (0.0,) + hall.beam_levels
    # as many rack bays as the racks' share of the target fills: whole rows from the
    # aisle southwards, the last one from the east end
    wanted = hall.target * RACK_SHARE / (len(levels) * len(RACK_SLOTS) * SLOT_TRIANGLES)
    column_bays = max(1, math.ceil(wanted / per_bay))
    d = hall.rng("rack loads")
    for r, (y, north) in enumerate(rows, 1):
        if column_bays <= 0:
            break
        row_bays, column_bays = bays[max(0, len(bays) - column_bays) :], column_bays - len(bays)
        k = frame = guard = 0  # numbered along the row from the west
        for i in row_bays:
            start = (hall.xs[i] + hall.xs[i + 1]) / 2 - per_bay * RACK_BAY_PITCH / 2
            frames = [start + b * RACK_BAY_PITCH for b in range(per_bay + 1)]
            yaw = 180.0 if north else 0.0
            for b in range(per_bay):
                k += 1
                x0 = frames[b + 1] if north else frames[b]  # the bay's frame end, seen from its aisle
                hall.add(
                    "rack_beams",
                    "rack_beams",
                    "rack",
                    partial(rack_beams, hall.beam_levels),
                    place(x0, y, 0.0, yaw, id=f"rack-{r}-bay-{k:03d}"),
                )
                for t, z in enumerate(levels):
                    for s, dx in enumerate(RACK_SLOTS):
                        load = draw_load(d)
                        hall.slots.append(
                            Slot(
                                f"pallet-r{r}-{k:03d}-{t}{s}", start + (b + 0.5) * RACK_BAY_PITCH + dx, y, z, 90.0, load
                            )
                        )
            for x in frames:
                frame += 1
                hall.add(
                    "rack_frame",
                    "rack_frame",
                    "rack",
                    partial(rack_frame, hall.rack_h),
                    place(x, y, 0.0, yaw, id=f"rack-{r}-frame-{frame:03d}"),
                )
            for x, end_yaw in ((frames[0], 0.0), (frames[-1], 180.0)):  # protectors at both segment ends
                guard += 1
                hall.add(
                    "rack_guard",
                    "bollard",
                    "rack",
                    partial(rack_guard),
                    place(x, y, 0.0, end_yaw, id=f"rack-{r}-guard-{guard:02d}"),
                )
    return cross


def floor_storage(hall: Hall, x0, y0, x1, y1, prefix, purpose):
    """Block storage of single pallets (1.2 m along x) in pairs of rows with 2.5 m lanes."""
    rng = hall.rng(purpose)
    xs = np.arange(x0 + 0.65, x1 - 0.6, 1.35)
    ys, y = [], y0 + 0.45
    while y + 0.45 <= y1:
        ys.append(y)
        y += 0.95 if len(ys) % 2 else 3.45
    for r, yy in enumerate(ys):
        for c, xx in enumerate(xs):
            hall.slots.append(
                Slot(f"pallet-{prefix}-{r + 1:02d}{c + 1:02d}", float(xx), float(yy), 0.0, 0.0, draw_load(rng))
            )


__all__ = ["racks", "floor_storage", "draw_load"]
