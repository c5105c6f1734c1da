"""Coverage of a CAD instance by a scan: the share of its *visible* surface that has scan points.

The surface of every instance is sampled (area-weighted, :data:`SAMPLE_SPACING` apart on
average, between :data:`MIN_SAMPLES` and :data:`MAX_SAMPLES` samples per instance, drawn from
one seeded generator: the same scene gives the same samples on every run).

**Visible** means:

- with scanner positions (an E57 file's scan poses, or given): a sample is visible when the ray
  from at least one scanner to it first hits that very instance at the sample (within
  :data:`HIT_SLACK`, relative to the range): nothing of the CAD stands in between. Back faces
  count (a single-sided plate is scanned from either side);
- without them (PLY, PCD, XYZ, LAS carry no scanner position): a sample is visible when at least
  one side of the surface there is open, i.e. a ray along +n or -n leaves it and hits nothing of
  the CAD within :data:`OPEN_DISTANCE`. That drops faces resting on the floor, faces against
  walls and the inside of closed assemblies, which no scanner sees either; it keeps faces no
  scanner of THIS scan reached, so coverage without positions reads "share of the element's open
  surface".

A visible sample is **covered** when the closest CAD point of at least one scan point assigned
to the instance falls into the same :data:`COVER_CELL` voxel (the scan's own points may be off
by a moved element's offset; their closest CAD points lie on the surface). Coverage = covered /
visible samples; None when the instance has no visible sample.
"""

from __future__ import annotations

import numpy as np

from mrcheck.scene.raycast import triangle_owners

SAMPLE_SPACING = 0.05  # metres between surface samples on average
MIN_SAMPLES, MAX_SAMPLES = 32, 1024
COVER_CELL = 0.10  # metres: voxel edge of the covered test
HIT_SLACK = 0.01  # metres (or 0.2 % of the range if more): the ray's hit is the sample
OPEN_DISTANCE = 0.2  # metres of free space in front of a visible sample (no scanners known)
SEED = 0
RAY_CHUNK = 1 << 21


def _triangle_areas(part) -> tuple[np.ndarray, np.ndarray]:
    v = part.vertices.astype(np.float64)
    tri = v[part.faces.astype(np.int64)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(cross, axis=1) / 2.0
    return area, tri


def surface_samples(scene, rng=None):
    """Samples of every instance's surface: ``(points, normals, instance)``, world float64,
    unit normals (the triangle's front), instance indices in :func:`triangle_owners`' order."""
    rng = np.random.default_rng(SEED) if rng is None else rng
    owners, _ = triangle_owners(scene)
    points, normals, instance = [], [], []
    cache = {}
    for index, (part, k) in enumerate(owners):
        if id(part) not in cache:
            area, tri = _triangle_areas(part)
            cache = {id(part): (area, tri, area.sum())}
        area, tri, total = cache[id(part)]
        if total <= 0.0:
            continue
        T = part.transforms[k]
        scale = abs(np.linalg.det(T[:3, :3])) ** (2.0 / 3.0)
        m = int(np.clip(total * scale / SAMPLE_SPACING**2, MIN_SAMPLES, MAX_SAMPLES))
        chosen = rng.choice(len(area), size=m, p=area / total)
        a, b = rng.random(m), rng.random(m)
        flip = a + b > 1.0
        a, b = np.where(flip, 1.0 - a, a), np.where(flip, 1.0 - b, b)
        t = tri[chosen]
        local = t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0])
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        # normals transform with the inverse transpose (a replaced part is scaled)
        n = n @ np.linalg.inv(T[:3, :3])
        points.append(local @ T[:3, :3].T + T[:3, 3])
        normals.append(n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30))
        instance.append(np.full(m, index, np.int64))
    if not points:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
    return np.concatenate(points), np.concatenate(normals), np.concatenate(instance)


