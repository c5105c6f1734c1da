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

import math
from functools import partial

import numpy as np
import trimesh

from . import arms
from .equipment import (
    FENCE_HEIGHT,
    PEDESTAL_TOP,
    assembly_press,
    bollard,
    control_cabinet,
    fence_layout,
    fence_panel,
    fence_post,
    machining_centre,
    robot_pedestal,
    roller_conveyor,
    workbench,
)
from .geometry import box_between
from .manifest import place
from .plan import LOAD_WEIGHTS, PartPlan, Plan, Slot
from .presets import COLORS, Preset
from .services import cable_tray, high_bay_light, pipe_run
from .storage import (
    RACK_BAY_PITCH,
    RACK_DEPTH,
    RACK_SLOTS,
    rack_beams,
    rack_frame,
    rack_guard,
)
from .structure import (
    DECK_DEPTH,
    PURLIN_DEPTH,
    RAIL_HEIGHT,
    RUNWAY_DEPTH,
    WALL_THICKNESS,
    bridge_crane,
    crane_runway,
    floor_marking,
    floor_slab,
    mezzanine,
    pit,
    purlins,
    roof_deck,
    roof_truss,
    stair_run,
    steel_column,
    wall_module,
)

AISLE_WIDTH = 4.0  # m, main forklift aisle
LINE_BAND = 10.5  # m, across-hall room one production line needs (cells, machines, gangway)
CONVEYOR_SEGMENT = 4.0  # m, length of one roller conveyor module
TIER_PITCH = 1.5  # m, rack beam level spacing
RACK_PITCH_MIN = 5.8  # m, double rack row + aisle (2 x 1.1 + 0.3 flue + 3.3 aisle)
FENCE_DEPTH = (1.5, 4.5)  # m, a robot cell's fence south and north of the conveyor axis
ROBOT_OFFSET = 1.6  # m, robot axis north of the conveyor axis
EYE = 1.7  # m, a planner's eye height
TINY = 0.02  # amount below which a plan drops crane, pipes, lights and aisle bollards
CRANE_MIN_RAIL = 5.5  # m, lowest crane rail worth a crane (hook 2 m above the floor, racks below)
RACK_SHARE = 0.5  # share of the triangle target meant for the racks and their pallets
SLOT_TRIANGLES = 450  # a loaded pallet at the middle levels of detail
STREAMS = ("cranes", "rack loads", "lines", "storage", "wall storage", "pits", "fill order")  # random streams


def conveyor_segment(length_mm, motor, detail) -> trimesh.Trimesh:
    """The roller conveyor (authored in mm) as a segment in metres."""
    mesh = roller_conveyor(length_mm, detail, motor)
    mesh.apply_scale(0.001)
    return mesh


def _share(amount: float, full_at: float) -> float:
    """Fraction (0..1] of something a plan of ``amount`` holds: all of it from ``full_at`` on."""
    return min(1.0, max(amount, 1e-6) / full_at)


def _spread(first: int, last: int, count: int) -> list[int]:
    """``count`` indices spread evenly from ``first`` to ``last`` inclusive (last first)."""
    if count <= 1:
        return [last]
    return sorted({int(round(v)) for v in np.linspace(last, first, count)})


