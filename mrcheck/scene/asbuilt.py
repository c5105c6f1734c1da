"""``mrcheck scene asbuilt``: a perturbed copy of a planned scene, and the list of what differs.

Ground truth for discrepancy checks: the planned scene says where things should be, the
as-built variant is what a photo of the real hall would show, and ``discrepancies.json`` says
exactly what changed. The same planned scene and seed always give byte-identical files.

Output folder::

    OUTDIR/scene.toml          the as-built manifest (format 1, as mrcheck.scene.model reads it)
    OUTDIR/discrepancies.json  the changes, below
    OUTDIR/...                 copies of every file the meshes need (URDF folders with their
                               meshes and licence files too), in the planned scene's layout, so
                               the folder is self-contained and can be moved anywhere
    OUTDIR/external/<n>/...    the same for meshes outside the planned scene's folder, one
                               numbered folder per folder they come from (see :func:`_layout`)

A new variant in the folder of an earlier one replaces only what that one wrote (its manifest,
its report and the folders its meshes are in); other files there stay.

``discrepancies.json``::

    {"planned": "/abs/path/of/the/planned/scene.toml",
     "seed": 0,
     "excluded_parts": [{"part": "floor", "reason": "largest footprint"}, ...],
     "discrepancies": [
       {"id": "pallet#3", "part": "pallet", "kind": "moved", "magnitude": 0.734, "unit": "m",
        "detail": {"vector": [dx, dy, 0.0], "from": [x, y, z], "to": [x, y, z]}},
       ...]}

``id`` is the instance id of :attr:`mrcheck.scene.model.Part.instance_ids`, the same in both scenes.
``from``, ``to``, ``position`` and ``pivot`` points are world coordinates (metres for parts with
declared units); a "base" point is the centre of the bottom face of an instance's bounding box.

=========  =========================================================  ==========  =====
kind       change                                                      magnitude   unit
=========  =========================================================  ==========  =====
moved      translated horizontally by 0.05 .. 2 m; detail: ``vector``  distance    m
           (dx, dy, 0), ``from`` and ``to`` (base points)
rotated    turned about the vertical axis through ``pivot`` by         abs. angle  deg
           ``angle_deg`` (signed, counter-clockwise seen from above),
           5 .. 90 deg; the pivot is the part's own origin when it lies
           inside the instance's footprint (a robot's base, a pallet's
           centre), else the footprint centre
missing    the instance is not in the as-built scene;                  null        null
           detail: ``position`` (base point it had)
added      a new instance (a new id) of an existing part, standing     null        null
           free on the floor; detail: ``position`` (base point),
           ``template`` (the instance it copies, shifted horizontally)
replaced   replaced by another size: scaled uniformly by 0.7 .. 0.9 or  scale       null
           1.1 .. 1.4 about its base point (``pivot``); written as a
           part of its own (``new_part``) with ``scale``, same mesh
=========  =========================================================  ==========  =====

Which instances change (all drawn from the seed, with Python's ``random``, whose stream does
not depend on the platform): ``max(round(10 % of the instances), 5)`` changes, one of each kind
first, the rest of random kinds (a scene of fewer than 5 instances gets one). Each part is as
likely to be picked as any other, however many instances it has. A kind that no instance can
take under the rules below is skipped with a warning on stderr. Never changed, listed in
``excluded_parts``: the part with the largest single bounding-box footprint (the floor slab,
or a hall shell) and every part whose name contains one of :data:`STRUCTURE_WORDS` (floor,
slab, wall, roof, ceiling, column, beam, hall) -- the building is not what an as-built check
is about. So that nothing floats and nothing sinks, the changes keep physical sense:

- only an instance with nothing standing on it or hanging from it is moved, rotated, removed
  or replaced (a pallet carrying cartons, a fence post holding panels and the robot's pedestal
  stay put); one that hangs from another (a fence panel between posts) can only go missing;
- moved and added instances stand on the floor (their base at the lowest base of the scene's
  objects), stay inside the floor's footprint, keep a clear gap to everything else and stay
  out of the 3 m around the foot of each viewpoint's eye (there they would hide the view);
- rotated and replaced instances still stand on what they stood on (the robot on its
  pedestal, cartons on their pallet) and run into nothing else;
- every change is horizontal or about a vertical axis or the base, so no base moves vertically.

An instance gets at most one change. The manifest keeps every untouched part as it was (mesh
paths rewritten relative to OUTDIR); a part with a changed instance gets an explicit ``id`` on
every instance so the ids of the others stay what they were.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import check_not_inputs, check_writable_ancestor
from mrcheck.scene.manifest import (
    dumps_manifest,
    mesh_files,
    notice_files,
    read_manifest,
    write_generated,
)
from mrcheck.scene.model import load_scene, transform_from_table

__all__ = ["make_asbuilt", "KINDS", "STRUCTURE_WORDS", "SHARE"]

KINDS = ("moved", "rotated", "missing", "added", "replaced")
SHARE = 0.10                                  # of the scene's instances that change
STRUCTURE_WORDS = ("floor", "slab", "wall", "roof", "ceiling", "column", "beam", "hall")
MOVE_M = (0.05, 2.0)                          # horizontal distance of a move
ROTATE_DEG = (5.0, 90.0)                      # about the vertical axis
SCALES = ((0.7, 0.9), (1.1, 1.4))             # a replacement of another size; not 0.9 .. 1.1, too alike
CONTACT_M = 0.01                              # boxes this close count as touching, not overlapping
SINK_M = 0.05                                 # a base this far below a top still stands on it (bolt heads)
CLEARANCE_M = 0.05                            # free gap around a moved or added instance
EYE_CLEAR_M = 3.0                             # no object is put this close (horizontally) below a viewpoint's eye
TRIES = 40                                    # random placements tried per candidate instance
DECIMALS = 9                                  # of computed coordinates: 3.123, not 3.1229999999999998


@dataclass
class _Instance:
    id: str
    part: str
    index: int              # position in its part's instance list
    transform: np.ndarray   # (4, 4) local -> world as loaded (Part.transforms)
    corners: np.ndarray     # (8, 4) homogeneous corners of the part's local bounds
    origin: np.ndarray      # (3,) world position of the part's own (authored) origin
    box: np.ndarray         # (2, 3) world bounds
    on_floor: bool = False
    free: bool = True       # nothing rests on it or hangs from it
    held: bool = False      # hangs from something beside it (a fence panel between its posts)
    supporters: set = field(default_factory=set)  # ids of the instances it stands on


@dataclass(frozen=True)
class _Change:
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
            return {"matrix": [_rounded(row) for row in M]}
        t = np.asarray(instance.get("translate", (0.0, 0.0, 0.0)), np.float64)
        r = np.asarray(instance.get("rotate_deg", (0.0, 0.0, 0.0)), np.float64)
        s = float(instance.get("scale", 1.0)) * self.scale
        if self.angle_deg:
            # Rz(a) @ Rz(c) Ry(b) Rx(a0) = Rz(c + a) Ry(b) Rx(a0): the turn adds to the Euler z angle
            z = r[2] + self.angle_deg
            r[2] = z - 360.0 if z > 180.0 else z + 360.0 if z <= -180.0 else z
        out = {"translate": _rounded(np.add(self.pivot, self.shift) + self.linear() @ (t - self.pivot))}
        if np.any(r != 0):
            out["rotate_deg"] = _rounded(r)
        if s != 1.0:
            out["scale"] = round(s, DECIMALS)
        return out


def _rounded(values) -> list:
    return [round(float(v), DECIMALS) + 0.0 for v in values]  # + 0.0: no -0.0 in the files


def _base(box) -> np.ndarray:
    """Centre of the bottom face of a (2, 3) box."""
    return np.array([(box[0, 0] + box[1, 0]) / 2, (box[0, 1] + box[1, 1]) / 2, box[0, 2]])


def _overlapping(box, boxes) -> np.ndarray:
    """Which of ``boxes`` (n, 2, 3) overlap ``box`` by more than :data:`CONTACT_M` on every axis."""
    if len(boxes) == 0:
        return np.zeros(0, bool)
    lo, hi = np.maximum(box[0], boxes[:, 0]), np.minimum(box[1], boxes[:, 1])
    return np.all(hi - lo > CONTACT_M, axis=1)


# -- the planned scene ---------------------------------------------------------------------------
def _instances(scene, tables) -> list[_Instance]:
    found = []
    for part, table in zip(scene.parts, tables):
        base = transform_from_table(table, part.name)
        lo, hi = part.local_bounds()
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for index, (iid, T, inst) in enumerate(zip(part.instance_ids, part.transforms, table.get("instances") or [{}])):
            origin = (transform_from_table(inst, part.name) @ base)[:3, 3]
            found.append(_Instance(iid, part.name, index, T, corners, origin, _box(T, corners)))
    return found


def _box(T, corners) -> np.ndarray:
    """World bounds of local box ``corners`` (8, 4) under the transform ``T``, as Part.instance_bounds."""
    world = (corners @ T.T)[:, :3]
    return np.stack([world.min(axis=0), world.max(axis=0)])


def _moved_box(inst: _Instance, change: _Change) -> np.ndarray:
    return _box(change.matrix() @ inst.transform, inst.corners)


def _excluded(scene) -> dict:
    """{part name: reason} of the parts that never change (the building)."""
    footprint = {p.name: max(float(np.prod(b[1, :2] - b[0, :2])) for b in p.instance_bounds()) for p in scene.parts}
    largest = max(footprint, key=footprint.get)  # first of equals: manifest order
    reasons = {largest: "largest footprint"}
    for part in scene.parts:
        word = next((w for w in STRUCTURE_WORDS if w in part.name.lower()), None)
        if word and part.name not in reasons:
            reasons[part.name] = f"name contains {word!r}"
    return reasons


def _classify(instances: list[_Instance], floor_part: str, excluded: dict) -> float:
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
        xy = np.all(np.minimum(inst.box[1, :2], other[:, 1, :2]) - np.maximum(inst.box[0, :2], other[:, 0, :2]) > CONTACT_M, axis=1)
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
class _Planner:
    """Draws the changes from the seed, keeping the world's boxes up to date as it goes."""

    def __init__(self, instances, excluded, floor_part, floor_z, region, eyes, seed):
        self.rng = random.Random(seed)  # Python's generator: same stream on every platform and version
        self.instances = instances
        self.excluded = excluded
        self.region = region              # (2, 2) xy footprint the floor covers
        self.boxes = {i.id: i.box for i in instances if i.part != floor_part}
        # a camera's near foreground stays as it was: an object put there would hide the view
        for k, (x, y, z) in enumerate(eyes):
            self.boxes[("eye", k)] = np.array([[x - EYE_CLEAR_M, y - EYE_CLEAR_M, floor_z - 1.0],
                                               [x + EYE_CLEAR_M, y + EYE_CLEAR_M, z + 0.5]])
        self.used = set()
        self.taken_ids = {i.id for i in instances}
        self.changes = []                 # (kind, _Instance (the template for added), _Change, new id or None)
        self._cache = None

    def _world(self):
        if self._cache is None:  # rebuilt only after a change: a hall has thousands of boxes
            self._cache = (list(self.boxes), np.array(list(self.boxes.values())).reshape(-1, 2, 3))
        return self._cache

    def _blocked(self, box, ignore=(), clearance=0.0) -> bool:
        if clearance:
            box = box + np.array([[-clearance, -clearance, 0.0], [clearance, clearance, 0.0]])
        keys, boxes = self._world()
        hits = _overlapping(box, boxes)
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
        eyes = {keys[k] for k in np.flatnonzero(_overlapping(inst.box, boxes)) if isinstance(keys[k], tuple)}
        return not self._blocked(box, inst.supporters | eyes | {inst.id})

    def _draw(self, kind, inst):
        """A change of ``kind`` for ``inst`` that fits, or None after :data:`TRIES` draws."""
        rng = self.rng
        for _ in range(TRIES):
            if kind == "moved":
                distance, heading = round(rng.uniform(*MOVE_M), 3), np.radians(round(rng.uniform(0.0, 360.0), 1))
                change = _Change(shift=(distance * np.cos(heading), distance * np.sin(heading), 0.0))
                if self._on_free_floor(_moved_box(inst, change), {inst.id}):
                    return change
            elif kind == "added":
                x, y = (rng.uniform(*self.region[:, k]) for k in (0, 1))
                b = _base(inst.box)
                change = _Change(shift=(round(x - b[0], 3), round(y - b[1], 3), 0.0))
                if self._on_free_floor(_moved_box(inst, change)):
                    return change
            elif kind == "rotated":
                angle = round(rng.uniform(*ROTATE_DEG), 1) * rng.choice((-1, 1))
                inside = np.all(inst.origin[:2] >= inst.box[0, :2]) and np.all(inst.origin[:2] <= inst.box[1, :2])
                pivot = inst.origin if inside else _base(inst.box)
                change = _Change(pivot=tuple(pivot), angle_deg=angle)
                if self._fits_in_place(inst, _moved_box(inst, change)):
                    return change
            elif kind == "replaced":
                scale = round(rng.uniform(*rng.choice(SCALES)), 2)
                change = _Change(pivot=tuple(_base(inst.box)), scale=scale)
                if self._fits_in_place(inst, _moved_box(inst, change)):
                    return change
            else:  # missing: always possible for a free instance
                return _Change()
        return None

    def _pool(self, kind) -> list[_Instance]:
        pool = [i for i in self.instances if i.part not in self.excluded and i.free]
        if kind in ("moved", "added"):
            pool = [i for i in pool if i.on_floor]
        elif kind in ("rotated", "replaced"):  # turned or resized, it would leave what holds it
            pool = [i for i in pool if not i.held]
        if kind != "added":  # an added copy may share its template with another change
            pool = [i for i in pool if i.id not in self.used]
        return pool

    def plan(self, kinds, progress: bool = False):
        from tqdm import tqdm

        # the longest step on a big hall (each draw is checked against thousands of boxes)
        with tqdm(kinds, desc="choosing changes", unit="change", disable=None if progress else True, leave=False) as bar:
            for kind in bar:
                self._plan_one(kind)
        return self.changes

    def _plan_one(self, kind):
        # parts first, then their instances, both in random order: each part is as likely to
        # change as any other, however many instances it has (18 fence panels, 1 robot)
        by_part = {}
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
            from tqdm import tqdm

            # through tqdm: a line of its own above the bar, not into it
            tqdm.write(f"warning: no free instance fits a {kind!r} change; the variant has one change fewer", file=sys.stderr)

    def _apply(self, kind, inst, change):
        self._cache = None
        new_id = None
        if kind == "added":
            new_id = _unique(f"{inst.part}#added", self.taken_ids)
            self.boxes[new_id] = _moved_box(inst, change)
        else:
            self.used.add(inst.id)
            if kind == "missing":
                self.boxes.pop(inst.id, None)
            else:
                self.boxes[inst.id] = _moved_box(inst, change)
        self.changes.append((kind, inst, change, new_id))


