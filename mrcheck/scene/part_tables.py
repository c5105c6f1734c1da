"""The values of a manifest's ``[[parts]]`` table, checked: placement (units, transforms), colour
and joints. Each check names the part (``where``) and the manifest (``path``) in its error."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.elements import matrices_in_bulk, vector3

UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254, "ft": 0.3048}  # metres per unit


def _rotation_xyz(degrees) -> np.ndarray:
    rx, ry, rz = np.radians(degrees)
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx  # about world x first, then y, then z


def transform_from_table(table: dict, where: str) -> np.ndarray:
    """(4, 4) float64 from ``translate`` / ``rotate_deg`` / ``scale`` or a full ``matrix``."""
    M = np.eye(4)
    try:
        if "matrix" in table:
            if any(k in table for k in ("translate", "rotate_deg", "scale")):
                raise MrcheckError(f"{where}: give either matrix or translate/rotate_deg/scale, not both")
            M = np.array(table["matrix"], dtype=np.float64)
            if M.shape != (4, 4):
                raise MrcheckError(f"{where}: matrix must be 4x4")
            if not np.all(np.isfinite(M)):
                raise MrcheckError(f"{where}: matrix has NaN or infinite values")
            A = M[:3, :3]
            if not np.allclose(M[3], (0, 0, 0, 1)):
                raise MrcheckError(f"{where}: matrix bottom row must be [0, 0, 0, 1] (an affine transform)")
            # a singular matrix flattens the part, and its normals (inverse transpose) would be NaN
            if not abs(np.linalg.det(A)) > 1e-12 * np.linalg.norm(A) ** 3:
                raise MrcheckError(f"{where}: matrix is singular")
        else:
            scale = float(table.get("scale", 1.0))
            if not math.isfinite(scale):
                raise MrcheckError(f"{where}: scale: {scale} is not a finite number")
            if not scale > 0:
                raise MrcheckError(f"{where}: scale must be positive, got {scale}")
            M[:3, :3] = _rotation_xyz(vector3(table.get("rotate_deg", (0, 0, 0)), f"{where} rotate_deg")) * scale
            M[:3, 3] = vector3(table.get("translate", (0, 0, 0)), f"{where} translate")
    except (TypeError, ValueError):
        raise MrcheckError(f"{where}: transform values must be numbers") from None
    if not np.all(np.isfinite(M)):
        raise MrcheckError(f"{where}: transform has NaN or infinite values")
    return M


def unit_scale(units, where) -> float:
    if units is None:
        return 1.0
    if not isinstance(units, str) or units not in UNITS:  # a TOML list is not hashable
        raise MrcheckError(f"unknown units {units!r} (use one of {', '.join(UNITS)})", where)
    return UNITS[units]


def part_transforms(table: dict, instances: list, where: str, path: Path) -> list:
    """Every instance's transform @ the part's (checked at once for an import's plain matrices)."""
    try:
        base = transform_from_table(table, where)
        bulk = matrices_in_bulk(instances)
        if bulk is not None:
            return list(bulk @ base)
        return [transform_from_table(t, f"{where} instance {i}") @ base for i, t in enumerate(instances)]
    except MrcheckError as exc:
        raise MrcheckError(str(exc), path) from None


def part_color(table: dict, where: str, path: Path):
    """The part's ``color`` as three floats in 0..1, or None when it has none."""
    color = table.get("color")
    if color is not None:
        try:
            color = np.asarray(color, dtype=np.float64)
        except (TypeError, ValueError):
            color = None  # reported just below, like a colour out of range
        if color is None or color.shape != (3,) or not np.all((color >= 0) & (color <= 1)):
            raise MrcheckError(f"{where}: color must be three numbers in 0..1, got {table['color']!r}", path)
    return color


def part_joints(table: dict, where: str, path: Path):
    """The part's ``joints`` table (None when it has none), each value a finite number."""
    joints = table.get("joints")
    if joints is not None and not isinstance(joints, dict):
        raise MrcheckError(f"{where}: joints must be a table of name = value", path)
    for joint, value in (joints or {}).items():
        # TOML's true would pass float() as 1 rad, and nan would pose the arm anyhow
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise MrcheckError(
                f"{where}: joint {joint!r} must be a finite number (radians, or metres for a "
                f"prismatic joint), got {value!r}",
                path,
            )
    return joints


__all__ = ["UNITS", "unit_scale", "transform_from_table", "part_transforms", "part_color", "part_joints"]
