"""Levels of detail: how finely the part builders tessellate and how much small detail they add.

The scene generator meets a triangle target by choosing a level (this module) and the number
of repeated things (``layout``). A level never changes what a part is or where it stands, only
its tessellation and small detail: round parts get more sides, bolts appear, conveyors get
more rollers, fence panels their welded mesh, cartons subdivided faces (as a tessellating CAD
exporter would write them).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Detail:
    """One level of detail (frozen: it keys the builders' caches)."""

    level: int
    sections: int  # sides of small round parts (bolts, rollers, pipes); bollards 1.5x
    bolts: bool  # anchor and flange bolts drawn at all
    roller_pitch: float  # mm, conveyor roller spacing
    wire_pitch: float | None  # m, welded mesh of fence panels; None: a plain infill sheet
    carton_divisions: int  # faces of a carton split into n x n quads
    rib_pitch: float | None  # m, ribs of wall cladding and roof deck; None: flat sheets
    truss_bays: bool  # roof trusses with diagonals (else solid girders)


# level 4 is what the hand-built sample cell uses (16-sided cylinders, M20 bolts, 100 mm
# roller pitch, 50 mm mesh); levels beyond the table keep its last row and subdivide
# cartons further, so there is no upper limit to the triangles a scene can be given.
# Neighbouring levels differ by small steps so that a triangle target finds a level
# whose fixed part leaves a fair share to the pallets.
_TABLE = (
    # sections bolts roller wire   cartons ribs  truss
    (6, False, 200.0, None, 1, None, False),
    (8, False, 200.0, 0.10, 1, None, True),
    (8, False, 150.0, 0.10, 1, 0.6, True),
    (12, True, 100.0, 0.10, 1, 0.3, True),
    (16, True, 100.0, 0.05, 1, 0.3, True),
    (20, True, 75.0, 0.05, 2, 0.25, True),
    (24, True, 75.0, 0.05, 3, 0.2, True),
    (32, True, 60.0, 0.05, 4, 0.2, True),
)
SAMPLE_LEVEL = 4


def detail(level: int) -> Detail:
    """The :class:`Detail` of ``level`` (0 = coarsest; any level >= 0 is valid)."""
    if level < 0:
        raise ValueError(f"level must be >= 0, got {level}")
    row = _TABLE[min(level, len(_TABLE) - 1)]
    sections, bolts, roller, wire, cartons, ribs, truss = row
    cartons += max(0, level - (len(_TABLE) - 1))
    return Detail(level, sections, bolts, roller, wire, cartons, ribs, truss)


SAMPLE_DETAIL = detail(SAMPLE_LEVEL)

__all__ = ["Detail", "detail", "SAMPLE_DETAIL", "SAMPLE_LEVEL"]
