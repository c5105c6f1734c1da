"""Unexplained photo structure (:func:`unexplained_regions`): photo edges far from every CAD edge,
grouped into regions, the "extra" suggestions of :func:`~mrcheck.apps.discrepancies.detector.detect`
(its docstring, item 6); and the plain floor (:func:`plain_ground`) whose texture sets the edge
strength such structure needs (:func:`~mrcheck.apps.discrepancies.edges.texture_edges`)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.discrepancies.planned import PlannedView
from mrcheck.apps.discrepancies.thresholds import MIN_REGION_PIXELS


@dataclass
class Region:
    """Photo structure no CAD edge explains (an added object, clutter)."""

    bbox: list[int]  # [x0, y0, x1, y1]
    edge_pixels: int


def far_from_cad(planned: PlannedView, tol: float) -> np.ndarray:
    """(H, W) bool: the pixels farther than ``3 * tol`` from every CAD edge, where a photo edge
    is unexplained (no CAD edge can account for it)."""
    return cv2.distanceTransform((~planned.cad).astype(np.uint8), cv2.DIST_L2, 5) > 3.0 * tol


def unexplained_regions(
    edges: np.ndarray, planned: PlannedView, tol: float, far: np.ndarray
) -> tuple[list[Region], np.ndarray]:
    """Unexplained photo structure: photo edges ``far`` from every CAD edge (:func:`far_from_cad`),
    grouped into regions; returns the regions (largest first) and the unexplained edge pixels. A
    group wholly inside CAD faces above floor level is texture (print, labels), not structure: an
    added object stands on the floor, so its edges reach down to the floor's pixels
    (``planned.ground``)."""
    unexplained = edges & far
    k = max(3, int(round(3 * tol)) | 1)
    grouped = cv2.morphologyEx(unexplained.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((k, k), np.uint8))
    count, comp, stats, _ = cv2.connectedComponentsWithStats(grouped, connectivity=8)
    on_face = planned.ids >= 0 if planned.ground is None else (planned.ids >= 0) & ~planned.ground
    counts = np.bincount(comp[unexplained], minlength=count)
    texture = counts == np.bincount(comp[unexplained & on_face], minlength=count)
    texture[0] = False
    unexplained &= ~texture[comp]  # texture is not shown as unexplained either
    regions = []
    for c in np.nonzero((counts >= MIN_REGION_PIXELS) & ~texture)[0]:
        pixels = int(counts[c])
        x, y, bw, bh = (int(v) for v in stats[c, :4])
        regions.append(Region([x, y, x + bw - 1, y + bh - 1], pixels))
    regions.sort(key=lambda r: -r.edge_pixels)
    return regions, unexplained


def plain_ground(planned: PlannedView, far: np.ndarray) -> np.ndarray:
    """The planned floor ``far`` from every CAD edge (:func:`far_from_cad`): where the photo
    shows the floor's own texture, if anything."""
    return np.zeros_like(planned.cad) if planned.ground is None else planned.ground & far


__all__ = ["Region", "unexplained_regions", "plain_ground", "far_from_cad"]
