"""Choosing an as-built variant's changes: which instances change, and how, from the seed.

The rules (what may move, where it may go) are described in :mod:`mrcheck.scene.asbuilt`, which
writes the variant; this module reads the planned scene's instances, classifies them (on the
floor, free, standing on or hanging from another) and draws the changes with :class:`Planner`.
"""

from __future__ import annotations

import contextlib
import random
from dataclasses import dataclass, field

import numpy as np

from mrcheck.core.errors import warn
from mrcheck.core.progress import Progress, no_progress
from mrcheck.scene.part_tables import transform_from_table

KINDS = ("moved", "rotated", "missing", "added", "replaced")
SHARE = 0.10  # of the scene's instances that change
STRUCTURE_WORDS = ("floor", "slab", "wall", "roof", "ceiling", "column", "beam", "hall")
MOVE_M = (0.05, 2.0)  # horizontal distance of a move
ROTATE_DEG = (5.0, 90.0)  # about the vertical axis
SCALES = ((0.7, 0.9), (1.1, 1.4))  # a replacement of another size; not 0.9 .. 1.1, too alike
CONTACT_M = 0.01  # boxes this close count as touching, not overlapping
SINK_M = 0.05  # a base this far below a top still stands on it (bolt heads)
CLEARANCE_M = 0.05  # free gap around a moved or added instance
EYE_CLEAR_M = 3.0  # no object is put this close (horizontally) below a viewpoint's eye
TRIES = 40  # random placements tried per candidate instance
DECIMALS = 9  # of computed coordinates: 3.123, not 3.1229999999999998


@dataclass
class Instance:
    id: str
    part: str
    index: int  # position in its part's instance list
    transform: np.ndarray  # (4, 4) local -> world as loaded (Part.transforms)
    corners: np.ndarray  # (8, 4) homogeneous corners of the part's local bounds
    origin: np.ndarray  # (3,) world position of the part's own (authored) origin
    box: np.ndarray  # (2, 3) world bounds
    on_floor: bool = False
    free: bool = True  # nothing rests on it or hangs from it
    held: bool = False  # hangs from something beside it (a fence panel between its posts)
    supporters: set = field(default_factory=set)  # ids of the instances it stands on


@dataclass(frozen=True)
class Change:
    """The world-space similarity x -> pivot + shift + scale * Rz(angle) (x - pivot)."""

    pivot: tuple = (0.0, 0.0, 0.0)
    shift: tuple = (0.0, 0.0, 0.0)
    angle_deg: float = 0.0
    scale: float = 1.0

    def linear(self) -> np.ndarray:
        a = np.radians(self.angle_deg)
        return self.scale * np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])

    def matrix(self) -> np.ndarray:
        M = np.eye(4)
        M[:3, :3] = self.linear()
        M[:3, 3] = np.add(self.pivot, self.shift) - M[:3, :3] @ np.asarray(self.pivot)
        return M

    def table(self, instance: dict) -> dict:
        """The instance table (``translate``/``rotate_deg``/``scale`` or ``matrix``) moved by this change."""
        if "matrix" in instance:
            M = self.matrix() @ np.asarray(instance["matrix"], np.float64)
            return {"matrix": [rounded(row) for row in M]}
        t = np.asarray(instance.get("translate", (0.0, 0.0, 0.0)), np.float64)
        r = np.asarray(instance.get("rotate_deg", (0.0, 0.0, 0.0)), np.float64)
        s = float(instance.get("scale", 1.0)) * self.scale
        if self.angle_deg:
            # Rz(a) @ Rz(c) Ry(b) Rx(a0) = Rz(c + a) Ry(b) Rx(a0): the turn adds to the Euler z angle
            z = r[2] + self.angle_deg
            r[2] = z - 360.0 if z > 180.0 else z + 360.0 if z <= -180.0 else z
        out: dict[str, list[float] | float] = {
            "translate": rounded(np.add(self.pivot, self.shift) + self.linear() @ (t - self.pivot))
        }
        if np.any(r != 0):
            out["rotate_deg"] = rounded(r)
        if s != 1.0:
            out["scale"] = round(s, DECIMALS)
        return out


def rounded(values) -> list[float]:
    return [round(float(v), DECIMALS) + 0.0 for v in values]  # + 0.0: no -0.0 in the files


def base_point(box) -> np.ndarray:
    """Centre of the bottom face of a (2, 3) box."""
    return np.array([(box[0, 0] + box[1, 0]) / 2, (box[0, 1] + box[1, 1]) / 2, box[0, 2]])


def overlapping(box, boxes) -> np.ndarray:
    """Which of ``boxes`` (n, 2, 3) overlap ``box`` by more than :data:`CONTACT_M` on every axis."""
    if len(boxes) == 0:
        return np.zeros(0, bool)
    lo, hi = np.maximum(box[0], boxes[:, 0]), np.minimum(box[1], boxes[:, 1])
    return np.all(hi - lo > CONTACT_M, axis=1)


