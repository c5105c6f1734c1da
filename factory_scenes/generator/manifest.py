"""Scene manifests (``scene.toml``, format 1, see ``mrcheck/scene.py``) as the generators write them.

A :class:`Part` is one ``[[parts]]`` entry: a generated mesh (written as ``meshes/NAME.glb``)
or an external file such as a robot's URDF, with its colour, unit and placements. The mesh of
a :class:`Part` is in the part's declared ``units``; placements (``translate``, instances) are
always metres, as the manifest format defines.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

import numpy as np
import trimesh

from mrcheck.scene.part_tables import UNITS


@dataclass
class Part:
    """One ``[[parts]]`` entry: either a generated mesh or an external file (a URDF)."""

    name: str
    color: tuple
    mesh: trimesh.Trimesh | None = None  # generated -> meshes/<name>.glb, in `units`
    path: str | None = None  # external file, relative to the manifest
    units: str | None = "m"  # None: the manifest leaves the unit out
    translate: tuple | None = None
    rotate_deg: tuple | None = None
    joints: dict | None = None
    instances: list = field(default_factory=list)
    triangles: int = 0  # of an external file (a generated mesh counts itself)

    @property
    def mesh_path(self) -> str:
        return self.path if self.path else f"meshes/{self.name}.glb"

    @property
    def copies(self) -> int:
        """How many times the mesh is drawn."""
        return max(len(self.instances), 1)

    @property
    def mesh_triangles(self) -> int:
        return len(self.mesh.faces) if self.mesh is not None else self.triangles

    @property
    def drawn_triangles(self) -> int:
        """Triangles as rendered: the mesh's times its copies."""
        return self.mesh_triangles * self.copies


def place(x, y, z=0.0, yaw_deg=0.0, id: str | None = None) -> dict:
    """One instance transform (metres, degrees): a yaw about the part origin, then a translation."""
    inst = {"id": id} if id is not None else {}
    inst["translate"] = [x, y, z]
    if yaw_deg:
        inst["rotate_deg"] = [0.0, 0.0, yaw_deg]
    return inst


def with_units(part: Part, units: str) -> Part:
    """``part`` with its generated mesh rescaled from metres to ``units`` (and declaring them).

    The vertex coordinates really are in that unit afterwards, as a CAD export in mm or inches
    would be; placements stay in metres.
    """
    if part.mesh is None or part.units != "m":
        raise ValueError(f"part {part.name!r}: only generated meshes in metres can be converted")
    mesh = part.mesh.copy()
    mesh.apply_scale(1.0 / UNITS[units])
    return replace(part, mesh=mesh, units=units)


def toml_value(value) -> str:
    """TOML literal for the few value types the manifest uses."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(round(float(value), 6) + 0.0)  # + 0.0 turns -0.0 into 0.0
    if isinstance(value, str):
        return json.dumps(value)  # ASCII JSON strings are TOML strings
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def manifest_text(parts: list[Part], name: str, description: str, viewpoints: list[dict], header: str) -> str:
    """scene.toml in the manifest format 1 (keys in the documented order).

    ``header`` is the first line, a comment naming what wrote the file (so that nobody edits it
    by hand); a part whose ``units`` is None gets no ``units`` key.
    """
    lines = [
        header,
        "format = 1",
        f"name = {toml_value(name)}",
        f"description = {toml_value(description)}",
    ]
    for part in parts:
        lines += ["", "[[parts]]", f"name = {toml_value(part.name)}", f"mesh = {toml_value(part.mesh_path)}"]
        if part.units is not None:
            lines.append(f"units = {toml_value(part.units)}")
        lines.append(f"color = {toml_value(list(part.color))}")
        for key in ("translate", "rotate_deg", "joints"):
            value = getattr(part, key)
            if value is not None:
                lines.append(f"{key} = {toml_value(value)}")
        if part.instances:
            lines.append("instances = [")
            lines += [f"    {toml_value(inst)}," for inst in part.instances]
            lines.append("]")
    for view in viewpoints:
        lines += ["", "[[viewpoints]]"] + [f"{k} = {toml_value(v)}" for k, v in view.items()]
    return "\n".join(lines) + "\n"


__all__ = ["Part", "place", "with_units", "toml_value", "manifest_text"]
