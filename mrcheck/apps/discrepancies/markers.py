"""The review markers a detection suggests (``mrcheck review --suggestions``): one per suspect, on
the part's own planned pixels, and one per unexplained region."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrcheck.apps.discrepancies.planned import PlannedView
from mrcheck.apps.discrepancies.thresholds import MIN_REGION_PIXELS


@dataclass
class Marker:
    """A marker the review tool can import (``mrcheck review --suggestions``)."""

    x: float
    y: float
    category: str  # moved, missing or extra
    severity: int  # 1 .. 3
    note: str
    part: str | None  # the suspect's instance id; None for a region


def _on_part(planned: PlannedView, s) -> tuple[float, float]:
    """The pixel of the suspect's own planned image nearest to its centre: the centre of an
    unsupported outline may lie on the floor or a wall next to it, and a marker there would
    point (and pick, in the review) at that instead."""
    index = next(i for i, (_, name) in enumerate(planned.labels) if name == s.id)
    x0, y0, x1, y1 = s.bbox
    ys, xs = np.nonzero(planned.ids[y0 : y1 + 1, x0 : x1 + 1] == index)
    k = int(np.argmin((xs + x0 - s.centre[0]) ** 2 + (ys + y0 - s.centre[1]) ** 2))
    return float(xs[k] + x0), float(ys[k] + y0)


def suggested_markers(suspects: list, regions: list, planned: PlannedView) -> list[Marker]:
    """Review markers: one per suspect (missing when almost none of it is seen, else moved) on
    the part's own planned pixels, one per unexplained region (extra)."""
    markers = []
    for s in suspects:
        if not s.suspect:
            continue
        category = "missing" if s.support < 0.15 else "moved"
        severity = 3 if s.score >= 0.8 else 2 if s.score >= 0.65 else 1
        markers.append(
            Marker(
                *_on_part(planned, s),
                category,
                severity,
                f"{s.name}: {100 * s.support:.0f} % of its CAD outline found in the photo",
                s.id,
            )
        )
    for r in regions:
        x0, y0, x1, y1 = r.bbox
        markers.append(
            Marker(
                round((x0 + x1) / 2, 1),
                round((y0 + y1) / 2, 1),
                "extra",
                2 if r.edge_pixels >= 4 * MIN_REGION_PIXELS else 1,
                f"photo structure no CAD part explains ({r.edge_pixels} edge px)",
                None,
            )
        )
    return markers


__all__ = ["Marker", "suggested_markers"]
