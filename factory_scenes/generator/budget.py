"""Meeting a triangle target: how much content, which level of detail, how many pallets.

Triangles are counted as rendered (a mesh's triangles times its instances), exactly as
``mrcheck.scene.model.Scene.triangle_count`` counts them after loading. The solver

1. plans the preset at ``amount`` = target / the preset's default target (at most 1), and
   lowers the amount until the plan's fixed part (everything but pallets) at the coarsest
   level leaves room for pallets;
2. tries the levels of detail from the coarsest: at each, pallet places are filled in the
   plan's seeded order until the total is as close to the target as one pallet allows; the
   first level whose fixed part alone exceeds the target is tried too when no coarser level
   came close (a cell whose robot takes most of the target jumps past it between levels);
3. keeps the level that hits the target (within CLOSE) with a fill share nearest to
   FILL_RANGE (racks neither nearly empty nor full), preferring the finer of equals. Beyond
   the detail table cartons get finer without end, so every target is reachable.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .detail import Detail, detail
from .layout import plan_scene
from .plan import MeshCache, Plan
from .presets import Preset

FILL_RANGE = (0.5, 0.85)  # share of pallet places filled that looks like a working plant
CLOSE = 0.02  # a level whose best fill is this close to the target counts as a hit
MIN_AMOUNT = 0.002  # below this a plan holds one line of two bays, one rack row: nothing left to drop
AMOUNT_STEP = 0.7  # factor by which the amount shrinks while the fixed part is too large
TOLERANCE = 0.1  # the promise: within 10 % of the target


@dataclass
class Solution:
    plan: Plan
    detail: Detail
    filled: int  # pallet places filled (the first ones in the plan's order)
    triangles: int  # as rendered


def solve(preset: Preset, size, seed: int, target: int, cache: MeshCache) -> Solution:
    """The plan, level and fill whose triangle count is closest to ``target``, however far off
    (the caller decides whether a miss by more than TOLERANCE is an error or a warning)."""
    amount = min(1.0, target / preset.default_target)
    while True:
        plan = plan_scene(preset, size, seed, target, amount)
        if plan.fixed_triangles(detail(0), cache) <= target * (1 - TOLERANCE) or amount <= MIN_AMOUNT:
            break
        amount *= AMOUNT_STEP
    best = None
    for level in itertools.count():
        d = detail(level)
        fixed = plan.fixed_triangles(d, cache)
        if fixed > target and best is not None and not best[0][0]:
            break  # a hit already; finer levels only grow the fixed part
        slots = plan.slot_triangles(d, cache)
        totals = fixed + np.concatenate([[0], np.cumsum(slots)])
        if fixed > target:
            # reached only when no coarser level came close (a heavy robot in a small cell): the
            # first level above the target, with as many pallets as keep it within the promise
            # (up to FILL_RANGE[0]) rather than none, so the scene still has its pallets
            within = int(np.searchsorted(totals, (1 + TOLERANCE) * target, side="right"))
            filled = max(0, min(within - 1, math.ceil(FILL_RANGE[0] * len(slots))))
        else:
            filled = int(np.argmin(np.abs(totals - target)))
        share = filled / max(1, len(slots))
        # close to the target first, then racks neither nearly empty nor full
        score = (
            abs(int(totals[filled]) - target) > CLOSE * target,
            max(0.0, FILL_RANGE[0] - share, share - FILL_RANGE[1]),
        )
        if best is None or score <= best[0]:
            best = (score, Solution(plan, d, filled, int(totals[filled])))
        if fixed + FILL_RANGE[0] * slots.sum() > target:
            break  # finer levels leave the racks emptier still
    return best[1]


__all__ = ["Solution", "solve", "TOLERANCE"]