# -- the planned scene ---------------------------------------------------------------------------
def planned_instances(scene, tables) -> list[Instance]:
    found = []
    for part, table in zip(scene.parts, tables):
        base = transform_from_table(table, part.name)
        lo, hi = part.local_bounds()
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for index, (iid, T, inst) in enumerate(zip(part.instance_ids, part.transforms, table.get("instances") or [{}])):
            origin = (transform_from_table(inst, part.name) @ base)[:3, 3]
            found.append(Instance(iid, part.name, index, T, corners, origin, world_box(T, corners)))
    return found


def world_box(T, corners) -> np.ndarray:
    """World bounds of local box ``corners`` (8, 4) under the transform ``T``, as Part.instance_bounds."""
    world = (corners @ T.T)[:, :3]
    return np.stack([world.min(axis=0), world.max(axis=0)])


def moved_box(inst: Instance, change: Change) -> np.ndarray:
    return world_box(change.matrix() @ inst.transform, inst.corners)


def excluded_parts(scene) -> dict:
    """{part name: reason} of the parts that never change (the building)."""
    footprint = {p.name: max(float(np.prod(b[1, :2] - b[0, :2])) for b in p.instance_bounds()) for p in scene.parts}
    largest = max(footprint, key=footprint.__getitem__)  # first of equals: manifest order
    reasons = {largest: "largest footprint"}
    for part in scene.parts:
        word = next((w for w in STRUCTURE_WORDS if w in part.name.lower()), None)
        if word and part.name not in reasons:
            reasons[part.name] = f"name contains {word!r}"
    return reasons


def classify(instances: list[Instance], floor_part: str, excluded: dict) -> float:
    """Set ``on_floor``, ``free`` and ``supporters``; returns the floor level (the lowest base
    of the changeable objects)."""
    floor_z = min(i.box[0, 2] for i in instances if i.part not in excluded)
    standing = sorted((i for i in instances if i.part != floor_part), key=lambda i: i.box[0, 0])
    boxes = np.array([i.box for i in standing])
    for a, inst in enumerate(standing):
        inst.on_floor = abs(inst.box[0, 2] - floor_z) <= CONTACT_M
        # only boxes starting left of this one's right side can overlap it (sorted by x min):
        # a hall of thousands of instances is not compared pair by pair
        near = np.arange(np.searchsorted(boxes[:, 0, 0], inst.box[1, 0], side="right"))
        other = boxes[near]
        # B leans on A when their footprints overlap and B's base lies higher than A's but not
        # above A's top: at the top (within SINK_M: a robot on its pedestal's plate, cartons on
        # a pallet) B stands on A; lower down B hangs from A (a fence panel between its posts)
        xy = np.all(
            np.minimum(inst.box[1, :2], other[:, 1, :2]) - np.maximum(inst.box[0, :2], other[:, 0, :2]) > CONTACT_M,
            axis=1,
        )
        zb = other[:, 0, 2]
        leaning = xy & (zb > inst.box[0, 2] + CONTACT_M) & (zb <= inst.box[1, 2] + CONTACT_M)
        inst.free = not leaning.any()
        for b, on_top in zip(near[leaning], zb[leaning] >= inst.box[1, 2] - SINK_M):
            if on_top:
                standing[b].supporters.add(inst.id)
            else:
                standing[b].held = True
    return floor_z


