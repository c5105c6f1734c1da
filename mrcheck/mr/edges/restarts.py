"""Restarts of an accepted fit when one part fits far worse than the others (:func:`best_of`).

Why: a scene of separate objects shares one camera pose, and a part whose outline hardly
constrains some direction of that pose (a bottle, a body of revolution, turned about its own
axis) leaves that direction to the other parts. When a small part among them lands in a wrong
basin, the large part still fits and the verdict accepts the pose. Measured on DLR M3T frame 200
from 20 px off (seeds 0-9): in 6 of 10 fits the 66 mm prism ended 11.9-16.8 px off while the
bottle was within 2.4-3.0 px; the prism's own support beyond chance was then 0.13-0.27 against
the bottle's 0.55-0.78 (good fits: 0.82-0.85 and 0.71-0.79).

What: the directions of the pose the other parts constrain least (the smallest eigenvalues of
their normal equations) are the ones along which the lagging part can be wrong while they stay
put; a direction they do see (:data:`FREE`) is not tried. The fit is made again (the two finest
levels) from the pose moved along each of the :data:`DIRECTIONS` weakest directions by
:data:`RESTART_PX` at the lagging part, both ways, and the fit with the highest support beyond
chance over all visible samples is kept; the first fit stays unless another beats it by
:data:`MIN_GAIN`. The chamfer schedule's fit also meets the normal schedule's (see
:func:`mrcheck.mr.edges.refine._fit`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import solver
from mrcheck.mr.edges.fitter import Fitter
from mrcheck.mr.edges.model import Samples
from mrcheck.mr.edges.options import EdgeFit, EdgeFitError

# a part below this share of the best part's support beyond chance is lagging (a bound on the
# work, not a verdict: a restart is kept only on evidence). M3T's good fits measured 0.88-0.99 of
# the best part's; seed 7 (the bottle 5.1 px off) 0.83, the prism in a wrong basin 0.19-0.49
LAGGING = 0.9
RESTART_PX = (8.0, 16.0)  # how far the restarts move the lagging part (median px)
DIRECTIONS = 2  # the weakest directions of the other parts' normal equations tried
# a direction is tried only when the other parts' edges move across themselves by at most this
# share of the lagging part's motion (median; 1 px at 8 px): along a direction they see, they pull
# the fit back. Measured: M3T's two weakest directions 0.013-0.11 (seeds 1-8, 20); the generated
# cell's overview (640x480, seeds 0-3, dozens of parts) 0.16-0.69, where restarts cost 8-10 s a
# fit (5x) for no fit moved into another basin
FREE = 0.125
# a restart is kept only when it beats the first fit's support beyond chance by this much: the
# spread of that figure among M3T's good fits from different starts is 0.78-0.82
MIN_GAIN = 0.05


def lagging_part(fit: EdgeFit) -> str | None:
    """The part whose support beyond chance lies below :data:`LAGGING` of the best part's, the
    lowest such; None with fewer than two parts judged or none lagging."""
    parts = fit.part_above
    if len(parts) < 2:
        return None
    lowest = min(parts, key=parts.__getitem__)
    best = max(parts.values())
    return lowest if best > 0 and parts[lowest] < LAGGING * best else None


def best_of(fitter: Fitter, fit: EdgeFit, centre: np.ndarray, refit: Callable) -> EdgeFit:
    """``fit``, or a restart (module docstring) that beats it; ``centre``: the pose's centre of
    rotation; ``refit(pose)``: the two finest levels and the verdict from a
    :class:`~mrcheck.mr.edges.solver.PoseState` (an :class:`EdgeFitError` when refused)."""
    lag = lagging_part(fit)
    if lag is None or fitter.all_visible is None:
        return fit
    pose = solver.PoseState.of(fit.camera, centre)
    best, tried = fit, 0
    for step in weak_steps(fitter.camera, fitter.all_visible, pose, fitter.edges.group_names.index(lag)):
        fitter.restart()
        tried += 1
        try:
            candidate = refit(pose.moved(step))
        except EdgeFitError:
            continue
        if candidate.above_chance > best.above_chance + (MIN_GAIN if best is fit else 0.0):
            best = candidate
    if tried:
        best.restart = _note(fit, lag, tried, best)
    return best


def weak_steps(camera: Camera, samples: Samples, pose: solver.PoseState, lagging: int) -> list[np.ndarray]:
    """Steps of ``pose`` along the :data:`DIRECTIONS` weakest directions of the normal equations
    of the ``samples`` not of part ``lagging`` (their edge-normal offsets per pose parameter),
    each scaled to move the ``lagging`` part's samples by each of :data:`RESTART_PX` (median),
    both ways; only the directions the others leave free (:data:`FREE`)."""
    proj = solver.project(pose, camera, samples.points, samples.tangents)
    rows = np.einsum("ni,nij->nj", proj.normal, proj.J)  # d(normal offset) / d pose, px
    others, mine = samples.group != lagging, samples.group == lagging
    _, vectors = np.linalg.eigh(rows[others].T @ rows[others])
    steps = []
    for v in vectors.T[:DIRECTIONS]:
        moved = float(np.median(np.linalg.norm(np.einsum("nij,j->ni", proj.J[mine], v), axis=1)))
        if moved > 0 and np.median(np.abs(rows[others] @ v)) <= FREE * moved:
            steps += [sign * px / moved * v for px in RESTART_PX for sign in (1.0, -1.0)]
    return steps


def _note(fit: EdgeFit, lag: str, tried: int, best: EdgeFit) -> str:
    figures = f"{fit.part_above[lag]:.2f} beyond chance against up to {max(fit.part_above.values()):.2f}"
    kept = (
        "kept the first fit"
        if best is fit
        else f"kept a restart ({best.above_chance:.2f} beyond chance over all parts against {fit.above_chance:.2f})"
    )
    tried_text = f"{tried} restarts along the weakest directions"
    return f"{lag} fitted far worse than the other parts ({figures}): {tried_text}, {kept}"


__all__ = ["best_of", "lagging_part", "weak_steps", "LAGGING", "RESTART_PX", "DIRECTIONS", "MIN_GAIN", "FREE"]
