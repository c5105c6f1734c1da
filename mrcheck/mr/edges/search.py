"""The pose search of the coarse stage: from a rough pose up to the search radius off to within
a few pixels, by scoring many candidate poses on the oriented chamfer distance.

Why a search over whole poses: in a dense hall (fences, trusses, roof decks, racks) a descent
on the chamfer distance from 15-40 px off ends in the nearest local minimum, and a search over
image shifts alone (a pan and tilt) does not reach the true pose, whose error is a rotation
*and* a translation: on the generated cell's overview (640x480, seeds 0-9) the true image
motion differs from its best shift by 2-9 level px (median over the samples, at 320 px wide),
and the shift search, then the descent, ended 5-36 px off in 9 of 10 cases. Yet at 320 px wide
the true pose has the lowest chamfer cost by a clear margin (7-8 against 9-11 at the wrong
poses reached), and that cost is cheap to evaluate for thousands of poses once the samples'
projection is linearised.

Method (a beam search, as in particle filters or the cross-entropy method):

1. The salient samples at the rough pose (at most :data:`SAMPLES`, evenly picked), their pixel
   positions ``uv0`` and the Jacobian ``J`` of their projection (``cv2.projectPoints``, lens
   distortion as calibrated); a candidate pose change ``d`` (the solver's six parameters)
   moves them to ``uv0 + J d`` (first order: the error is a few degrees).
2. :data:`FIRST` candidates from the prior: a random direction of the six parameters, rotation
   in radians and translation in metres over the samples' median depth (equal weight: a rough
   pose is off by some angle and some distance), scaled to a uniform median image motion of
   0 up to the search radius. Each is scored by its truncated chamfer cost (nearest pixel of
   the distance map of the sample's direction bin).
3. Rounds: the :data:`ELITE` best each get :data:`CHILDREN` random neighbours up to the radius
   over ``ROUNDS[k]``. Of all candidates scored, those within :data:`NEAR_BEST` of the lowest
   cost are the fits, and the one nearest the start is taken (repeated or parallel edges fit
   at several poses).

Measured (cell overview, 640x480, seeds 0-9, 15-30 px off, 12 000 + 3 x 3 000 candidates of 400
samples): the best candidate ends 1.4-6.0 px (full resolution) from the true pose, where the
descent and the fine stage take over (seeds 0-19 all end within 1 px), in 0.19-0.39 s at load 1-2.
Twice as many candidates of 600 samples ended 1.0-3.7 px off, but cost 0.5-0.9 s, and the fits
ended 19 of 20 within 1 px.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import chamfer, model, solver

SEARCH_WIDTH_PX = 320  # the pyramid level searched: the one nearest this width (see search_level)
SAMPLES = 400  # samples scored per candidate
FIRST = 12000  # candidates drawn from the prior
ELITE = 100  # candidates kept per round
CHILDREN = 30  # neighbours drawn per kept candidate and round
ROUNDS = (4.0, 8.0, 16.0)  # the rounds' neighbourhood: the search radius over these
NEAR_BEST = 0.02  # of the candidates within this share of the lowest cost, the nearest is taken
RESCORED = 24  # distinct candidates (the best by linearised cost) scored at their exact projection
POLISHED = 2  # ... of those (and the start), the best polished on the exact chamfer distance: the alternates
_DISTINCT_PX = 2.0  # level px of median image motion: two candidates nearer are one
_DISTINCT_POOL = 4000  # the distinct candidates are looked for among this many best
_POLISH_STEPS = 6  # Gauss-Newton steps of a polish
_BATCH = 500  # candidates scored at once (memory: BATCH x SAMPLES x 2 floats)
_MOTION_SAMPLES = 100  # samples the median image motion of a candidate is measured on


@dataclass
class SearchReport:
    """What :func:`search_pose` did: ``pose`` the pose chosen, ``moved_px`` the chosen change's
    median image motion (full resolution px), ``cost`` / ``start_cost`` the chamfer cost there
    and at the rough pose, ``candidates`` how many were scored, ``scale`` the level searched;
    ``finder`` makes the alternates (:meth:`alternates`), only when a fit asks for them."""

    pose: solver.PoseState
    moved_px: float
    cost: float
    start_cost: float
    candidates: int
    scale: float
    finder: Callable[[], list] | None = field(default=None, repr=False)
    found: list | None = field(default=None, repr=False)

    def alternates(self) -> list:
        """Other basins' poses (:class:`_Exact`), best first; made on the first call (a fit asks
        only after the pose chosen was refused), then kept."""
        if self.found is None:
            self.found = self.finder() if self.finder is not None else []
        return self.found


def search_level(widths: list) -> int:
    """Index of the pyramid level to search (``widths`` finest first): the one nearest
    :data:`SEARCH_WIDTH_PX` wide (in ratio), never the finest when there is a coarser one (the
    fine stage needs a level to descend from)."""
    ratio = np.abs(np.log(np.asarray(widths, np.float64) / SEARCH_WIDTH_PX))
    if len(widths) > 1:
        ratio[0] = np.inf
    return int(np.argmin(ratio))


class _Candidates:
    """The linearised projection of the picked samples, and the scoring of pose changes."""

    def __init__(self, cmap: chamfer.ChamferMap, proj: solver.Projection):
        pick = np.unique(np.linspace(0, len(proj.uv) - 1, min(SAMPLES, len(proj.uv))).astype(np.int64))
        self.pick = pick
        self.uv0 = proj.uv[pick] * cmap.scale
        self.J = proj.J[pick] * cmap.scale
        self.bins = chamfer.bins_of(proj.normal[pick])
        _, self.h, self.w = cmap.distance.shape
        self.flat = cmap.distance.reshape(-1)
        self.base = self.bins * (self.h * self.w)  # where each sample's direction bin starts
        self.rows = self.J.reshape(-1, 6)
        depth = float(np.median(proj.depth))
        self.units = np.array([1.0, 1.0, 1.0, depth, depth, depth])  # radians; metres over the depth
        some = np.unique(np.linspace(0, len(pick) - 1, min(_MOTION_SAMPLES, len(pick))).astype(np.int64))
        # the u and v rows apart, (6, m) each: two matrix products per batch of candidates (the
        # einsum into an (h, m, 2) array and its norm over the last axis took 55 of the 75 ms
        # per 12 000 candidates; the same motions within 1e-15)
        self.motion_u, self.motion_v = (np.ascontiguousarray(self.J[some, k, :].T) for k in (0, 1))

    def motion(self, D: np.ndarray) -> np.ndarray:
        """(h,) median image motion (level px) of the pose changes ``D`` (h, 6)."""
        u, v = D @ self.motion_u, D @ self.motion_v
        return np.median(np.sqrt(u * u + v * v), axis=1)

    def directions(self, count: int, rng) -> np.ndarray:
        """(count, 6) random pose changes of one level px of median image motion."""
        d = rng.normal(size=(count, 6)) * self.units
        d /= np.linalg.norm(d / self.units, axis=1, keepdims=True)
        return d / np.maximum(self.motion(d), 1e-12)[:, None]

    def cost(self, D: np.ndarray) -> np.ndarray:
        """(h,) truncated chamfer cost of the samples moved by the pose changes ``D`` (nearest pixel)."""
        return np.concatenate([self._cost(D[i : i + _BATCH]) for i in range(0, len(D), _BATCH)])

    def _cost(self, D: np.ndarray) -> np.ndarray:
        # one matrix product for all candidates: rows u0, v0, u1, v1, ... of the samples
        moved = self.rows @ D.T  # (2 n, h)
        u = np.clip(np.rint(moved[0::2] + self.uv0[:, 0:1]), 0, self.w - 1).astype(np.intp)
        v = np.clip(np.rint(moved[1::2] + self.uv0[:, 1:2]), 0, self.h - 1).astype(np.intp)
        d = self.flat[self.base[:, None] + v * self.w + u]  # (n, h)
        return np.mean(d * d, axis=0)


def search_pose(
    pose: solver.PoseState,
    camera: Camera,
    samples: model.Samples,
    cmap: chamfer.ChamferMap,
    radius_px: float,
    seed: int = 0,
) -> SearchReport:
    """Steps 1-3 on the level of ``cmap`` within ``radius_px`` (full-resolution median image
    motion) from ``pose`` (``camera``: the photo's intrinsics; ``samples``: the visible edges
    at ``pose`` on this level); the report holds the pose chosen (:func:`_nearest_of_the_best`).
    Seeded: the same photo and start give the same pose on every run."""
    proj = solver.project(pose, camera, samples.points, samples.tangents)
    radius = radius_px * cmap.scale
    pool = _Candidates(cmap, proj)
    rng = np.random.default_rng(seed)
    D = np.vstack([np.zeros((1, 6)), pool.directions(FIRST, rng) * rng.uniform(0.0, radius, (FIRST, 1))])
    cost = pool.cost(D)
    scored, scores = [D], [cost]
    for divisor in ROUNDS:
        keep = np.argsort(cost)[:ELITE]
        count = len(keep) * CHILDREN
        children = np.repeat(D[keep], CHILDREN, axis=0) + pool.directions(count, rng) * rng.uniform(
            0.0, radius / divisor, (count, 1)
        )
        child_cost = pool.cost(children)
        D, cost = np.vstack([D[keep], children]), np.concatenate([cost[keep], child_cost])
        scored.append(children)
        scores.append(child_cost)
    D, cost = np.vstack(scored), np.concatenate(scores)
    best, moved = _nearest_of_the_best(D, cost, pool.motion)
    exact = _Exact(pose, camera, samples.points[pool.pick], samples.tangents[pool.pick], cmap)

    def finder() -> list:
        return [pose.moved(d) for d in exact.alternates(D, cost, pool.motion, D[best])]

    scale = cmap.scale
    return SearchReport(pose.moved(D[best]), moved / scale, float(cost[best]), float(cost[0]), len(D), scale, finder)


class _Exact:
    """The chamfer cost of pose changes at their exact projection, and a short descent on it:
    the alternates of a search (:meth:`SearchReport.alternates`), tried by the fit when the pose
    chosen is refused.

    Why: the linearised projection of the beam search errs by pixels for changes of tens of
    pixels, and a wrong pose can look better through it than the true one. Measured on BOP LM-O
    (photos 3 and 402, 640x480 searched at 320, starts 20-40 px off that the fit refused): the
    pose chosen scored 7.3-8.5 linearised but 8.2-9.7 exactly, the true pose 7.4-8.8 exactly;
    the best polished alternate led 3 of 5 such fits to within 1.8 px. Why not instead of the
    pose chosen: on the generated cell (seeds 0-9, 640x480) it moved two good fits (0.12 and
    0.42 px) to 1.0 and 1.3 px; its true pose is not the exact chamfer minimum at 320 px wide."""

    def __init__(self, pose: solver.PoseState, camera: Camera, points, tangents, cmap: chamfer.ChamferMap):
        self.pose, self.camera, self.points, self.tangents, self.cmap = pose, camera, points, tangents, cmap

    def distances(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The samples' chamfer distances after the change ``d`` and their rows (d distance / d change)."""
        proj = solver.project(self.pose.moved(d), self.camera, self.points, self.tangents)
        dist, grad = chamfer.lookup(self.cmap, proj.uv * self.cmap.scale, chamfer.bins_of(proj.normal))
        return dist, np.einsum("ni,nij->nj", grad, proj.J) * self.cmap.scale

    def polish(self, d: np.ndarray) -> tuple[np.ndarray, float]:
        """``d`` moved down the exact chamfer cost by a few Gauss-Newton steps, and its cost."""
        dist, rows = self.distances(d)
        now = chamfer.cost(dist)
        for _ in range(_POLISH_STEPS):
            weights = chamfer.huber_weights(dist)
            near = weights > 0
            if np.count_nonzero(near) < 6:
                break
            step = solver.gauss_newton_step(rows[near], dist[near], weights[near], 1e-3)
            if step is None:
                break
            trial_dist, trial_rows = self.distances(d + step)
            if chamfer.cost(trial_dist) >= now:
                break
            d, dist, rows, now = d + step, trial_dist, trial_rows, chamfer.cost(trial_dist)
        return d, now

    def alternates(self, D: np.ndarray, cost: np.ndarray, motion, chosen: np.ndarray) -> list[np.ndarray]:
        """Up to :data:`POLISHED` pose changes other than ``chosen``: the best distinct candidates
        (:data:`RESCORED`, by linearised cost) and the start, scored exactly, the best polished,
        lowest exact cost first, none within :data:`_DISTINCT_PX` of ``chosen`` or of another."""
        picked = _distinct(np.vstack([np.zeros((1, 6)), D]), np.concatenate([[-np.inf], cost]), motion)
        pool = np.vstack([np.zeros((1, 6)), D])[picked]
        exact = np.array([chamfer.cost(self.distances(d)[0]) for d in pool])
        polished = [self.polish(pool[i]) for i in np.argsort(exact)[: POLISHED + 1]]
        out: list[np.ndarray] = []
        for d, _ in sorted(polished, key=lambda p: p[1]):
            near = [chosen, *out]
            if float(np.min(motion(np.vstack(near) - d))) >= _DISTINCT_PX:
                out.append(d)
        return out[:POLISHED]


