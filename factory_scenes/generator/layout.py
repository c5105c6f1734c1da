"""Placement: where every column, wall field, line, cell, rack bay and pallet place goes.

World frame: Z up, metres, the floor's top face at z = 0, the hall centred on the origin with
its length along x and its width along y. The hall is a grid of steel columns (rows along x
lettered A, B, ... from the south wall, lines along y numbered from the west gable). From
south to north: the rack zone (back-to-back pallet racks in rows along x), the main aisle
(a forklift path the length of the hall, doors in both gables), the production zone (lines
along x; robot cells, machines and workstations stand in the column bays along a line).

:func:`plan_scene` decides all positions for a preset (``presets``), a size, a seed and an
``amount`` (0..1: how much of the preset's content -- lines, cells, line length, cranes,
pits -- to place; the budget solver lowers it for small triangle targets; the number of rack
bays follows the target directly). The level of detail is not part of the plan: the
:class:`plan.Plan` it returns builds its meshes at any level, so the solver can count
triangles at several levels for one plan. Pallet places (in racks, in cells, on the floor)
are kept apart as slots in the order they are filled.
"""

from __future__ import annotations

from functools import partial

from . import arms
from .equipment import PEDESTAL_TOP, robot_pedestal
from .hall import AISLE_WIDTH, EYE, Hall
from .place_building import building, cranes, plan_doors
from .place_lines import conveyor_segment, lines
from .place_racks import floor_storage, racks
from .place_services import markings_and_bollards, place_mezzanine, plan_pits, services
from .plan import Plan
from .presets import Preset


def viewpoints(hall: Hall) -> list[dict]:
    L, W = hall.L, hall.W
    views = []

    def view(name, eye, target):
        views.append(
            {
                "name": name,
                "eye": [round(float(v), 3) for v in eye],
                "target": [round(float(v), 3) for v in target],
                "up": [0.0, 0.0, 1.0],
                "fov_y_deg": 60.0,
                "width": 1024,
                "height": 768,
            }
        )

    # down the main aisle from inside the west gable door, eye height, looking a little
    # down; the bollard past the door stands 1.5 m ahead
    x_eye = -L / 2 + 0.5
    view("aisle", (x_eye, hall.aisle_y + 1.4, EYE), (x_eye + 60.0, hall.aisle_y + 0.5, 0.2))
    if hall.preset.mezzanine:  # 0.6 m behind the platform's east rail, looking down the hall
        x0, y0, length, width, deck = hall.mezz
        eye = (x0 + length - 0.6, y0 + 1.2, deck + EYE)
        view("mezzanine", eye, (eye[0] + 60.0, eye[1] - 15.0, -10.0))
    # the cell seen through its open fence door from 1.5 m outside, looking west along the
    # line (the far gable behind it); the easternmost cell of a line outside the crane span
    cell = max(hall.line_cells, key=lambda c: (not hall.in_crane_span(c["y"]), c["x0"]))
    view("robot_cell", (cell["x1"] + 1.5, cell["door_y"] + 0.1, EYE), (cell["xc"], cell["robot_y"], 1.0))
    # from high in the north-west corner (above the floor storage or the mezzanine, beside
    # the wall's pipe run) across the production lines to the racks
    view("overview", (-L / 2 + 1.5, W / 2 - 1.5, hall.zc - 1.2), (L / 2, hall.aisle_y, 0.0))
    return views


def plan_scene(preset: Preset, size, seed: int, target: int, amount: float) -> Plan:
    """Every placement of a ``preset`` scene of ``size`` (m) for ``seed`` at ``amount`` (0..1]."""
    hall = Hall(preset, size, seed, target, amount)
    cross = racks(hall)
    plan_doors(hall, cross)
    plan_pits(hall)
    storage_y1 = place_mezzanine(hall) if preset.mezzanine else hall.zone_y1 - 1.0
    lines(hall)
    scale = max(arms.pedestal_scale(name) for name in hall.robots)  # one pedestal for the largest base
    for inst in hall.pedestals:
        hall.add("robot_pedestal", "pedestal", "equipment", partial(robot_pedestal, PEDESTAL_TOP, scale=scale), inst)
    if preset.racks:  # floor storage at the free west end of the production zone
        floor_storage(
            hall, hall.xs[0] + 1.0, hall.zone_y0 + 0.5, hall.xs[hall.line_bays[0]] - 1.0, storage_y1, "f", "storage"
        )
    else:  # the cell: in the first bay north of the conveyor, and along the south wall
        floor_storage(
            hall, hall.xs[0] + 0.8, hall.line_ys[0] + 1.2, hall.xs[1] - 0.5, hall.zone_y1 - 0.3, "f", "storage"
        )
        wall = -hall.W / 2 + hall.e + 0.1
        floor_storage(hall, hall.xs[0] + 1.0, wall, hall.xs[-1] - 1.0, wall + 0.95, "w", "wall storage")
    building(hall)
    cranes(hall)
    services(hall)
    markings_and_bollards(hall, cross)
    # fill order: the cells' own pallets first, then every other place in a seeded order
    order = hall.rng("fill order").permutation(len(hall.slots))
    slots = hall.cell_slots + [hall.slots[i] for i in order]
    return Plan(
        preset.name,
        preset.description,
        list(hall.parts.values()),
        slots,
        sorted(set(hall.robots)),
        viewpoints(hall),
        seed,
    )


__all__ = ["plan_scene", "viewpoints", "conveyor_segment", "AISLE_WIDTH", "EYE"]