def _unique(stem: str, taken: set) -> str:
    """``stem`` + the first number from 1 not yet in ``taken`` (which it joins)."""
    n = 1
    while f"{stem}{n}" in taken:
        n += 1
    taken.add(f"{stem}{n}")
    return f"{stem}{n}"


def _kinds(n_instances: int, rng: random.Random) -> list[str]:
    count = max(round(SHARE * n_instances), len(KINDS) if n_instances >= len(KINDS) else 1)
    first = list(KINDS) if count >= len(KINDS) else []
    return first + [rng.choice(KINDS) for _ in range(count - len(first))]


# -- writing -----------------------------------------------------------------------------------------
def _record(kind, inst, change, new_id, new_part) -> dict:
    if kind == "moved":
        shift = _rounded(change.shift)
        detail = {"vector": shift, "from": _rounded(_base(inst.box)), "to": _rounded(_base(inst.box) + shift)}
        return _entry(inst, kind, round(float(np.hypot(*change.shift[:2])), DECIMALS), "m", detail)
    if kind == "rotated":
        detail = {"angle_deg": change.angle_deg, "axis": [0.0, 0.0, 1.0], "pivot": _rounded(change.pivot)}
        return _entry(inst, kind, abs(change.angle_deg), "deg", detail)
    if kind == "missing":
        return _entry(inst, kind, None, None, {"position": _rounded(_base(inst.box))})
    if kind == "added":
        detail = {"position": _rounded(_base(inst.box) + change.shift), "template": inst.id}
        return {**_entry(inst, kind, None, None, detail), "id": new_id}
    detail = {"scale": change.scale, "pivot": _rounded(change.pivot), "new_part": new_part}
    return _entry(inst, kind, change.scale, None, detail)


