"""What an importer returns: plain records of parts, instances and the model's coordinates.

An importer (IFC, STEP) turns a file into an :class:`ImportedModel`; :mod:`.writer` writes it
as a normal mrcheck scene (manifest + GLB meshes), and the scene model reads the fields back
(part and instance ``name``, ``ifc_class``, ``storey``; the scene's float64 ``origin``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# the import settings a cached scene depends on (threads do not change the result)
COORDINATES = ("model", "map")
DEFAULT_TOLERANCE_PX = 0.5  # STEP tessellation: chord error in pixels ...
DEFAULT_DISTANCE_M = 2.0  # ... of a 1024-pixel, 60-degree camera at this distance


@dataclass(frozen=True)
class ImportSettings:
    """How a CAD/BIM file becomes a scene.

    coordinates : "model" keeps the file's own coordinates; "map" places an IFC model at its
        map coordinates (IfcMapConversion, else its site placement).
    tolerance_px, distance_m : the STEP tessellation's chord error, stated as pixels of a
        1024-pixel-wide 60-degree camera looking from ``distance_m`` (as the LOD states it).
    threads : geometry threads (IFC); None means every core. Not part of the cache key.
    units : IFC: the length unit the file's numbers are in ("mm", "cm", "m", "in", "ft"),
        instead of the one it declares (metres when it declares none); None: as declared.
    """

    coordinates: str = "model"
    tolerance_px: float = DEFAULT_TOLERANCE_PX
    distance_m: float = DEFAULT_DISTANCE_M
    threads: int | None = None
    units: str | None = None

    def key(self) -> str:
        """The part of the cache key that changes the imported scene."""
        key = f"coordinates={self.coordinates};tolerance_px={self.tolerance_px!r};distance_m={self.distance_m!r}"
        return key + (f";units={self.units}" if self.units else "")

    def deflection_m(self) -> float:
        """The chord error in metres that ``tolerance_px`` pixels are at ``distance_m``: a
        1024-pixel-wide image of a 60-degree field of view has a pixel of
        2 d tan(30 deg) / 1024 metres at distance d."""
        return float(self.tolerance_px * 2.0 * self.distance_m * np.tan(np.radians(30.0)) / 1024.0)


_DEFAULTS: dict = {}


def set_default_settings(**values) -> None:
    """What :func:`default_settings` gives (the CLI's ``mrcheck --coordinates``), process-wide."""
    _DEFAULTS.clear()
    _DEFAULTS.update(values)


def default_settings() -> ImportSettings:
    """The settings an IFC/STEP file given directly as SCENE is imported with."""
    return ImportSettings(**_DEFAULTS)


@dataclass
class ImportedInstance:
    """One placed copy of a part: an IFC element (id = its GlobalId) or a STEP assembly
    occurrence (id = the assembly path)."""

    id: str
    matrix: np.ndarray  # (4, 4) float64 part -> world, world relative to the model's origin
    name: str = ""
    ifc_class: str = ""
    storey: str = ""


@dataclass
class ImportedPart:
    """One distinct shape: triangles in metres, drawn at every instance."""

    name: str
    vertices: np.ndarray  # (n, 3) float64 metres
    faces: np.ndarray  # (m, 3) int64
    color: tuple
    instances: list[ImportedInstance] = field(default_factory=list)
    ifc_class: str = ""
    storey: str = ""


@dataclass
class FailedElement:
    """An element whose geometry could not be built (a warning, the rest imports)."""

    id: str
    ifc_class: str
    reason: str = ""
    name: str = ""

    def label(self) -> str:
        """ "IfcWallStandardCase 'Basic Wall 0' 2ebDUHeC5BNfwjQtFf6prP": how lists name it."""
        return f"{self.ifc_class} {self.name!r} {self.id}" if self.name else f"{self.ifc_class} {self.id}"


@dataclass
class ImportedModel:
    """A CAD/BIM file as parts and instances.

    origin : (3,) float64 world position of the placements' frame: every instance matrix is
        relative to it (world = origin + matrix @ vertex), so the manifest holds small numbers
        and one exact float64 origin (map coordinates: 5e6 m kept to the millimetre).
    crs : the map's coordinate reference system (IfcProjectedCRS name, "EPSG:25832"), or "".
    """

    name: str
    source: Path
    kind: str  # "ifc" or "step"
    schema: str
    parts: list[ImportedPart]
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    crs: str = ""
    failed: list[FailedElement] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what the summary says besides counts
    viewpoints: list[dict] = field(default_factory=list)  # the file's own, as manifest tables

    @property
    def element_count(self) -> int:
        return sum(len(p.instances) for p in self.parts)

    @property
    def triangle_count(self) -> int:
        """Triangles as rendered (instances counted)."""
        return sum(len(p.faces) * len(p.instances) for p in self.parts)


@dataclass
class ImportResult:
    """What ``scene import`` (or a direct load through the cache) did."""

    manifest: Path
    model_name: str
    kind: str
    schema: str
    parts: int
    elements: int
    triangles: int
    failed: list[FailedElement]
    seconds: float
    cached: bool
    origin: tuple = (0.0, 0.0, 0.0)
    crs: str = ""
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """The line ``scene import`` prints: what was imported, from where, how long it took."""
        if self.cached:
            return f"{self.manifest}: from the import cache"
        origin = (
            ""
            if not any(self.origin)
            else f", origin {', '.join(f'{v:.3f}' for v in self.origin)} m" + (f" ({self.crs})" if self.crs else "")
        )
        what = "element" if self.kind == "ifc" else "instance"
        return (
            f"imported {self.model_name} ({self.schema.split()[0]}): {_count(self.elements, what)} in "
            f"{_count(self.parts, 'part')}, {self.triangles:,} triangles, {len(self.failed)} left out{origin}; "
            f"{self.seconds:.1f} s"
        )


def _count(n: int, noun: str) -> str:
    """ "1 part", "2 parts", "7,981 elements"."""
    return f"{n:,} {noun}" + ("" if n == 1 else "s")


_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def unique_part_names(parts: list[ImportedPart]) -> None:
    """Give every part a unique name that is safe as a file name (``meshes/NAME.glb``):
    unsafe characters as ``_``, at most 60 characters, repeats numbered ``NAME_2`` ..."""
    taken: dict[str, int] = {}
    for part in parts:
        base = _UNSAFE.sub("_", part.name).strip("_.")[:60] or "part"
        count = taken.get(base.lower(), 0)
        taken[base.lower()] = count + 1
        part.name = base if count == 0 else f"{base}_{count + 1}"


__all__ = [
    "unique_part_names",
    "set_default_settings",
    "default_settings",
    "ImportSettings",
    "ImportedInstance",
    "ImportedPart",
    "ImportedModel",
    "FailedElement",
    "ImportResult",
    "COORDINATES",
    "DEFAULT_TOLERANCE_PX",
    "DEFAULT_DISTANCE_M",
]