def _distinct(D: np.ndarray, cost: np.ndarray, motion) -> np.ndarray:
    """Indices of up to :data:`RESCORED` candidates, lowest linearised cost first, each at least
    :data:`_DISTINCT_PX` of median image motion from those before it (one per basin)."""
    chosen: list[int] = []
    for i in np.argsort(cost)[:_DISTINCT_POOL]:
        if chosen and float(np.min(motion(D[chosen] - D[i]))) < _DISTINCT_PX:
            continue
        chosen.append(int(i))
        if len(chosen) == RESCORED:
            break
    return np.array(chosen, np.int64)


def _nearest_of_the_best(D: np.ndarray, cost: np.ndarray, motion) -> tuple:
    """``(index, motion)``: of the candidates within :data:`NEAR_BEST` of the lowest cost, the
    one that moves the view least. Why: where the edges leave a direction open (a bar across
    the view, a row of equal racks) many poses fit equally, and the start is the best guess
    between them; a prior on the motion instead (the cost times ``1 + k (motion / radius)^2``)
    either let such a pose drift to the search radius (small k) or beat a true pose 30 px off
    (k = 0.5 on the generated cell, seed 1: the true pose's cost 8.1, a wrong one's 8.8)."""
    near = np.flatnonzero(cost <= cost.min() * (1.0 + NEAR_BEST))
    moves = motion(D[near])
    pick = int(np.argmin(moves))
    return int(near[pick]), float(moves[pick])


__all__ = ["SearchReport", "search_level", "search_pose", "SEARCH_WIDTH_PX"]