class _Layout:
    """Builds a :class:`Plan`; one method per concern, sharing the column grid."""

    def __init__(self, preset: Preset, size, seed: int, target: int, amount: float):
        self.preset, self.seed, self.target, self.amount = preset, seed, target, amount
        self.L, self.W, self.H = (float(v) for v in size)
        self.parts: dict[str, PartPlan] = {}
        self.slots: list[Slot] = []
        self.cell_slots: list[Slot] = []
        self.robots: list[str] = []
        self.pits: list[tuple] = []
        self.doors: list[tuple] = []  # (x, y, yaw): centre of a door, yaw of its wall
        self.pedestals: list[dict] = []  # instances of the robot pedestal
        self.line_cells: list[dict] = []
        self.line_ys: list[float] = []
        self.storage_bays: set = set()  # column bays a line leaves to floor storage
        self.mezz = None
        # lines and cells per line at this amount (lines() may fit fewer into a narrow hall)
        self.n_lines = max(1, round(preset.lines * _share(amount, 0.6)))
        self.max_cells = max(1, round(preset.cells[1] * _share(amount, 0.3)))
        self._grid()

    def rng(self, purpose: str) -> np.random.Generator:
        """An independent random stream per purpose: planning one thing never shifts another."""
        return np.random.default_rng([self.seed, STREAMS.index(purpose)])

    def add(self, name, color, category, build: partial, inst: dict):
        """One instance of part ``name``, created on first use with its builder ``build``
        (a partial of a part builder; the level of detail comes later)."""
        if name not in self.parts:
            self.parts[name] = PartPlan(name, COLORS[color], category, build)
        self.parts[name].instances.append(inst)

    # -- the column grid and the zones -----------------------------------------------------
    def _grid(self):
        p, L, W, H = self.preset, self.L, self.W, self.H
        self.n_bays = max(3, round(L / p.bay))
        self.xs = np.linspace(-L / 2, L / 2, self.n_bays + 1)  # column lines
        self.bay_w = L / self.n_bays
        self.n_spans = max(1, round(W / p.span))
        self.ys = np.linspace(-W / 2, W / 2, self.n_spans + 1)  # column rows
        self.span_w = W / self.n_spans
        self.truss_depth = max(0.8, self.span_w / 12.0)
        self.zc = H - DECK_DEPTH - PURLIN_DEPTH - self.truss_depth  # column top, truss bottom
        self.k = float(np.clip(self.zc / 6.0, 1.0, 1.6))  # HEB 300 .. HEB 480
        self.e = 0.15 * self.k + 0.05  # wall inner face off the grid
        self.gable_n = math.ceil(self.span_w / 10.0)  # gable fields per span
        self.gable_w = self.span_w / self.gable_n
        self.door_h = min(4.5, 0.5 * H)
        self.door_w = min(4.0, self.gable_w - 1.2, self.bay_w - 1.2)
        self.window = (self.door_h + 0.6, min(self.door_h + 2.1, H - 0.8))
        # the main aisle runs along the gable field just north of column row `aisle_row`,
        # whose columns stand inside the last rack row; with no racks, along the south wall
        need = LINE_BAND * self.n_lines
        row = 0
        if p.racks:
            fits = [
                j for j in range(1, self.n_spans) if W / 2 - (self.ys[j] + self.gable_w / 2 + AISLE_WIDTH / 2) >= need
            ]
            row = max(fits) if fits else 0
        self.aisle_row = row
        self.aisle_y = self.ys[row] + self.gable_w / 2
        self.zone_y0 = self.aisle_y + AISLE_WIDTH / 2 + 0.5  # production zone, south edge
        self.zone_y1 = W / 2 - self.e - 0.4
        tiny = self.amount < TINY  # no crane, pipes, lights below
        self.rail_z = self.zc - 2.4  # crane rail top: the crane fits below the trusses
        crane_fits = self.rail_z >= CRANE_MIN_RAIL and row + 1 <= self.n_spans
        self.crane_span = row if p.cranes and crane_fits and not tiny else None
        runway_bottom = self.rail_z - RAIL_HEIGHT - RUNWAY_DEPTH
        limit = runway_bottom - 0.2 if self.crane_span is not None else self.zc - 0.8
        self.beam_levels = tuple(TIER_PITCH * t for t in range(1, 12) if TIER_PITCH * (t + 1) <= limit)
        self.rack_h = (self.beam_levels[-1] if self.beam_levels else TIER_PITCH) + 1.0
        # column bays of the lines: the west end holds the mezzanine or floor storage, the east
        # end the pits; a cell (no racks) uses every bay, storage in the first
        self.line_bays = (2, self.n_bays - 1) if p.mezzanine else (1, self.n_bays - 1) if p.racks else (0, self.n_bays)
        if not p.racks:
            self.storage_bays = {0}

    def in_crane_span(self, y) -> bool:
        j = self.crane_span
        return j is not None and self.ys[j] - 0.5 <= y <= self.ys[j + 1] + 0.5

    # -- building -------------------------------------------------------------------------
    def building(self):
        """Floor, columns, roof, walls (the pits must be known: they cut the floor)."""
        L, W, k, e = self.L, self.W, self.k, self.e
        d = self.truss_depth
        out = e + WALL_THICKNESS  # the slab reaches under the walls
        outer = (-L / 2 - out, -W / 2 - out, L / 2 + out, W / 2 + out)
        pits = tuple((x - ln / 2, y - w / 2, x + ln / 2, y + w / 2) for x, y, ln, w, _ in self.pits)
        self.add("floor", "floor", "structure", partial(floor_slab, outer, pits), place(0.0, 0.0, id="floor"))
        for n, (x, y, ln, w, depth) in enumerate(self.pits, 1):
            self.add(f"floor_pit_{n}", "pit", "structure", partial(pit, ln, w, depth), place(x, y, id=f"pit-{n}"))
        crane = self.crane_span
        bracket = self.rail_z - RAIL_HEIGHT - RUNWAY_DEPTH
        for j, y in enumerate(self.ys):
            for i, x in enumerate(self.xs):
                cid = f"column-{chr(65 + j)}{i + 1:02d}"
                if crane is not None and j in (crane, crane + 1):
                    self.add(
                        "column_crane",
                        "steel",
                        "structure",
                        partial(steel_column, self.zc, scale=k, bracket_z=bracket),
                        place(x, y, yaw_deg=0.0 if j == crane else 180.0, id=cid),
                    )
                else:
                    self.add(
                        "column", "steel", "structure", partial(steel_column, self.zc, scale=k), place(x, y, id=cid)
                    )
        for side, x in (("W", self.xs[0]), ("E", self.xs[-1])):  # gable wind columns
            n = 0
            for j in range(self.n_spans):
                for m in range(1, self.gable_n):
                    n += 1
                    self.add(
                        "column",
                        "steel",
                        "structure",
                        partial(steel_column, self.zc, scale=k),
                        place(x, self.ys[j] + m * self.gable_w, id=f"windcolumn-{side}{n:02d}"),
                    )
        # roof: a truss on every column line and span, purlins and deck per bay and span
        for j in range(self.n_spans):
            yc = (self.ys[j] + self.ys[j + 1]) / 2
            for i, x in enumerate(self.xs):
                self.add(
                    "roof_truss",
                    "galvanised",
                    "structure",
                    partial(roof_truss, self.span_w, d, scale=k),
                    place(x, yc, self.zc, id=f"truss-{chr(65 + j)}{i + 1:02d}"),
                )
            for i in range(self.n_bays):
                self.add(
                    "roof_purlins",
                    "galvanised",
                    "structure",
                    partial(purlins, self.bay_w, self.span_w),
                    place(self.xs[i], yc, self.zc + d, id=f"purlins-{chr(65 + j)}{i + 1:02d}"),
                )
                self.add(
                    "roof_deck",
                    "deck",
                    "structure",
                    partial(roof_deck, self.bay_w, self.span_w),
                    place(
                        (self.xs[i] + self.xs[i + 1]) / 2,
                        yc,
                        self.zc + d + PURLIN_DEPTH,
                        id=f"deck-{chr(65 + j)}{i + 1:02d}",
                    ),
                )
        self._walls()

    def _walls(self):
        """Wall fields with window bands; sectional doors where :meth:`plan_doors` put them."""
        L, W, e, H = self.L, self.W, self.e, self.H + 0.3  # walls rise 0.3 m above the deck
        doors = {(round(x, 3), round(y, 3)) for x, y, _ in self.doors}
        fields = []  # (x, y, yaw, width, kind prefix)
        for i in range(self.n_bays):
            xm = (self.xs[i] + self.xs[i + 1]) / 2
            fields += [(xm, -W / 2 - e, 0.0, self.bay_w, "side"), (xm, W / 2 + e, 180.0, self.bay_w, "side")]
        for j in range(self.n_spans):
            for m in range(self.gable_n):
                ym = self.ys[j] + (m + 0.5) * self.gable_w
                fields += [(-L / 2 - e, ym, -90.0, self.gable_w, "gable"), (L / 2 + e, ym, 90.0, self.gable_w, "gable")]
        for n, (x, y, yaw, width, kind) in enumerate(fields, 1):
            door = (round(x, 3), round(y, 3)) in doors
            name = f"wall_{kind}_door" if door else f"wall_{kind}"
            self.add(
                name,
                "wall",
                "structure",
                partial(wall_module, width, H, window=self.window, door=(self.door_w, self.door_h) if door else None),
                place(x, y, 0.0, yaw, id=f"wall-{n:03d}"),
            )
        t = WALL_THICKNESS
        ce = (e + t) / 2
        for n, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1)), 1):  # corner closers
            self.add(
                "wall_corner",
                "wall",
                "structure",
                partial(box_between, (-ce, -ce, 0.0), (ce, ce, H)),
                place(sx * (L / 2 + ce), sy * (W / 2 + ce), id=f"corner-{n}"),
            )
        top = self.H - DECK_DEPTH
        for n, (x, y, yaw, length) in enumerate(
            ((0.0, -W / 2, 0.0, L), (0.0, W / 2, 180.0, L), (-L / 2, 0.0, -90.0, W), (L / 2, 0.0, 90.0, W)), 1
        ):
            self.add(
                f"roof_edge_{'x' if n <= 2 else 'y'}",
                "deck",
                "structure",
                partial(box_between, (-length / 2 - e, -e, 0.0), (length / 2 + e, 0.0, DECK_DEPTH)),
                place(x, y, top, yaw, id=f"roof-edge-{n}"),
            )

    def plan_doors(self, cross_bays):
        """Doors: both gables at the main aisle, the south wall at rack cross aisles, the
        north wall in the last bay (hall). Each gets a bollard either side, inside."""
        L, W, e = self.L, self.W, self.e
        self.doors = [(-L / 2 - e, self.aisle_y, -90.0), (L / 2 + e, self.aisle_y, 90.0)]
        for i in cross_bays:
            self.doors.append(((self.xs[i] + self.xs[i + 1]) / 2, -W / 2 - e, 0.0))
        if self.preset.mezzanine:
            self.doors.append(((self.xs[-2] + self.xs[-1]) / 2, W / 2 + e, 180.0))

    # -- crane ----------------------------------------------------------------------------
    def cranes(self):
        j = self.crane_span
        if j is None:
            return
        off = 0.15 * self.k + 0.35  # runway axis off the column row
        y0, y1 = self.ys[j] + off, self.ys[j + 1] - off
        z = self.rail_z - RAIL_HEIGHT - RUNWAY_DEPTH
        for n, y in enumerate((y0, y1)):
            for i in range(self.n_bays):
                self.add(
                    "crane_runway_beam",
                    "steel",
                    "structure",
                    partial(crane_runway, self.bay_w, scale=self.k),
                    place(self.xs[i], y, z, id=f"runway-{n + 1}-{i + 1:02d}"),
                )
        count = max(1, round(self.preset.cranes * _share(self.amount, 0.5)))
        rng = self.rng("cranes")
        lo, hi = self.xs[0] + 4.0, self.xs[-1] - 4.0
        xs = np.sort(lo + (hi - lo) * (np.arange(count) + rng.uniform(0.2, 0.8, count)) / count)
        span = y1 - y0
        hook, pendant = self.rail_z - 3.7, self.rail_z - 1.55
        for n, x in enumerate(xs, 1):
            self.add(
                "hall_crane",
                "crane",
                "structure",
                partial(bridge_crane, span, hook, pendant),
                place(float(x), (y0 + y1) / 2, self.rail_z, id=f"crane-{n}"),
            )

    # -- racks ----------------------------------------------------------------------------
    def racks(self) -> list[int]:
        """Pallet racking in the rack zone; returns the column bays left free as cross aisles."""
        if not self.preset.racks or not self.beam_levels:
            return []
        W = self.W
        centres = []  # double rows, aisle side first
        pitch = self.span_w / max(1, math.floor(self.span_w / RACK_PITCH_MIN))
        y = self.ys[self.aisle_row]
        wall_row = -W / 2 + self.e + 0.1 + RACK_DEPTH / 2  # single row against the south wall
        while y - RACK_DEPTH - 0.15 - 3.0 >= wall_row + RACK_DEPTH / 2:
            centres.append(y)
            y -= pitch
        rows = []  # (y of the row axis, facing north?)
        for c in centres:
            rows += [(c + RACK_DEPTH / 2 + 0.15, True), (c - RACK_DEPTH / 2 - 0.15, False)]
        if centres and centres[-1] - RACK_DEPTH - 0.15 - wall_row - RACK_DEPTH / 2 >= 3.0:
            rows.append((wall_row, True))
        cross = [i for i in range(self.n_bays) if self.n_bays >= 5 and i % 5 == 2] or [self.n_bays // 2]
        bays = [i for i in range(self.n_bays) if i not in cross]
        per_bay = max(1, math.floor((self.bay_w - 1.2) / RACK_BAY_PITCH))
        levels = (0.0,) + self.beam_levels
        # as many rack bays as the racks' share of the target fills: whole rows from the
        # aisle southwards, the last one from the east end
        wanted = self.target * RACK_SHARE / (len(levels) * len(RACK_SLOTS) * SLOT_TRIANGLES)
        column_bays = max(1, math.ceil(wanted / per_bay))
        d = self.rng("rack loads")
        for r, (y, north) in enumerate(rows, 1):
            if column_bays <= 0:
                break
            row_bays, column_bays = bays[max(0, len(bays) - column_bays) :], column_bays - len(bays)
            k = frame = guard = 0  # numbered along the row from the west
            for i in row_bays:
                start = (self.xs[i] + self.xs[i + 1]) / 2 - per_bay * RACK_BAY_PITCH / 2
                frames = [start + b * RACK_BAY_PITCH for b in range(per_bay + 1)]
                yaw = 180.0 if north else 0.0
                for b in range(per_bay):
                    k += 1
                    x0 = frames[b + 1] if north else frames[b]  # the bay's frame end, seen from its aisle
                    self.add(
                        "rack_beams",
                        "rack_beams",
                        "rack",
                        partial(rack_beams, self.beam_levels),
                        place(x0, y, 0.0, yaw, id=f"rack-{r}-bay-{k:03d}"),
                    )
                    for t, z in enumerate(levels):
                        for s, dx in enumerate(RACK_SLOTS):
                            load = _draw_load(d)
                            self.slots.append(
                                Slot(
                                    f"pallet-r{r}-{k:03d}-{t}{s}",
                                    start + (b + 0.5) * RACK_BAY_PITCH + dx,
                                    y,
                                    z,
                                    90.0,
                                    load,
                                )
                            )
                for x in frames:
                    frame += 1
                    self.add(
                        "rack_frame",
                        "rack_frame",
                        "rack",
                        partial(rack_frame, self.rack_h),
                        place(x, y, 0.0, yaw, id=f"rack-{r}-frame-{frame:03d}"),
                    )
                for x, end_yaw in ((frames[0], 0.0), (frames[-1], 180.0)):  # protectors at both segment ends
                    guard += 1
                    self.add(
                        "rack_guard",
                        "bollard",
                        "rack",
                        partial(rack_guard),
                        place(x, y, 0.0, end_yaw, id=f"rack-{r}-guard-{guard:02d}"),
                    )
        return cross

    # -- production lines -----------------------------------------------------------------
    def lines(self):
        p = self.preset
        n_lines = max(1, min(self.n_lines, math.floor((self.zone_y1 - self.zone_y0) / LINE_BAND)))
        pitch = (self.zone_y1 - self.zone_y0) / n_lines
        first, last = self.line_bays
        avail = last - first
        length = max(min(avail, 2), round(avail * _share(self.amount, 0.15)))
        first = last - length  # lines end at the east
        self.line_extent = (first, last)
        rng = self.rng("lines")
        cells = []
        for li in range(n_lines):
            y = self._clear_of_rows(self.zone_y0 + pitch * li + FENCE_DEPTH[0] + 1.1)
            self.line_ys.append(y)
            n_cells = max(1, min(int(rng.integers(p.cells[0], p.cells[1] + 1)), self.max_cells, length))
            # the easternmost cell needs room east of its door for the robot_cell view
            cell_bays = _spread(first + len(self.storage_bays), last - 1 - (last == self.n_bays), n_cells)
            self._conveyor(li + 1, y, first, last)
            for i in range(first, last):
                xc = (self.xs[i] + self.xs[i + 1]) / 2
                if i in self.storage_bays:
                    continue
                if i in cell_bays:
                    cells.append(self._robot_cell(len(cells) + 1, li, xc, y, rng))
                elif (i - first) % 4 == 3:
                    self._workstations(li + 1, i, xc, y)
                else:
                    self._machines(li + 1, i, xc, y, rng)
        self.line_cells = cells

    def _clear_of_rows(self, y):
        """Move a conveyor axis at least 1.2 m off any column row (it must pass the columns)."""
        for row in self.ys:
            if abs(y - row) < 1.2:
                y = row + 1.2 if y >= row else row - 1.2
        return float(y)

    def _conveyor(self, line, y, first, last):
        x0, x1 = self.xs[first] + 0.6, self.xs[last] - 0.6
        n = max(1, math.floor((x1 - x0) / CONVEYOR_SEGMENT))
        mm = CONVEYOR_SEGMENT * 1000.0
        for s in range(n):
            x = x0 + s * CONVEYOR_SEGMENT
            if s < n - 1:
                self.add(
                    "conveyor",
                    "conveyor",
                    "conveyor",
                    partial(conveyor_segment, mm, False),
                    place(x, y, id=f"line-{line}-conveyor-{s + 1:02d}"),
                )
            else:
                self.add(
                    "conveyor_drive",
                    "conveyor",
                    "conveyor",
                    partial(conveyor_segment, mm, True),
                    place(x, y, id=f"line-{line}-drive"),
                )

    def _robot_cell(self, n, line_index, xc, y, rng) -> dict:
        """A fenced robot cell straddling the conveyor in the column bay centred on ``xc``."""
        fw = float(min(6, math.floor(self.bay_w - 1.2)))
        x0, x1 = xc - fw / 2, xc + fw / 2
        y0, y1 = y - FENCE_DEPTH[0], y + FENCE_DEPTH[1]
        door_y = y0 + 3.5  # a panel midpoint on the east side
        posts, panels = fence_layout((x0, y0, x1, y1), 1.0, openings=((x0, y), (x1, y), (x1, door_y)))
        for m, (px, py) in enumerate(posts, 1):
            self.add(
                "fence_post",
                "fence",
                "equipment",
                partial(fence_post, FENCE_HEIGHT),
                place(float(px), float(py), id=f"cell-{n}-post-{m:02d}"),
            )
        for m, (mid, heading) in enumerate(panels, 1):
            self.add(
                "fence_panel",
                "fence",
                "equipment",
                partial(fence_panel, 1.0, 0.15, 2.05),
                place(float(mid[0]), float(mid[1]), 0.0, float(heading), id=f"cell-{n}-panel-{m:02d}"),
            )
        share = self.preset.robot_share * self.target
        name = arms.choose_robot(rng, share / (self.n_lines * self.max_cells))  # the allowance per cell
        ry = y + ROBOT_OFFSET
        reach = min(fw / 2, y1 - ry, ry - y0) - 0.3
        joints = arms.working_pose(name, rng, reach)
        self.robots.append(name)
        self.parts[f"robot_{n}"] = PartPlan(
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
        self.pedestals.append(place(xc, ry, id=f"pedestal-{n}"))
        self.cell_slots.append(Slot(f"pallet-c{n}", x0 + 1.0, y1 - 1.0, 0.0, 90.0, "cartons_full"))
        self.add(
            "control_cabinet",
            "cabinet",
            "machine",
            partial(control_cabinet),
            place(x1 - 0.7, y1 + 0.45, 0.0, 180.0, id=f"cell-{n}-cabinet"),
        )  # behind the fence, facing out
        return {"n": n, "line": line_index, "x0": x0, "x1": x1, "xc": xc, "y": y, "door_y": door_y, "robot_y": ry}

    def _machines(self, line, i, xc, y, rng):
        """North of the conveyor a machining centre or a press, south a workbench and a cabinet."""
        if rng.random() < 0.65:
            self.add(
                "machining_centre",
                "machine",
                "machine",
                partial(machining_centre),
                place(xc, y + 2.6, id=f"line-{line}-cnc-{i + 1:02d}"),
            )
        else:
            self.add(
                "press",
                "press",
                "machine",
                partial(assembly_press),
                place(xc, y + 2.2, id=f"line-{line}-press-{i + 1:02d}"),
            )
        self.slots.append(Slot(f"pallet-l{line}-{i + 1:02d}", xc - 2.4, y + 2.6, 0.0, 90.0, _draw_load(rng)))
        self.add(
            "workbench",
            "bench",
            "equipment",
            partial(workbench),
            place(xc - 1.2, y - 0.95, id=f"line-{line}-bench-{i + 1:02d}"),
        )
        self.add(
            "control_cabinet",
            "cabinet",
            "machine",
            partial(control_cabinet),
            place(xc + 1.4, y - 0.95, id=f"line-{line}-cabinet-{i + 1:02d}"),
        )

    def _workstations(self, line, i, xc, y):
        """Manual workstations: two benches either side of the conveyor."""
        for m, (dx, dy, yaw) in enumerate(
            ((-1.2, -0.95, 0.0), (1.2, -0.95, 0.0), (-1.2, 0.95, 180.0), (1.2, 0.95, 180.0))
        ):
            self.add(
                "workbench",
                "bench",
                "equipment",
                partial(workbench),
                place(xc + dx, y + dy, 0.0, yaw, id=f"line-{line}-bench-{i + 1:02d}{'abcd'[m]}"),
            )

    # -- floor storage, pits, mezzanine ---------------------------------------------------
    def floor_storage(self, x0, y0, x1, y1, prefix, purpose):
        """Block storage of single pallets (1.2 m along x) in pairs of rows with 2.5 m lanes."""
        rng = self.rng(purpose)
        xs = np.arange(x0 + 0.65, x1 - 0.6, 1.35)
        ys, y = [], y0 + 0.45
        while y + 0.45 <= y1:
            ys.append(y)
            y += 0.95 if len(ys) % 2 else 3.45
        for r, yy in enumerate(ys):
            for c, xx in enumerate(xs):
                self.slots.append(
                    Slot(f"pallet-{prefix}-{r + 1:02d}{c + 1:02d}", float(xx), float(yy), 0.0, 0.0, _draw_load(rng))
                )

    def plan_pits(self):
        """Pits in the production zone's free east end (hall, line)."""
        n = max(1 if self.preset.pits else 0, round(self.preset.pits * _share(self.amount, 0.3)))
        if not n:
            return
        x = (self.xs[self.line_bays[1]] + self.xs[-1]) / 2
        rng = self.rng("pits")
        span = self.zone_y1 - self.zone_y0 - (6.0 if self.preset.mezzanine else 0.0)
        for m in range(n):
            y = self.zone_y0 + span * (m + 0.5) / n
            ln, w = float(rng.uniform(3.0, min(5.0, self.bay_w - 3.0))), float(rng.uniform(2.0, 3.0))
            self.pits.append((float(x), float(y), round(ln, 2), round(w, 2), round(float(rng.uniform(0.9, 1.6)), 2)))

    def place_mezzanine(self):
        """Platform over the west bays at the north wall, with cabinets on it; its stair runs south."""
        x0 = self.xs[0] + 0.6
        length = self.xs[self.line_bays[0]] - 0.6 - x0
        width = min(7.0, (self.zone_y1 - self.zone_y0) / 3)
        deck = 4.0
        y0 = self.zone_y1 - width
        self.add(
            "hall_mezzanine",
            "mezzanine",
            "structure",
            partial(mezzanine, length, width, deck),
            place(x0, y0, id="mezzanine-1"),
        )
        for m in range(3):
            self.add(
                "control_cabinet",
                "cabinet",
                "machine",
                partial(control_cabinet),
                place(x0 + 1.0 + 0.85 * m, y0 + width - 0.45, deck, 180.0, id=f"mezzanine-cabinet-{m + 1}"),
            )
        self.mezz = (x0, y0, length, width, deck)
        return y0 - stair_run(deck) - 1.0

    # -- services, markings, bollards -----------------------------------------------------
    def services(self):
        """Cable trays over the lines outside the crane span, pipe runs along the long walls,
        high-bay lights on the trusses outside the crane span."""
        crane = self.crane_span
        z_tray = self.zc - 1.0
        first, last = self.line_extent
        for li, y in enumerate(self.line_ys, 1):
            if self.in_crane_span(y):
                continue
            for i in range(first, last):
                self.add(
                    "ceiling_cable_tray",
                    "tray",
                    "services",
                    partial(cable_tray, self.bay_w, 1.0),
                    place(self.xs[i], y - 0.8, z_tray, id=f"tray-{li}-{i + 1:02d}"),
                )
        z_pipe = self.zc - 0.6
        hang = self.zc + self.truss_depth - z_pipe
        walls = (("N", self.W / 2 - 1.0), ("S", -self.W / 2 + 1.0))
        for side, y in walls[: 0 if self.amount < TINY else 1 if self.amount < 0.05 else 2]:
            for i in range(self.n_bays):
                self.add(
                    "ceiling_pipe_run",
                    "pipe",
                    "services",
                    partial(pipe_run, self.bay_w, hang),
                    place(self.xs[i], y, z_pipe, id=f"pipes-{side}-{i + 1:02d}"),
                )
        n = 0
        for j in range(self.n_spans):
            if j == crane or self.amount < TINY:
                continue
            for m in range(max(1, round(self.span_w / 5.0))):
                y = self.ys[j] + (m + 0.5) * self.span_w / max(1, round(self.span_w / 5.0))
                for x in self.xs[1:-1]:
                    n += 1
                    self.add(
                        "roof_light",
                        "light",
                        "services",
                        partial(high_bay_light, 1.0),
                        place(float(x), float(y), self.zc, id=f"light-{n:03d}"),
                    )

    def markings_and_bollards(self, cross_bays):
        L = self.L
        n = 0
        for edge in (self.aisle_y - AISLE_WIDTH / 2, self.aisle_y + AISLE_WIDTH / 2):  # aisle edge lines per bay
            for i in range(self.n_bays):
                n += 1
                self.add(
                    "floor_marking",
                    "marking",
                    "structure",
                    partial(floor_marking, self.bay_w - 0.2),
                    place(self.xs[i] + 0.1, edge, id=f"marking-{n:03d}"),
                )
        if self.preset.racks:  # cross aisles through the rack zone
            length = self.aisle_y - AISLE_WIDTH / 2 - (-self.W / 2 + self.e + 0.3)
            for i in cross_bays:
                for dx in (-1.6, 1.6):
                    n += 1
                    self.add(
                        "floor_marking_cross",
                        "marking",
                        "structure",
                        partial(floor_marking, length),
                        place(
                            (self.xs[i] + self.xs[i + 1]) / 2 + dx,
                            -self.W / 2 + self.e + 0.3,
                            yaw_deg=90.0,
                            id=f"marking-{n:03d}",
                        ),
                    )
        spots = []
        for x, y, yaw in self.doors:  # both sides of every door, inside
            inward = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw))])
            along = np.array([inward[1], -inward[0]])
            for s in (-1.0, 1.0):
                spots.append(np.array([x, y]) + inward * 0.6 + along * s * (self.door_w / 2 + 0.35))
        north = self.aisle_y + AISLE_WIDTH / 2 + 0.35  # the production side of the aisle
        for x in self.xs[1:-1] if self.amount >= TINY else []:
            spots.append(np.array([x, north]))
        # the aisle's north edge past the west door, in line with the door's own bollards
        spots.append(np.array([-L / 2 + 2.0, self.aisle_y + self.door_w / 2 + 0.35]))
        for m, (x, y) in enumerate(spots, 1):
            self.add(
                "bollard", "bollard", "equipment", partial(bollard), place(float(x), float(y), id=f"bollard-{m:03d}")
            )

    # -- viewpoints -----------------------------------------------------------------------
    def viewpoints(self) -> list[dict]:
        L, W = self.L, self.W
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
        view("aisle", (x_eye, self.aisle_y + 1.4, EYE), (x_eye + 60.0, self.aisle_y + 0.5, 0.2))
        if self.preset.mezzanine:  # 0.6 m behind the platform's east rail, looking down the hall
            x0, y0, length, width, deck = self.mezz
            eye = (x0 + length - 0.6, y0 + 1.2, deck + EYE)
            view("mezzanine", eye, (eye[0] + 60.0, eye[1] - 15.0, -10.0))
        # the cell seen through its open fence door from 1.5 m outside, looking west along the
        # line (the far gable behind it); the easternmost cell of a line outside the crane span
        cell = max(self.line_cells, key=lambda c: (not self.in_crane_span(c["y"]), c["x0"]))
        view("robot_cell", (cell["x1"] + 1.5, cell["door_y"] + 0.1, EYE), (cell["xc"], cell["robot_y"], 1.0))
        # from high in the north-west corner (above the floor storage or the mezzanine, beside
        # the wall's pipe run) across the production lines to the racks
        view("overview", (-L / 2 + 1.5, W / 2 - 1.5, self.zc - 1.2), (L / 2, self.aisle_y, 0.0))
        return views