def _entry(inst, kind, magnitude, unit, detail) -> dict:
    return {"id": inst.id, "part": inst.part, "kind": kind, "magnitude": magnitude, "unit": unit, "detail": detail}


def _asbuilt_tables(tables, scene, changes) -> tuple[list, list]:
    """The as-built [[parts]] tables and the discrepancy records, in manifest order."""
    by_id = {inst.id: (kind, inst, change) for kind, inst, change, _ in changes if kind != "added"}
    added = {}
    for kind, inst, change, new_id in changes:
        if kind == "added":
            added.setdefault(inst.part, []).append((inst, change, new_id))
    names = {p.name for p in scene.parts}
    records, out = [], []
    for part, table in zip(scene.parts, tables):
        # an unnamed part is named by its position (part3), which dropping or adding parts would change
        table = {"name": part.name, **table}
        originals = table.get("instances") or [{}]
        touched = added.get(part.name) or any(i in by_id for i in part.instance_ids)
        if not touched:
            out.append(table)
            continue
        kept, replacements = [], []
        plain = {k: v for k, v in table.items() if k != "instances"}
        for iid, inst_table in zip(part.instance_ids, originals):
            kind, inst, change = by_id.get(iid, (None, None, None))
            new_part = None
            if kind is None:
                kept.append({"id": iid, **{k: v for k, v in inst_table.items() if k != "id"}})
            elif kind in ("moved", "rotated"):
                kept.append({"id": iid, **change.table(inst_table)})
            elif kind == "replaced":
                # another size is another product: a part of its own, same mesh, with a scale
                new_part = _unique(f"{part.name}-replaced-", names)
                replacements.append({**plain, "name": new_part, "instances": [{"id": iid, **change.table(inst_table)}]})
            if kind is not None:
                records.append(_record(kind, inst, change, None, new_part))
        for inst, change, new_id in added.get(part.name, []):
            template = originals[inst.index]
            kept.append({"id": new_id, **change.table(template)})
            records.append(_record("added", inst, change, new_id, None))
        if kept:  # a part left with no instance is dropped: an empty list would mean one, untransformed
            out.append({**plain, "instances": kept})
        out += replacements
    records.sort(key=lambda r: (KINDS.index(r["kind"]), r["id"]))
    return out, records


