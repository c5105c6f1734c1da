"""The production zone: lines along x, each a conveyor with robot cells, machines and
workstations in the column bays along it."""

from __future__ import annotations

import math
from functools import partial

import trimesh

from . import arms
from .equipment import (
    FENCE_HEIGHT,
    PEDESTAL_TOP,
    assembly_press,
    control_cabinet,
    fence_layout,
    fence_panel,
    fence_post,
    machining_centre,
    roller_conveyor,
    workbench,
)
from .hall import CONVEYOR_SEGMENT, FENCE_DEPTH, LINE_BAND, ROBOT_OFFSET, Hall, amount_share, spread_indices
from .manifest import place
from .place_racks import draw_load
from .plan import PartPlan, Slot


def conveyor_segment(length_mm, motor, detail) -> trimesh.Trimesh:
    """The roller conveyor (authored in mm) as a segment in metres."""
    mesh = roller_conveyor(length_mm, detail, motor)
    mesh.apply_scale(0.001)
    return mesh


def lines(hall: Hall):
    p = hall.preset
    n_lines = max(1, min(hall.n_lines, math.floor((hall.zone_y1 - hall.zone_y0) / LINE_BAND)))
    pitch = (hall.zone_y1 - hall.zone_y0) / n_lines
    first, last = hall.line_bays
    avail = last - first
    length = max(min(avail, 2), round(avail * amount_share(hall.amount, 0.15)))
    first = last - length  # lines end at the east
    hall.line_extent = (first, last)
    rng = hall.rng("lines")
    cells = []
    for li in range(n_lines):
        y = _clear_of_rows(hall, hall.zone_y0 + pitch * li + FENCE_DEPTH[0] + 1.1)
        hall.line_ys.append(y)
        n_cells = max(1, min(int(rng.integers(p.cells[0], p.cells[1] + 1)), hall.max_cells, length))
        # the easternmost cell needs room east of its door for the robot_cell view
        cell_bays = spread_indices(first + len(hall.storage_bays), last - 1 - (last == hall.n_bays), n_cells)
        _conveyor(hall, li + 1, y, first, last)
        for i in range(first, last):
            xc = (hall.xs[i] + hall.xs[i + 1]) / 2
            if i in hall.storage_bays:
                continue
            if i in cell_bays:
                cells.append(_robot_cell(hall, len(cells) + 1, li, xc, y, rng))
            elif (i - first) % 4 == 3:
                _workstations(hall, li + 1, i, xc, y)
            else:
                _machines(hall, li + 1, i, xc, y, rng)
    hall.line_cells = cells


def _clear_of_rows(hall: Hall, y):
    """Move a conveyor axis at least 1.2 m off any column row (it must pass the columns)."""
    for row in hall.ys:
        if abs(y - row) < 1.2:
            y = row + 1.2 if y >= row else row - 1.2
    return float(y)


def _conveyor(hall: Hall, line, y, first, last):
    x0, x1 = hall.xs[first] + 0.6, hall.xs[last] - 0.6
    n = max(1, math.floor((x1 - x0) / CONVEYOR_SEGMENT))
    mm = CONVEYOR_SEGMENT * 1000.0
    for s in range(n):
        x = x0 + s * CONVEYOR_SEGMENT
        if s < n - 1:
            hall.add(
                "conveyor",
                "conveyor",
                "conveyor",
                partial(conveyor_segment, mm, False),
                place(x, y, id=f"line-{line}-conveyor-{s + 1:02d}"),
            )
        else:
            hall.add(
                "conveyor_drive",
                "conveyor",
                "conveyor",
                partial(conveyor_segment, mm, True),
                place(x, y, id=f"line-{line}-drive"),
            )


