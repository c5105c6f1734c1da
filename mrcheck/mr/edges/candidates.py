"""The CAD edges worth sampling at one pyramid level, kept between the re-renders of a fit.

Why: a fit re-renders and re-finds the visible edges every 1.5 level px of motion, about 20 times
at 1280x960. The generated cell has 223 000 mesh edges; sampling all of them (front test, clip,
projection, about 72 000 candidate points) and testing every candidate against the depth buffer
took 0.3-0.4 s per re-render on this machine, more than half of a fit. Between two re-renders
the pose moves by a pixel or two, and the edges seen change only at occlusion borders and at the
image border; so after a full sampling only the edges that then had a visible, salient sample
(:func:`mrcheck.mr.edges.model.salient`) are sampled again while the view stays within
:data:`REUSE_PX` level px of the pose they were found at. Beyond that (the coarse stage's shift
search moves the view by up to the search radius) the level is sampled in full again.

The spacing of a level is fixed at its first sampling (widened there for a dense scene, see
:func:`~mrcheck.mr.edges.model.sample_edges`): widened anew at every re-render, the sample
positions along the edges changed with the pose, and with them which samples the thinning
kept, a noise in the cost that made the fit take more steps (measured on the cell at
1280x960: 22 re-renders with a fixed spacing's samples, 36 with the re-widened ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import model

REUSE_PX = 4.0  # the view moved less than this (level px) since the full sampling: reuse its edges
_PROBES = 256  # points whose motion measures the view's


@dataclass
class _Entry:
    among: np.ndarray  # edge indices that had a visible, salient sample
    spacing_px: float  # the spacing of the full sampling (full-resolution px)
    probes: np.ndarray  # (k, 3) world points of visible samples
    uv: np.ndarray  # (k, 2) their pinhole pixels (full resolution) at that pose


class CandidateEdges:
    """Per level scale: the edges seen at the last full sampling (see the module docstring)."""

    def __init__(self, edges: model.EdgeSet):
        self.edges = edges
        self.entries: dict = {}
        self.full_samplings = 0  # how often the level was sampled in full (a figure for tests)

    def sample(self, camera: Camera, scale: float, spacing_px: float, max_count: int) -> tuple:
        """``(samples, fresh)``: the candidate samples at ``camera``'s pose (before the depth test) and
        whether they come from a full sampling (then :meth:`remember` the salient ones)."""
        entry = self.entries.get(scale)
        if entry is None:
            self.full_samplings += 1
            return model.sample_edges(self.edges, camera, spacing_px, max_count=max_count), True
        if len(entry.probes):
            # a high percentile, not the maximum: a point a metre before the camera moves by ten
            # times a far one's, and the view is what changes visibility
            shift = np.linalg.norm(model.project_pinhole(camera, entry.probes) - entry.uv, axis=1)
            moved = np.percentile(shift, 90) * scale
            if np.isfinite(moved) and moved < REUSE_PX:
                return model.sample_edges(self.edges, camera, entry.spacing_px, among=entry.among), False
        self.full_samplings += 1
        return model.sample_edges(self.edges, camera, entry.spacing_px), True

    def remember(self, camera: Camera, scale: float, visible: model.Samples) -> None:
        """Keep the edges of the ``visible`` (and salient) samples of a full sampling at ``camera``'s pose."""
        pick: np.ndarray | list[int] = (
            np.linspace(0, len(visible) - 1, min(_PROBES, len(visible))).astype(int) if len(visible) else []
        )
        probes = visible.points[pick]
        self.entries[scale] = _Entry(
            np.unique(visible.edge), visible.spacing_px, probes, model.project_pinhole(camera, probes)
        )


__all__ = ["CandidateEdges", "REUSE_PX"]
