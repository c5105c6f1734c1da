"""What a scene knows beyond meshes and transforms: imported elements and map coordinates.

- :class:`ElementInfo`: an IFC/STEP element's name, IFC class and storey, one per instance
  (``Part.instance_info``); the instance id is the GlobalId or assembly path.
- the manifest's float64 ``origin`` (:func:`manifest_origin`): placements and viewpoints are
  relative to it (:func:`shifted`, :func:`viewpoint_in_world`), so a model at map coordinates
  keeps its millimetres.
- a part's ``instances_file`` (:func:`read_instances_file`), the JSON list an import writes
  instead of thousands of inline TOML tables, and :func:`matrices_in_bulk`, which checks such
  a list's matrices at once.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input_text

ELEMENT_KEYS = ("name", "ifc_class", "storey")  # what a BIM/CAD import knows about an element (instance keys)


@dataclass(frozen=True)
class ElementInfo:
    """What an IFC/STEP import knows about one instance (empty strings when nothing): the
    element's name, IFC class (``IfcColumn``) and storey."""

    name: str = ""
    ifc_class: str = ""
    storey: str = ""


def vector3(value, where: str) -> np.ndarray:
    """Three finite float64 numbers (a translation, an origin, an eye), else a MrcheckError."""
    try:
        v = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise MrcheckError(f"{where} must be three numbers") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise MrcheckError(f"{where} must be three finite numbers, got {value!r}")
    return v


def manifest_origin(data: dict, path: Path) -> np.ndarray:
    """The manifest's ``origin`` (3,) float64, zeros when it has none."""
    if "origin" not in data:
        return np.zeros(3)
    try:
        return vector3(data["origin"], "origin")
    except MrcheckError as exc:
        raise MrcheckError(f"{exc} (metres, the world position of the manifest's placements)", path) from None


def manifest_crs(data: dict, path: Path) -> str:
    crs = data.get("crs", "")
    if not isinstance(crs, str):
        raise MrcheckError(f'crs must be a string such as "EPSG:25832", got {crs!r}', path)
    return crs


def manifest_package_path(data: dict, path: Path) -> list[Path]:
    """The manifest's ``package_path`` folders (for URDF ``package://`` meshes), relative to it."""
    folders = data.get("package_path", [])
    if not isinstance(folders, list) or not all(isinstance(f, str) for f in folders):
        raise MrcheckError("package_path must be a list of folders (relative to the manifest)", path)
    return [path.parent / f for f in folders]


def shifted(transforms, origin: np.ndarray) -> list:
    """Placements relative to ``origin`` as world transforms (float64: exact to 1e-9 m at map
    coordinates)."""
    if not np.any(origin):
        return list(transforms)
    shift = np.eye(4)
    shift[:3, 3] = origin
    return [shift @ m for m in transforms]


def viewpoint_in_world(view: dict, origin: np.ndarray, path: Path) -> dict:
    """A viewpoint table with eye and target in world coordinates (the manifest's are relative
    to its origin)."""
    if not np.any(origin):
        return view
    try:
        return {
            **view,
            "eye": list(vector3(view["eye"], "eye") + origin),
            "target": list(vector3(view["target"], "target") + origin),
        }
    except MrcheckError as exc:
        raise MrcheckError(f"viewpoint {view['name']!r}: {exc}", path) from None


def read_instances_file(path: Path, table: dict, where: str) -> list:
    """The instance tables of a part's ``instances_file`` (JSON, relative to the manifest
    ``path``): an import's thousands of instances parse some 50 times faster as JSON than as TOML."""
    if "instances" in table:
        raise MrcheckError(f"{where}: give either instances or instances_file, not both", path)
    name = table["instances_file"]
    if not isinstance(name, str):
        raise MrcheckError(f"{where}: instances_file must be a file name", path)
    source = path.parent / name
    try:
        return json.loads(read_input_text(source, "instances file"))
    except ValueError as exc:
        raise MrcheckError(f"malformed instances file ({exc}; {where} of {path})", source) from None


def matrices_in_bulk(tables: list) -> np.ndarray | None:
    """(k, 4, 4) float64 of instance tables that each give only a ``matrix`` (and an id and the
    element keys), checked at once as ``transform_from_table`` checks one (finite, affine, not
    singular); None for any other list: the one-by-one check then names the bad instance."""
    if len(tables) < 2 or not all("matrix" in t and set(t) <= {"matrix", "id", *ELEMENT_KEYS} for t in tables):
        return None
    try:
        M = np.array([t["matrix"] for t in tables], dtype=np.float64)
    except (TypeError, ValueError):
        return None
    if M.shape != (len(tables), 4, 4) or not np.all(np.isfinite(M)) or not np.allclose(M[:, 3], (0, 0, 0, 1)):
        return None
    A = M[:, :3, :3]
    if not np.all(np.abs(np.linalg.det(A)) > 1e-12 * np.linalg.norm(A, axis=(1, 2)) ** 3):
        return None
    return M


def element_info(tables: list, where: str, path: Path) -> list:
    """The ElementInfo of every instance table (its ``name``, ``ifc_class``, ``storey``)."""
    found = []
    for i, t in enumerate(tables):
        values = {k: t.get(k, "") for k in ELEMENT_KEYS}
        bad = [k for k, v in values.items() if not isinstance(v, str)]
        if bad:
            raise MrcheckError(f"{where} instance {i}: {', '.join(bad)} must be text", path)
        found.append(ElementInfo(**values))
    return found


def part_element_fields(table: dict, where: str, path: Path) -> tuple[str, str]:
    """(ifc_class, storey) of a part table."""
    for key in ("ifc_class", "storey"):
        if not isinstance(table.get(key, ""), str):
            raise MrcheckError(f"{where}: {key} must be text", path)
    return table.get("ifc_class", ""), table.get("storey", "")


__all__ = [
    "vector3",
    "ElementInfo",
    "ELEMENT_KEYS",
    "manifest_origin",
    "manifest_crs",
    "manifest_package_path",
    "shifted",
    "viewpoint_in_world",
    "read_instances_file",
    "matrices_in_bulk",
    "element_info",
    "part_element_fields",
]