# -- choosing the changes --------------------------------------------------------------------------
class Planner:
    """Draws the changes from the seed, keeping the world's boxes up to date as it goes."""

    def __init__(self, instances, excluded, floor_part, floor_z, region, eyes, seed):
        self.rng = random.Random(seed)  # Python's generator: same stream on every platform and version
        self.instances = instances
        self.excluded = excluded
        self.region = region  # (2, 2) xy footprint the floor covers
        self.boxes = {i.id: i.box for i in instances if i.part != floor_part}
        # a camera's near foreground stays as it was: an object put there would hide the view
        for k, (x, y, z) in enumerate(eyes):
            self.boxes[("eye", k)] = np.array(
                [[x - EYE_CLEAR_M, y - EYE_CLEAR_M, floor_z - 1.0], [x + EYE_CLEAR_M, y + EYE_CLEAR_M, z + 0.5]]
            )
        self.used = set()
        self.taken_ids = {i.id for i in instances}
        self.changes = []  # (kind, Instance (the template for added), Change, new id or None)
        self._cache = None

    def _world(self):
        if self._cache is None:  # rebuilt only after a change: a hall has thousands of boxes
            self._cache = (list(self.boxes), np.array(list(self.boxes.values())).reshape(-1, 2, 3))
        return self._cache

    def _blocked(self, box, ignore=(), clearance=0.0) -> bool:
        if clearance:
            box = box + np.array([[-clearance, -clearance, 0.0], [clearance, clearance, 0.0]])
        keys, boxes = self._world()
        hits = overlapping(box, boxes)
        return any(keys[k] not in ignore for k in np.flatnonzero(hits))

    def _on_free_floor(self, box, ignore=()) -> bool:
        inside = np.all(box[0, :2] >= self.region[0]) and np.all(box[1, :2] <= self.region[1])
        return bool(inside) and not self._blocked(box, ignore, CLEARANCE_M)

    def _fits_in_place(self, inst, box) -> bool:
        # it may touch what it stands on (its pallet, its pedestal) but nothing beside it, and it
        # must still stand on all of that; a camera already close stays close
        for support in inst.supporters:
            other = self.boxes[support]
            if not np.all(np.minimum(box[1, :2], other[1, :2]) - np.maximum(box[0, :2], other[0, :2]) > CONTACT_M):
                return False
        keys, boxes = self._world()
        eyes = {keys[k] for k in np.flatnonzero(overlapping(inst.box, boxes)) if isinstance(keys[k], tuple)}
        return not self._blocked(box, inst.supporters | eyes | {inst.id})

    def _draw(self, kind, inst):
        """A change of ``kind`` for ``inst`` that fits, or None after :data:`TRIES` draws."""
        rng = self.rng
        for _ in range(TRIES):
            if kind == "moved":
                distance, heading = round(rng.uniform(*MOVE_M), 3), np.radians(round(rng.uniform(0.0, 360.0), 1))
                change = Change(shift=(distance * np.cos(heading), distance * np.sin(heading), 0.0))
                if self._on_free_floor(moved_box(inst, change), {inst.id}):
                    return change
            elif kind == "added":
                x, y = (rng.uniform(*self.region[:, k]) for k in (0, 1))
                b = base_point(inst.box)
                change = Change(shift=(round(x - b[0], 3), round(y - b[1], 3), 0.0))
                if self._on_free_floor(moved_box(inst, change)):
                    return change
            elif kind == "rotated":
                angle = round(rng.uniform(*ROTATE_DEG), 1) * rng.choice((-1, 1))
                inside = np.all(inst.origin[:2] >= inst.box[0, :2]) and np.all(inst.origin[:2] <= inst.box[1, :2])
                pivot = inst.origin if inside else base_point(inst.box)
                change = Change(pivot=tuple(pivot), angle_deg=angle)
                if self._fits_in_place(inst, moved_box(inst, change)):
                    return change
            elif kind == "replaced":
                scale = round(rng.uniform(*rng.choice(SCALES)), 2)
                change = Change(pivot=tuple(base_point(inst.box)), scale=scale)
                if self._fits_in_place(inst, moved_box(inst, change)):
                    return change
            else:  # missing: always possible for a free instance
                return Change()
        return None

    def _pool(self, kind) -> list[Instance]:
        pool = [i for i in self.instances if i.part not in self.excluded and i.free]
        if kind in ("moved", "added"):
            pool = [i for i in pool if i.on_floor]
        elif kind in ("rotated", "replaced"):  # turned or resized, it would leave what holds it
            pool = [i for i in pool if not i.held]
        if kind != "added":  # an added copy may share its template with another change
            pool = [i for i in pool if i.id not in self.used]
        return pool

    def plan(self, kinds, progress: Progress = no_progress):
        # the longest step on a big hall (each draw is checked against thousands of boxes)
        with contextlib.closing(progress(kinds, "choosing changes", "change")) as bar:
            for kind in bar:
                self._plan_one(kind)
        return self.changes

    def _plan_one(self, kind):
        # parts first, then their instances, both in random order: each part is as likely to
        # change as any other, however many instances it has (18 fence panels, 1 robot)
        by_part: dict[str, list] = {}
        for inst in self._pool(kind):
            by_part.setdefault(inst.part, []).append(inst)
        order = list(by_part)
        self.rng.shuffle(order)
        pool = []
        for name in order:
            self.rng.shuffle(by_part[name])
            pool += by_part[name]
        for inst in pool:
            change = self._draw(kind, inst)
            if change is not None:
                self._apply(kind, inst, change)
                break
        else:
            warn(f"no free instance fits a {kind!r} change; the variant has one change fewer")

    def _apply(self, kind, inst, change):
        self._cache = None
        new_id = None
        if kind == "added":
            new_id = unique_name(f"{inst.part}#added", self.taken_ids)
            self.boxes[new_id] = moved_box(inst, change)
        else:
            self.used.add(inst.id)
            if kind == "missing":
                self.boxes.pop(inst.id, None)
            else:
                self.boxes[inst.id] = moved_box(inst, change)
        self.changes.append((kind, inst, change, new_id))


def unique_name(stem: str, taken: set) -> str:
    """``stem`` + the first number from 1 not yet in ``taken`` (which it joins)."""
    n = 1
    while f"{stem}{n}" in taken:
        n += 1
    taken.add(f"{stem}{n}")
    return f"{stem}{n}"


def change_kinds(n_instances: int, rng: random.Random) -> list[str]:
    count = max(round(SHARE * n_instances), len(KINDS) if n_instances >= len(KINDS) else 1)
    first = list(KINDS) if count >= len(KINDS) else []
    return first + [rng.choice(KINDS) for _ in range(count - len(first))]


__all__ = [
    "KINDS",
    "SHARE",
    "STRUCTURE_WORDS",
    "DECIMALS",
    "Instance",
    "Change",
    "Planner",
    "planned_instances",
    "excluded_parts",
    "classify",
    "change_kinds",
    "unique_name",
    "rounded",
    "base_point",
    "overlapping",
    "world_box",
    "moved_box",
]
