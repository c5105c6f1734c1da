"""A planned scene: parts placed but not yet built, pallet places, and the mesh cache.

Units: metres, degrees. A :class:`PartPlan` knows how to build its mesh at any level of
detail; :class:`Plan` counts triangles as rendered (mesh triangles times instances) and
turns itself into manifest parts once the budget solver has picked a level and a fill.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import trimesh

from .detail import Detail
from .manifest import Part, place
from .presets import COLORS
from .storage import carton_stack, crate_load, eur_pallet


def seeded_cartons(layers, extra, seed, detail: Detail) -> trimesh.Trimesh:
    """:func:`storage.carton_stack` with its jitter drawn from ``seed`` (the same mesh every call)."""
    return carton_stack(layers, extra, np.random.default_rng(seed), detail)


# loads on pallets: colour key and builder (in the pallet's frame); the seeds differ per load
LOADS = {
    "cartons_full": ("cartons", partial(seeded_cartons, 3, 0)),
    "cartons_tall": ("cartons", partial(seeded_cartons, 4, 0)),
    "cartons_partial": ("cartons", partial(seeded_cartons, 1, 4)),
    "crate": ("crate", None),
}
LOAD_WEIGHTS = {"cartons_full": 0.4, "cartons_tall": 0.2, "cartons_partial": 0.15, "crate": 0.15, None: 0.1}


@dataclass
class Slot:
    """A place for a pallet: pose (metres, degrees) and what stands on it if it is filled."""

    id: str
    x: float
    y: float
    z: float
    yaw: float
    load: str | None  # key of LOADS, or None for an empty pallet


@dataclass
class PartPlan:
    """A part before its mesh exists.

    ``build`` is a ``functools.partial`` of a part builder (metres) that takes the level of
    detail as its ``detail`` keyword if it has one; None for a URDF robot, which brings its
    ``path``, ``joints`` and ``triangles`` instead.
    """

    name: str
    color: tuple
    category: str  # key of presets.UNITS_MIX
    build: partial | None = None
    instances: list = field(default_factory=list)
    path: str | None = None
    joints: dict | None = None
    triangles: int = 0
    translate: tuple | None = None
    rotate_deg: tuple | None = None

    @property
    def key(self) -> tuple:
        """Identifies the mesh: the builder and its arguments (all hashable)."""
        b = self.build
        return (b.func.__module__, b.func.__qualname__, b.args, tuple(sorted(b.keywords.items())))


class MeshCache:
    """Meshes by (builder and arguments, level): the budget solver counts one plan at several
    levels, and parts built alike (all 4 m conveyor segments) are built once."""

    def __init__(self):
        self._meshes = {}

    def get(self, plan: PartPlan, detail: Detail) -> trimesh.Trimesh:
        key = (plan.key, detail.level)
        if key not in self._meshes:
            takes_detail = "detail" in inspect.signature(plan.build.func).parameters
            mesh = plan.build(detail=detail) if takes_detail else plan.build()
            if len(mesh.faces) == 0:
                raise RuntimeError(f"part {plan.name!r} built no triangles at level {detail.level} (a layout bug)")
            self._meshes[key] = mesh
        return self._meshes[key]


@dataclass
class Plan:
    """Everything placed, no meshes yet."""

    name: str
    description: str
    parts: list[PartPlan]
    slots: list[Slot]  # in fill order
    robots: list[str]  # robot models to copy next to the manifest
    viewpoints: list[dict]
    seed: int

    def fixed_triangles(self, detail: Detail, cache: MeshCache) -> int:
        """Triangles as rendered of everything but the pallets and their loads."""
        return sum(
            (len(cache.get(p, detail).faces) if p.build else p.triangles) * max(1, len(p.instances)) for p in self.parts
        )

    def slot_triangles(self, detail: Detail, cache: MeshCache) -> np.ndarray:
        """(len(slots),) int64: triangles a filled slot adds (pallet plus load), in fill order."""
        pallet = len(cache.get(self._pallet_plan(), detail).faces)
        per_load = {name: len(cache.get(self._load_plan(name), detail).faces) for name in LOADS}
        return np.array([pallet + per_load.get(s.load, 0) for s in self.slots], dtype=np.int64)

    def manifest_parts(self, detail: Detail, cache: MeshCache, filled: int) -> list[Part]:
        """The manifest parts (meshes in metres) with the first ``filled`` slots filled."""
        return [
            Part(
                name=p.name,
                color=p.color,
                mesh=cache.get(p, detail) if p.build else None,
                path=p.path,
                units="m",
                translate=p.translate,
                rotate_deg=p.rotate_deg,
                joints=p.joints,
                instances=p.instances,
                triangles=p.triangles,
            )
            for p in self.part_plans(filled)
        ]

    def part_plans(self, filled: int):
        """The fixed part plans, then the pallet and load parts of the first ``filled`` slots."""
        yield from self.parts
        used = sorted(self.slots[:filled], key=lambda s: s.id)  # manifest order by id
        pallet = self._pallet_plan()
        pallet.instances = [place(s.x, s.y, s.z, s.yaw, id=s.id) for s in used]
        if pallet.instances:
            yield pallet
        for name in LOADS:
            load = self._load_plan(name)
            load.instances = [place(s.x, s.y, s.z, s.yaw, id=f"{s.id}-load") for s in used if s.load == name]
            if load.instances:
                yield load

    def categories(self) -> dict[str, str]:
        """{part name: presets.UNITS_MIX category} of every part the plan can produce."""
        plans = [*self.parts, self._pallet_plan(), *(self._load_plan(n) for n in LOADS)]
        return {p.name: p.category for p in plans}

    def _pallet_plan(self) -> PartPlan:
        return PartPlan("pallet", COLORS["pallet"], "storage", partial(eur_pallet))

    def _load_plan(self, name) -> PartPlan:
        color, build = LOADS[name]
        seed = [self.seed, list(LOADS).index(name)]
        return PartPlan(
            name, COLORS[color], "storage", partial(build, seed=tuple(seed)) if build else partial(crate_load)
        )


__all__ = ["Slot", "PartPlan", "MeshCache", "Plan", "LOADS", "LOAD_WEIGHTS", "seeded_cartons"]