def _draw_load(rng) -> str | None:
    """What stands on a pallet, drawn with LOAD_WEIGHTS (None: the pallet is empty)."""
    names = list(LOAD_WEIGHTS)
    return names[int(rng.choice(len(names), p=list(LOAD_WEIGHTS.values())))]


def plan_scene(preset: Preset, size, seed: int, target: int, amount: float) -> Plan:
    """Every placement of a ``preset`` scene of ``size`` (m) for ``seed`` at ``amount`` (0..1]."""
    lay = _Layout(preset, size, seed, target, amount)
    cross = lay.racks()
    lay.plan_doors(cross)
    lay.plan_pits()
    storage_y1 = lay.place_mezzanine() if preset.mezzanine else lay.zone_y1 - 1.0
    lay.lines()
    scale = max(arms.pedestal_scale(name) for name in lay.robots)  # one pedestal for the largest base
    for inst in lay.pedestals:
        lay.add("robot_pedestal", "pedestal", "equipment", partial(robot_pedestal, PEDESTAL_TOP, scale=scale), inst)
    if preset.racks:  # floor storage at the free west end of the production zone
        lay.floor_storage(
            lay.xs[0] + 1.0, lay.zone_y0 + 0.5, lay.xs[lay.line_bays[0]] - 1.0, storage_y1, "f", "storage"
        )
    else:  # the cell: in the first bay north of the conveyor, and along the south wall
        lay.floor_storage(lay.xs[0] + 0.8, lay.line_ys[0] + 1.2, lay.xs[1] - 0.5, lay.zone_y1 - 0.3, "f", "storage")
        wall = -lay.W / 2 + lay.e + 0.1
        lay.floor_storage(lay.xs[0] + 1.0, wall, lay.xs[-1] - 1.0, wall + 0.95, "w", "wall storage")
    lay.building()
    lay.cranes()
    lay.services()
    lay.markings_and_bollards(cross)
    # fill order: the cells' own pallets first, then every other place in a seeded order
    order = lay.rng("fill order").permutation(len(lay.slots))
    slots = lay.cell_slots + [lay.slots[i] for i in order]
    return Plan(
        preset.name,
        preset.description,
        list(lay.parts.values()),
        slots,
        sorted(set(lay.robots)),
        lay.viewpoints(),
        seed,
    )


__all__ = ["plan_scene", "conveyor_segment", "AISLE_WIDTH", "EYE"]
