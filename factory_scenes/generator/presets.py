"""The three presets, the colours of the parts and the units their CAD exports arrive in.

All sizes in metres (length along x, width along y, height along z); triangle counts as
rendered (instances counted).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Preset:
    """What a preset holds at full ``amount`` (see ``layout``), its default size and target."""

    name: str
    size: tuple  # m, length (x), width (y), height (z)
    min_size: tuple  # m, the smallest size its content fits in
    default_target: int  # triangles as rendered
    span: float  # m, aimed distance between column rows (the truss span)
    bay: float  # m, aimed distance between column lines along the hall
    lines: int  # production lines
    cells: tuple  # (fewest, most) robot cells per line
    racks: bool  # a rack zone south of the main aisle
    cranes: int  # bridge cranes over the first line
    mezzanine: bool
    pits: int
    robot_share: float  # share of the triangle target all robots together may take
    description: str


PRESETS = {
    "cell": Preset(
        "cell",
        (20.0, 15.0, 6.0),
        (14.0, 12.0, 5.0),
        150_000,
        15.0,
        6.7,
        1,
        (1, 1),
        False,
        0,
        False,
        0,
        0.66,
        "One fenced robot cell on a short roller conveyor, pallets, a machining centre and a "
        "workbench, in a small steel-framed building.",
    ),
    "line": Preset(
        "line",
        (60.0, 30.0, 8.0),
        (36.0, 22.0, 6.0),
        1_500_000,
        10.0,
        7.5,
        1,
        (2, 4),
        True,
        0,
        False,
        1,
        0.3,
        "One production line with robot cells, machines and workstations along a roller "
        "conveyor, a pallet rack aisle, a floor storage area and a pit.",
    ),
    "hall": Preset(
        "hall",
        (200.0, 80.0, 12.0),
        (80.0, 40.0, 8.0),
        5_000_000,
        20.0,
        10.0,
        3,
        (2, 4),
        True,
        2,
        True,
        3,
        0.3,
        "Production hall: production lines with robot cells, a pallet rack zone, bridge cranes, "
        "a mezzanine, pits, cable trays and pipe runs under the roof.",
    ),
}

COLORS = {  # linear RGB
    "floor": (0.55, 0.55, 0.52),
    "pit": (0.48, 0.48, 0.46),
    "steel": (0.35, 0.42, 0.52),
    "galvanised": (0.62, 0.63, 0.65),
    "deck": (0.72, 0.72, 0.72),
    "wall": (0.78, 0.78, 0.76),
    "crane": (0.9, 0.68, 0.08),
    "conveyor": (0.4, 0.45, 0.5),
    "machine": (0.75, 0.76, 0.78),
    "press": (0.3, 0.45, 0.62),
    "bench": (0.35, 0.45, 0.4),
    "cabinet": (0.78, 0.78, 0.75),
    "fence": (0.9, 0.75, 0.1),
    "pedestal": (0.3, 0.3, 0.32),
    "rack_frame": (0.15, 0.3, 0.6),
    "rack_beams": (0.9, 0.42, 0.08),
    "pallet": (0.55, 0.4, 0.25),
    "cartons": (0.7, 0.52, 0.33),
    "crate": (0.6, 0.47, 0.3),
    "bollard": (0.95, 0.8, 0.05),
    "marking": (0.9, 0.75, 0.1),
    "tray": (0.6, 0.6, 0.6),
    "pipe": (0.25, 0.4, 0.6),
    "light": (0.88, 0.88, 0.86),
    "mezzanine": (0.3, 0.42, 0.32),
}

# Unit a CAD export of each part category arrives in with --units-mix (without it, all metres):
# building and services from the architect in m, conveyors and machines from their makers in
# mm, racks and pallets from a US supplier in inches.
UNITS_MIX = {
    "structure": "m",
    "services": "m",
    "equipment": "m",
    "conveyor": "mm",
    "machine": "mm",
    "rack": "in",
    "storage": "in",
}
UNIT_MISSING_PART = "machining_centre"  # the mm part whose unit scene_unit_missing.toml forgets

__all__ = ["Preset", "PRESETS", "COLORS", "UNITS_MIX", "UNIT_MISSING_PART"]
