"""How well the per-element status finds small as-built shifts: simulated scans
(:mod:`mrcheck.eval.scansim`) of shifted variants of a planned scene, scored against what was moved.

Protocol (one seed): move ``share`` of the movable instances by ``low_mm`` .. ``high_mm``
horizontally, add clutter boxes, scan the result from ``stations`` scanner positions
(2-5 mm range noise, occlusion, stray returns), then run :func:`element_status` of the scan
against the *planned* scene at ``tolerance_mm``. Truth: "out of tolerance" for an instance
moved by more than the tolerance, "installed" for every other one. Positives are the
"out of tolerance" calls; a call without evidence ("not found", "not enough data",
"occluded") counts as not out (a moved element without data is a miss). Precision, recall
and F1 over every instance with triangles, structure included.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from mrcheck.apps.deviation.distances import closest_surface
from mrcheck.apps.deviation.elements import NO_EVIDENCE, element_status
from mrcheck.eval.scansim import clutter_parts, scanner_stations, shifted_variant, simulate_scan


@dataclass
class ElementScore:
    """One seed's counts and figures."""

    seed: int
    instances: int
    points: int
    tp: int
    fp: int
    fn: int
    tn: int
    no_data: int  # instances called "not found", "not enough data" or "occluded"
    moved_no_data: int  # of them moved beyond the tolerance
    seconds: float
    misses: list = field(default_factory=list)  # ids of the wrong calls, "fp:" / "fn:" prefixed

    @property
    def precision(self) -> float:
        return self.tp / max(self.tp + self.fp, 1)

    @property
    def recall(self) -> float:
        return self.tp / max(self.tp + self.fn, 1)

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 0.0 if p + r == 0 else 2 * p * r / (p + r)


def _score(rows, shifts, tolerance_mm: float) -> dict:
    moved = {s.id for s in shifts if np.hypot(*s.vector[:2]) * 1000.0 > tolerance_mm}
    counts = dict(tp=0, fp=0, fn=0, tn=0, no_data=0, moved_no_data=0)
    misses = []
    for row in rows:
        called, truth = row.status == "out of tolerance", row.id in moved
        key = ("tp" if truth else "fp") if called else ("fn" if truth else "tn")
        counts[key] += 1
        if key in ("fp", "fn"):
            misses.append(f"{key}:{row.id}")
        if row.status in NO_EVIDENCE:
            counts["no_data"] += 1
            counts["moved_no_data"] += truth
    return {**counts, "misses": misses}


def score_seed(
    planned,
    seed: int,
    tolerance_mm: float = 10.0,
    share: float = 0.3,
    low_mm: float = 5.0,
    high_mm: float = 50.0,
    stations: int = 4,
    rays: int = 1_000_000,
    clutter: int = 12,
) -> ElementScore:
    """One seed of the protocol (module docstring) on a loaded planned scene."""
    variant, shifts = shifted_variant(planned, share, low_mm / 1000.0, high_mm / 1000.0, seed)
    scanned = replace(variant, parts=variant.parts + clutter_parts(variant, clutter, seed))
    positions = scanner_stations(scanned, stations, seed)
    scan = simulate_scan(scanned, positions, rays, seed)
    start = time.perf_counter()
    surface = closest_surface(planned, scan.points, normals=True)
    rows = element_status(surface, planned, scan.points, tolerance_mm, scanners=positions)
    seconds = time.perf_counter() - start
    return ElementScore(
        seed=seed, instances=len(rows), points=len(scan.points), seconds=seconds, **_score(rows, shifts, tolerance_mm)
    )


__all__ = ["score_seed", "ElementScore"]