def _robot_cell(hall: Hall, n, line_index, xc, y, rng) -> dict:
    """A fenced robot cell straddling the conveyor in the column bay centred on ``xc``."""
    fw = float(min(6, math.floor(hall.bay_w - 1.2)))
    x0, x1 = xc - fw / 2, xc + fw / 2
    y0, y1 = y - FENCE_DEPTH[0], y + FENCE_DEPTH[1]
    door_y = y0 + 3.5  # a panel midpoint on the east side
    posts, panels = fence_layout((x0, y0, x1, y1), 1.0, openings=((x0, y), (x1, y), (x1, door_y)))
    for m, (px, py) in enumerate(posts, 1):
        hall.add(
            "fence_post",
            "fence",
            "equipment",
            partial(fence_post, FENCE_HEIGHT),
            place(float(px), float(py), id=f"cell-{n}-post-{m:02d}"),
        )
    for m, (mid, heading) in enumerate(panels, 1):
        hall.add(
            "fence_panel",
            "fence",
            "equipment",
            partial(fence_panel, 1.0, 0.15, 2.05),
            place(float(mid[0]), float(mid[1]), 0.0, float(heading), id=f"cell-{n}-panel-{m:02d}"),
        )
    share = hall.preset.robot_share * hall.target
    name = arms.choose_robot(rng, share / (hall.n_lines * hall.max_cells))  # the allowance per cell
    ry = y + ROBOT_OFFSET
    reach = min(fw / 2, y1 - ry, ry - y0) - 0.3
    joints = arms.working_pose(name, rng, reach)
    hall.robots.append(name)
    hall.parts[f"robot_{n}"] = PartPlan(
        f"robot_{n}",
        arms.ROBOT_COLORS[name],
        "equipment",
        None,
        [],
        path=f"robots/{name}/robot.urdf",
        joints=joints,
        triangles=arms.robot_triangles(name),
        translate=(xc, ry, PEDESTAL_TOP),
        rotate_deg=(0.0, 0.0, -90.0),
    )
    hall.pedestals.append(place(xc, ry, id=f"pedestal-{n}"))
    hall.cell_slots.append(Slot(f"pallet-c{n}", x0 + 1.0, y1 - 1.0, 0.0, 90.0, "cartons_full"))
    hall.add(
        "control_cabinet",
        "cabinet",
        "machine",
        partial(control_cabinet),
        place(x1 - 0.7, y1 + 0.45, 0.0, 180.0, id=f"cell-{n}-cabinet"),
    )  # behind the fence, facing out
    return {"n": n, "line": line_index, "x0": x0, "x1": x1, "xc": xc, "y": y, "door_y": door_y, "robot_y": ry}


def _machines(hall: Hall, line, i, xc, y, rng):
    """North of the conveyor a machining centre or a press, south a workbench and a cabinet."""
    if rng.random() < 0.65:
        hall.add(
            "machining_centre",
            "machine",
            "machine",
            partial(machining_centre),
            place(xc, y + 2.6, id=f"line-{line}-cnc-{i + 1:02d}"),
        )
    else:
        hall.add(
            "press",
            "press",
            "machine",
            partial(assembly_press),
            place(xc, y + 2.2, id=f"line-{line}-press-{i + 1:02d}"),
        )
    hall.slots.append(Slot(f"pallet-l{line}-{i + 1:02d}", xc - 2.4, y + 2.6, 0.0, 90.0, draw_load(rng)))
    hall.add(
        "workbench",
        "bench",
        "equipment",
        partial(workbench),
        place(xc - 1.2, y - 0.95, id=f"line-{line}-bench-{i + 1:02d}"),
    )
    hall.add(
        "control_cabinet",
        "cabinet",
        "machine",
        partial(control_cabinet),
        place(xc + 1.4, y - 0.95, id=f"line-{line}-cabinet-{i + 1:02d}"),
    )


def _workstations(hall: Hall, line, i, xc, y):
    """Manual workstations: two benches either side of the conveyor."""
    for m, (dx, dy, yaw) in enumerate(((-1.2, -0.95, 0.0), (1.2, -0.95, 0.0), (-1.2, 0.95, 180.0), (1.2, 0.95, 180.0))):
        hall.add(
            "workbench",
            "bench",
            "equipment",
            partial(workbench),
            place(xc + dx, y + dy, 0.0, yaw, id=f"line-{line}-bench-{i + 1:02d}{'abcd'[m]}"),
        )


__all__ = ["lines", "conveyor_segment"]
