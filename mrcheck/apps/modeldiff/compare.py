"""The element diff of two revisions: added, removed, moved, changed geometry, unchanged.

Elements are matched by id (:mod:`mrcheck.apps.modeldiff.elements`). A matched pair is

* **changed geometry** when the meshes differ (vertex count, faces, or a vertex by more than
  :data:`TOLERANCE_M`) or the transforms differ by more than a rigid motion (a scale, a mirror,
  a shear): some corner of the element's box lands more than :data:`TOLERANCE_M` from where the
  best-fitting rotation puts it;
* **moved** when the geometry is the same and the rigid motion between the two placements moves
  the element's box centre by more than :data:`TOLERANCE_M` or turns it by more than
  :data:`TOLERANCE_DEG`; the offset (metres, world axes) and the rotation (degrees, about
  ``axis``) are reported. A shape whose exporter baked its position into the mesh (a STEP shape
  outside an assembly, a glTF mesh with identity nodes) is moved too when the two meshes have the
  same faces and their world vertices differ by a rigid motion (every vertex within
  :data:`TOLERANCE_M` of the fit); otherwise it is changed geometry;
* **unchanged** otherwise.

The tolerances are what a planner cares about (a millimetre, a tenth of a degree: the 1 mm
chord of a 0.6 m object) and far above float noise: an unchanged element of an IFC at map
coordinates reads back to the same bits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mrcheck.apps.modeldiff.elements import Element, same_mesh, same_topology, scene_elements
from mrcheck.scene.model import Scene

TOLERANCE_M = 0.001  # a move, a vertex's difference or a deformation below this is no change, metres
TOLERANCE_DEG = 0.1  # a rotation below this is no change, degrees
KINDS = ("added", "removed", "moved", "changed geometry", "unchanged")


@dataclass(frozen=True)
class Change:
    """One element's row of the diff. Points and offsets in world metres; ``rotation_deg`` about
    the unit ``axis`` (counter-clockwise looking down the axis), None where it does not apply."""

    id: str
    kind: str
    label: str
    global_id: str | None
    part_old: str | None
    part_new: str | None
    old_centre: tuple | None
    new_centre: tuple | None
    offset_m: tuple | None = None
    rotation_deg: float | None = None
    axis: tuple | None = None
    size_old_m: tuple | None = None
    size_new_m: tuple | None = None

    @property
    def distance_m(self) -> float | None:
        return None if self.offset_m is None else float(np.linalg.norm(self.offset_m))


@dataclass(frozen=True)
class ModelDiff:
    """Every element of both revisions, changes first (in :data:`KINDS` order), then unchanged."""

    old: str
    new: str
    tolerance_m: float
    tolerance_deg: float
    rows: list = field(default_factory=list)  # Change

    @property
    def counts(self) -> dict[str, int]:
        return {kind: sum(r.kind == kind for r in self.rows) for kind in KINDS}

    @property
    def changes(self) -> list[Change]:
        return [r for r in self.rows if r.kind != "unchanged"]


def _rounded(values, digits: int = 6) -> tuple:
    return tuple(round(float(v), digits) for v in values)


def rigid_fit(old: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, float]:
    """The rotation R (3, 3) that best maps the centred points ``old`` onto ``new`` (Kabsch,
    proper rotations only) and the largest distance left, metres."""
    a, b = old - old.mean(axis=0), new - new.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    residual = float(np.linalg.norm(a @ rotation.T - b, axis=1).max(initial=0.0))
    return rotation, residual


def rotation_angle_axis(rotation: np.ndarray) -> tuple[float, np.ndarray]:
    """(degrees, unit axis) of a rotation matrix; the axis is +z for no rotation."""
    cos = float(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0))
    angle = math.degrees(math.acos(cos))
    axis = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])
    norm = float(np.linalg.norm(axis))
    if norm < 1e-12:  # 0 or 180 degrees: the axis is the eigenvector of eigenvalue 1
        if angle < 90.0:
            return angle, np.array([0.0, 0.0, 1.0])
        w, v = np.linalg.eigh((rotation + rotation.T) / 2.0)
        return angle, v[:, int(np.argmax(w))]
    return angle, axis / norm


def compare_pair(old: Element, new: Element, tolerance_m: float, tolerance_deg: float, meshes=None) -> Change:
    """The row of an element in both revisions (module docstring); ``meshes``: a
    :class:`MeshPairs` shared by the pairs of one diff."""
    meshes = meshes if meshes is not None else MeshPairs(tolerance_m)
    base: dict[str, Any] = dict(
        id=new.id,
        label=new.label,
        global_id=new.global_id or old.global_id,
        part_old=old.part.name,
        part_new=new.part.name,
        old_centre=_rounded(old.centre),
        new_centre=_rounded(new.centre),
    )
    same = meshes.same(old.part, new.part)
    if same and np.array_equal(old.matrix, new.matrix):  # most elements of a weekly revision
        return Change(kind="unchanged", **base)
    if same:  # the placement changed: its box's corners say how
        points = old.corners(), new.corners()
    elif same_topology(old.part, new.part):  # a shape whose position is baked into its mesh
        points = old.world_vertices(), new.world_vertices()
    else:
        return _changed(old, new, base)
    rotation, residual = rigid_fit(*points)
    if residual > tolerance_m:
        return _changed(old, new, base)
    # where the motion takes the old box centre (for a baked shape the new box is not the old one
    # turned: the axis-aligned box of a turned mesh is another box)
    moved_centre = rotation @ (old.centre - points[0].mean(axis=0)) + points[1].mean(axis=0)
    offset = moved_centre - old.centre
    angle, axis = rotation_angle_axis(rotation)
    if float(np.linalg.norm(offset)) > tolerance_m or angle > tolerance_deg:
        base["new_centre"] = _rounded(moved_centre)
        return Change(
            kind="moved", offset_m=_rounded(offset), rotation_deg=round(angle, 4), axis=_rounded(axis), **base
        )
    return Change(kind="unchanged", **base)


def _changed(old: Element, new: Element, base: dict) -> Change:
    return Change(
        kind="changed geometry",
        offset_m=_rounded(new.centre - old.centre),
        size_old_m=_rounded(old.size()),
        size_new_m=_rounded(new.size()),
        **base,
    )


class MeshPairs:
    """:func:`same_mesh` of part pairs, each pair compared once (a part's instances share it)."""

    def __init__(self, tolerance_m: float):
        self.tolerance_m = tolerance_m
        self._known: dict[tuple[int, int], bool] = {}

    def same(self, a, b) -> bool:
        key = (id(a), id(b))
        if key not in self._known:
            self._known[key] = same_mesh(a, b, self.tolerance_m)
        return self._known[key]


def _one_side(element: Element, kind: str) -> Change:
    centre = _rounded(element.centre)
    return Change(
        id=element.id,
        kind=kind,
        label=element.label,
        global_id=element.global_id,
        part_old=element.part.name if kind == "removed" else None,
        part_new=element.part.name if kind == "added" else None,
        old_centre=centre if kind == "removed" else None,
        new_centre=centre if kind == "added" else None,
        size_old_m=_rounded(element.size()) if kind == "removed" else None,
        size_new_m=_rounded(element.size()) if kind == "added" else None,
    )


def diff_scenes(
    old: Scene, new: Scene, tolerance_m: float = TOLERANCE_M, tolerance_deg: float = TOLERANCE_DEG
) -> ModelDiff:
    """The element diff of two loaded revisions (module docstring). A mesh pair is compared
    once however many instances share it (the tolerance check is a vertex-array comparison)."""
    before, after = scene_elements(old), scene_elements(new)
    rows = [_one_side(e, "added") for i, e in after.items() if i not in before]
    rows += [_one_side(e, "removed") for i, e in before.items() if i not in after]
    meshes = MeshPairs(tolerance_m)
    rows += [compare_pair(before[i], e, tolerance_m, tolerance_deg, meshes) for i, e in after.items() if i in before]
    rows.sort(key=lambda r: KINDS.index(r.kind))  # stable: scene order within a kind
    return ModelDiff(str(old.source), str(new.source), tolerance_m, tolerance_deg, rows)


__all__ = [
    "Change",
    "ModelDiff",
    "diff_scenes",
    "compare_pair",
    "MeshPairs",
    "rigid_fit",
    "rotation_angle_axis",
    "KINDS",
    "TOLERANCE_M",
    "TOLERANCE_DEG",
]