def _layout(manifest: Path, tables) -> dict:
    """{part mesh string: [(source file, path in OUTDIR)]}, the mesh file first.

    A part whose files all lie in the manifest's folder keeps its path there. Any other (mesh =
    "../shared/x.glb", "/data/robots/pybullet_data/kuka_iiwa/model.urdf") goes to
    ``external/<n>/``, n = 1, 2, ... for each folder holding such parts' files (the outermost of
    nested ones, in path order), laid out as in that folder: a URDF keeps its meshes and its
    package's licence where its relative paths expect them, and the variant does not mirror
    the file system from ``/``.
    """
    home = Path(os.path.normpath(manifest.parent.absolute()))
    files, inside = {}, {}
    for table in tables:
        mesh = manifest.parent / table["mesh"]
        found = mesh_files(mesh)
        inside[table["mesh"]] = all(home in f.parents for f in found)
        # a licence above the scene's folder for a part inside it (a robot.urdf beside
        # scene.toml) would be the licence of whatever project holds the scene: left out
        notices = [n for n in notice_files(mesh) if not inside[table["mesh"]] or home in n.parents]
        files[table["mesh"]] = list(dict.fromkeys(found + notices))
    roots = []
    for root in sorted({Path(os.path.commonpath([f.parent for f in found])) for mesh, found in files.items()
                        if not inside[mesh]}, key=lambda p: p.parts):   # a folder before those inside it
        if not any(r == root or r in root.parents for r in roots):
            roots.append(root)
    layout = {}
    for mesh, found in files.items():
        if inside[mesh]:
            layout[mesh] = [(f, f.relative_to(home).as_posix()) for f in found]
        else:
            n, root = next((n, r) for n, r in enumerate(roots, 1) if r == found[0].parent or r in found[0].parents)
            layout[mesh] = [(f, f"external/{n}/{f.relative_to(root).as_posix()}") for f in found]
    return layout


