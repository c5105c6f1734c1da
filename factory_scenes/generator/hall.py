"""The hall a layout fills: its column grid and zones, and the parts and pallet places placed so far.

World frame: Z up, metres, the floor's top face at z = 0, the hall centred on the origin with
its length along x and its width along y. The hall is a grid of steel columns (rows along x
lettered A, B, ... from the south wall, lines along y numbered from the west gable). From
south to north: the rack zone, the main aisle, the production zone. :class:`Hall` computes
the grid and the zones once; the zone modules (``place_building``, ``place_racks``,
``place_lines``, ``place_services``) place their parts into it through :meth:`Hall.add`.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from .plan import PartPlan, Slot
from .presets import COLORS, Preset
from .structure import DECK_DEPTH, PURLIN_DEPTH, RAIL_HEIGHT, RUNWAY_DEPTH

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


def amount_share(amount: float, full_at: float) -> float:
    """Fraction (0..1] of something a plan of ``amount`` holds: all of it from ``full_at`` on."""
    return min(1.0, max(amount, 1e-6) / full_at)


def spread_indices(first: int, last: int, count: int) -> list[int]:
    """``count`` indices spread evenly from ``first`` to ``last`` inclusive (last first)."""
    if count <= 1:
        return [last]
    return sorted({int(round(v)) for v in np.linspace(last, first, count)})


class Hall:
    """The plan being built: the column grid, the zones, and what is placed so far (one
    instance per :meth:`add`, pallet places in ``slots``)."""

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
        self.n_lines = max(1, round(preset.lines * amount_share(amount, 0.6)))
        self.max_cells = max(1, round(preset.cells[1] * amount_share(amount, 0.3)))
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


__all__ = ["Hall", "amount_share", "spread_indices", "STREAMS", "AISLE_WIDTH", "EYE", "TINY"]