def _cast(caster, starts: np.ndarray, directions: np.ndarray):
    """First hits (t, instance) of rays given relative to the caster's origin, in chunks."""
    t = np.empty(len(starts), np.float32)
    inst = np.empty(len(starts), np.int64)
    for s in range(0, len(starts), RAY_CHUNK):
        rays = np.hstack([starts[s : s + RAY_CHUNK], directions[s : s + RAY_CHUNK]]).astype(np.float32)
        hits = caster.cast(rays)
        t[s : s + len(rays)], inst[s : s + len(rays)] = hits.t, hits.instance
    return t, inst


def visible_from_scanners(caster, samples, instance, scanners) -> np.ndarray:
    """(S,) bool: seen from at least one scanner (module docstring)."""
    seen = np.zeros(len(samples), bool)
    relative = samples - caster.origin
    for scanner in np.asarray(scanners, np.float64).reshape(-1, 3):
        start = scanner - caster.origin
        ray = relative - start
        dist = np.linalg.norm(ray, axis=1)
        t, inst = _cast(caster, np.broadcast_to(start, ray.shape), ray / np.maximum(dist, 1e-12)[:, None])
        slack = np.maximum(HIT_SLACK, 0.002 * dist)
        seen |= (inst == instance) & (np.abs(t - dist) < slack)
    return seen


def open_surface(caster, samples, normals) -> np.ndarray:
    """(S,) bool: one side of the surface open for :data:`OPEN_DISTANCE` (module docstring)."""
    relative = samples - caster.origin
    free = np.zeros(len(samples), bool)
    for side in (1.0, -1.0):
        direction = side * normals
        t, _ = _cast(caster, relative + 1e-3 * direction, direction)
        free |= ~(t < OPEN_DISTANCE)
    return free


def _voxel_keys(groups: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
    """One int64 per (instance, voxel) of each ``(instance, points)`` group, comparable across
    the groups: the voxel's cell indices relative to their minimum packed with the instance.
    A cell too fine to pack (a scan kilometres across with a million instances) doubles until
    it fits, which only coarsens the covered test."""
    top = max(int(inst.max(initial=0)) for inst, _ in groups) + 1
    inst_bits = max(1, top.bit_length())
    cell = COVER_CELL
    while True:
        cells = [np.floor(p / cell).astype(np.int64) for _, p in groups]
        lo = (
            np.min([c.min(axis=0) for c in cells if len(c)], axis=0)
            if any(len(c) for c in cells)
            else np.zeros(3, np.int64)
        )
        span = max((int((c - lo).max(initial=0)) for c in cells), default=0) + 1
        bits = max(1, span.bit_length())
        if inst_bits + 3 * bits <= 63:
            break
        cell *= 2.0
    keys = []
    for (inst, _), c in zip(groups, cells):
        c = c - lo
        keys.append((((inst.astype(np.int64) << bits | c[:, 0]) << bits | c[:, 1]) << bits) | c[:, 2])
    return keys


def coverage(caster, scene, owner, closest, scanners=None) -> tuple[np.ndarray, np.ndarray]:
    """Per instance (:func:`triangle_owners` order): ``(coverage, visible)``, float64 (nan where
    nothing is visible) and int64 visible sample counts. ``owner`` and ``closest`` are the
    assigned points' instances and closest CAD points (relative to the caster's origin)."""
    count = len(triangle_owners(scene)[0])
    samples, normals, instance = surface_samples(scene)
    if scanners is not None and len(scanners):
        visible = visible_from_scanners(caster, samples, instance, scanners)
    else:
        visible = open_surface(caster, samples, normals)
    samples, instance = samples[visible], instance[visible]
    point_keys, sample_keys = _voxel_keys([(owner, closest.astype(np.float64)), (instance, samples - caster.origin)])
    covered = np.isin(sample_keys, np.unique(point_keys))
    n_visible = np.bincount(instance, minlength=count)
    n_covered = np.bincount(instance[covered], minlength=count)
    share = np.full(count, np.nan)
    np.divide(n_covered, n_visible, out=share, where=n_visible > 0)
    return share, n_visible


__all__ = [
    "surface_samples",
    "visible_from_scanners",
    "open_surface",
    "coverage",
    "SAMPLE_SPACING",
    "COVER_CELL",
    "OPEN_DISTANCE",
]