def _check_outdir(outdir: Path, manifest: Path):
    out, home = outdir.resolve(), manifest.parent.resolve()
    if out == home:
        raise MrcheckError("the output folder is the planned scene's own folder; pick another", outdir)
    if out in home.parents:
        raise MrcheckError("the output folder contains the planned scene, which replacing it would delete", outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("the output is a file, not a folder", outdir)
    check_writable_ancestor(outdir)    # fail before the work, not after it
    if outdir.is_dir() and any(outdir.iterdir()) and not (outdir / "discrepancies.json").is_file():
        # only an earlier as-built variant's files (or an empty folder's nothing) are replaced
        raise MrcheckError("the output folder exists and is not an as-built variant (no discrepancies.json)", outdir)


def _earlier_entries(outdir: Path) -> set:
    """Top-level entries an earlier variant in ``outdir`` wrote: its manifest, its report and
    the first folder (or file) of each mesh path its manifest names. Regenerating replaces
    these and nothing else there."""
    names = {"scene.toml", "discrepancies.json"}
    try:
        parts = read_manifest(outdir / "scene.toml").get("parts", [])
    except MrcheckError:   # missing or unreadable: only the two fixed names are the variant's
        return names
    for part in parts if isinstance(parts, list) else []:
        mesh = part.get("mesh") if isinstance(part, dict) else None
        if isinstance(mesh, str) and mesh:
            first = PurePosixPath(mesh).parts[0]
            if first not in ("/", "..", "."):     # a variant's paths are relative and inside it
                names.add(first)
    return names


def make_asbuilt(scene_path, outdir, seed: int = 0, progress: bool = True) -> list[Path]:
    """Write the as-built variant of the planned manifest ``scene_path`` for ``seed`` into
    ``outdir`` (replacing an earlier variant there); returns [scene.toml, discrepancies.json].
    ``progress``: bars for loading, choosing the changes and copying, on a terminal only."""
    scene = load_scene(Path(scene_path), progress=progress)
    # absolute first: `-o .` and `-o ../here` from inside the folder name the same folder
    manifest, outdir = scene.source, Path(os.path.abspath(outdir))
    if manifest.suffix.lower() != ".toml":
        raise MrcheckError("an as-built variant is made from a scene manifest (.toml), not a single mesh file", manifest)
    _check_outdir(outdir, manifest)
    data = read_manifest(manifest)
    tables = data["parts"]
    layout = _layout(manifest, tables)
    # every top-level entry written or replaced in OUTDIR (its meshes/, external/ ...) goes as a whole
    stale = _earlier_entries(outdir)
    entries = stale | {PurePosixPath(name).parts[0] for files in layout.values() for _, name in files}
    check_not_inputs([], [("the planned scene", manifest),
                          *((f"a file of part mesh {mesh}", [f for f, _ in files]) for mesh, files in layout.items())],
                     folders=[outdir / name for name in sorted(entries)])

    instances = _instances(scene, tables)
    excluded = _excluded(scene)
    floor_part = next(name for name, why in excluded.items() if why == "largest footprint")
    if all(i.part in excluded for i in instances):
        raise MrcheckError(f"nothing to change: every part is floor or hall structure ({', '.join(excluded)})", manifest)
    floor_z = _classify(instances, floor_part, excluded)
    floor_boxes = scene.parts[[p.name for p in scene.parts].index(floor_part)].instance_bounds()
    region = np.array([floor_boxes[:, 0, :2].min(axis=0), floor_boxes[:, 1, :2].max(axis=0)])
    eyes = [vp["eye"] for vp in scene.viewpoints.values()]
    planner = _Planner(instances, excluded, floor_part, floor_z, region, eyes, seed)
    changes = planner.plan(_kinds(len(instances), planner.rng), progress)
    parts, records = _asbuilt_tables(tables, scene, changes)

    used = sorted({pair for table in parts for pair in layout[table["mesh"]]})  # not the meshes of dropped parts
    for table in parts:
        table["mesh"] = layout[table["mesh"]][0][1]
    planned = str(manifest.resolve())
    header = (f"As-built variant of {planned}\nmade by `mrcheck scene asbuilt --seed {seed}`: "
              "every change is listed in discrepancies.json.")
    name = str(data.get("name", manifest.stem))
    description = f"As built (seed {seed}) of {name}. {data.get('description', '')}".strip()
    out_data = {"format": 1, **data, "name": f"{name}_asbuilt_{seed}", "description": description, "parts": parts}
    report = {"planned": planned, "seed": seed,
              "excluded_parts": [{"part": name, "reason": why} for name, why in excluded.items()],
              "discrepancies": records}

    def fill(tmp: Path):
        from tqdm import tqdm

        for source, name in tqdm(used, desc="copying meshes", unit="file", disable=None if progress else True, leave=False):
            target = tmp / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
        (tmp / "scene.toml").write_text(dumps_manifest(out_data, header))
        (tmp / "discrepancies.json").write_text(json.dumps(report, indent=2) + "\n")

    write_generated(outdir, fill, stale=stale)
    return [outdir / "scene.toml", outdir / "discrepancies.json"]
