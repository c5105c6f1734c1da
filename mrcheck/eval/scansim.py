"""Simulated terrestrial laser scans of a scene, and small as-built shifts: ground truth for the
per-element tolerance status (``mrcheck deviation --per-element``).

- :func:`shifted_variant`: a copy of a scene with some instances moved horizontally by a few
  millimetres to centimetres (``mrcheck scene asbuilt`` moves them 5 cm to 2 m; a tolerance
  check is about the millimetres). Structure (the floor slab, walls, columns, ... the parts
  :func:`mrcheck.scene.asbuilt_plan.excluded_parts` names) never moves.
- :func:`clutter_parts`: boxes standing on the floor that the CAD does not have (people, carts,
  crates), clear of every instance: they occlude, and their points are clutter.
- :func:`simulate_scan`: scanner stations at eye height in the free floor area, each sweeping a
  Fibonacci sphere of rays (elevation -60 .. +90 deg) that stop at the first surface (occlusion
  as a real scanner sees it), with Gaussian range noise of 2-5 mm (drawn per station) and a
  small share of stray returns anywhere in the scene's box (mixed pixels, dust).

Everything comes from one seeded ``numpy`` generator: the same arguments give the same points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mrcheck.eval.realdata import cuboid_faces
from mrcheck.scene.asbuilt_plan import excluded_parts
from mrcheck.scene.model import Scene, make_part
from mrcheck.scene.raycast import build_caster

EYE_HEIGHT = 1.6
STRAY_SHARE = 0.005
CLUTTER_SIZE = ((0.4, 0.4, 1.75), (0.8, 0.6, 1.0), (1.2, 0.8, 0.9))  # a person, a cart, a crate


@dataclass(frozen=True)
class Shift:
    """One moved instance: its id and the (3,) horizontal move, metres."""

    id: str
    vector: tuple


def _movable(scene: Scene) -> list[tuple[int, int]]:
    skip = excluded_parts(scene)
    return [(p, k) for p, part in enumerate(scene.parts) if part.name not in skip for k in range(len(part.transforms))]


def shifted_variant(scene: Scene, share: float, low_m: float, high_m: float, seed: int) -> tuple[Scene, list[Shift]]:
    """A copy of ``scene`` with ``share`` of its movable instances moved by ``low_m`` .. ``high_m``
    (uniform magnitude, uniform horizontal direction)."""
    rng = np.random.default_rng(seed)
    movable = _movable(scene)
    chosen = rng.choice(len(movable), size=max(1, int(round(share * len(movable)))), replace=False)
    transforms = {p: part.transforms.copy() for p, part in enumerate(scene.parts)}
    shifts = []
    for index in sorted(chosen):
        p, k = movable[index]
        angle, size = rng.uniform(0.0, 2.0 * math.pi), rng.uniform(low_m, high_m)
        vector = (size * math.cos(angle), size * math.sin(angle), 0.0)
        transforms[p][k, :3, 3] += vector
        shifts.append(Shift(scene.parts[p].instance_ids[k], vector))
    parts = [replace(part, transforms=transforms[p], _bounds=None) for p, part in enumerate(scene.parts)]
    return replace(scene, parts=parts), shifts


def _box_mesh(size) -> tuple[np.ndarray, np.ndarray]:
    sx, sy, sz = size
    v = np.array([[x, y, z] for x in (0, sx) for y in (0, sy) for z in (0, sz)], np.float64)
    f = cuboid_faces()  # corners x slowest, as v above
    return v, f


def _floor(scene: Scene):
    """(lo, hi) of the scene's box and the floor's top z: the top of the instance with the
    largest footprint (the slab)."""
    lo, hi = scene.bounds()
    boxes = np.concatenate([p.instance_bounds() for p in scene.parts])
    footprint = np.prod(boxes[:, 1, :2] - boxes[:, 0, :2], axis=1)
    return lo, hi, float(boxes[int(np.argmax(footprint)), 1, 2])


def _free(box, boxes, floor_z, margin) -> bool:
    lo, hi = box[0] - margin, box[1] + margin
    above = boxes[:, 1, 2] > floor_z + 1e-3  # the floor slab itself never blocks
    overlap = np.all((boxes[:, 0] < hi) & (boxes[:, 1] > lo), axis=1)
    return not np.any(overlap & above)


def clutter_parts(scene: Scene, count: int, seed: int, margin: float = 0.15) -> list:
    """Up to ``count`` clutter boxes (module docstring) as scene parts, clear of every instance."""
    rng = np.random.default_rng(seed + 7919)
    lo, hi, floor_z = _floor(scene)
    boxes = np.concatenate([p.instance_bounds() for p in scene.parts])
    parts = []
    for attempt in range(count * 40):
        if len(parts) == count:
            break
        size = np.array(CLUTTER_SIZE[attempt % len(CLUTTER_SIZE)])
        corner = np.array([rng.uniform(lo[0], hi[0] - size[0]), rng.uniform(lo[1], hi[1] - size[1]), floor_z])
        box = np.stack([corner, corner + size])
        if _free(box, boxes, floor_z, margin):
            v, f = _box_mesh(size)
            parts.append(make_part(f"clutter{len(parts)}", "clutter", v + corner, f, [np.eye(4)]))
            boxes = np.concatenate([boxes, box[None]])
    return parts


def scanner_stations(scene: Scene, count: int, seed: int) -> np.ndarray:
    """(count, 3) stations at :data:`EYE_HEIGHT` above the floor, in free space (no CAD within
    0.5 m on 26 rays), spread by farthest-point choice over a grid of the inner 70 % of the floor."""
    lo, hi, floor_z = _floor(scene)
    centre, half = (lo + hi) / 2.0, (hi - lo) * 0.35
    gx, gy = np.meshgrid(np.linspace(-1, 1, 15), np.linspace(-1, 1, 15))
    grid = np.column_stack(
        [centre[0] + gx.ravel() * half[0], centre[1] + gy.ravel() * half[1], np.full(gx.size, floor_z + EYE_HEIGHT)]
    )
    caster = build_caster(scene, centre)
    dirs = np.array(
        [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)], float
    )
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    rays = np.concatenate([np.hstack([np.broadcast_to(g - centre, dirs.shape), dirs]) for g in grid])
    t = caster.cast(rays.astype(np.float32)).t.reshape(len(grid), len(dirs))
    free = grid[np.all(t > 0.5, axis=1)]
    if not len(free):
        free = grid
    rng = np.random.default_rng(seed)
    chosen = [free[rng.integers(len(free))]]
    while len(chosen) < min(count, len(free)):
        dist = np.min(np.linalg.norm(free[:, None] - np.array(chosen)[None], axis=2), axis=1)
        chosen.append(free[int(np.argmax(dist))])
    return np.array(chosen)


def _sphere(n: int, min_elevation_deg: float = -60.0) -> np.ndarray:
    """``n`` Fibonacci-sphere directions above ``min_elevation_deg``."""
    z_low = math.sin(math.radians(min_elevation_deg))
    i = np.arange(n) + 0.5
    z = 1.0 - i / n * (1.0 - z_low)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


@dataclass
class SimulatedScan:
    points: np.ndarray  # (N, 3) float64 world metres
    stations: np.ndarray  # (k, 3) the scanner positions
    noise_mm: list  # per station, the range noise's sigma


def simulate_scan(
    scene: Scene, stations: np.ndarray, rays_per_station: int, seed: int, noise_mm=(2.0, 5.0)
) -> SimulatedScan:
    """Points of ``scene`` (the as-built one, clutter included) seen from ``stations``."""
    rng = np.random.default_rng(seed + 104729)
    centre = stations.mean(axis=0)
    caster = build_caster(scene, centre)
    directions = _sphere(rays_per_station)
    points, sigmas = [], []
    for station in stations:
        sigma = rng.uniform(*noise_mm) / 1000.0
        rays = np.hstack([np.broadcast_to(station - centre, directions.shape), directions]).astype(np.float32)
        t = caster.cast(rays).t.astype(np.float64)
        hit = np.isfinite(t)
        rng_noise = rng.normal(0.0, sigma, int(hit.sum()))
        points.append(station + directions[hit] * (t[hit] + rng_noise)[:, None])
        sigmas.append(round(sigma * 1000.0, 3))
    points = np.concatenate(points)
    lo, hi = scene.bounds()
    stray = rng.uniform(lo, hi, (int(STRAY_SHARE * len(points)), 3))
    return SimulatedScan(np.concatenate([points, stray]), np.asarray(stations), sigmas)


__all__ = ["shifted_variant", "clutter_parts", "scanner_stations", "simulate_scan", "Shift", "SimulatedScan"]
