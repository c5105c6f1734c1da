"""Viewpoints carried in an IFC file: a property set of the IfcProject.

IFC has no camera entity (BCF carries viewpoints beside the model), so a scene written as IFC
(``mrcheck scene generate --format ifc``) keeps its named viewpoints in the property set
:data:`VIEWPOINTS_PSET` of its IfcProject: one IfcPropertySingleValue per viewpoint, its Name
the viewpoint's name, its NominalValue an IfcText of JSON ``{"eye": [x, y, z], "target": [...],
"up": [...], "fov_y_deg": f, "width": w, "height": h}``, eye and target in the file's model
coordinates in metres (before any map conversion). The importer takes them through the same
placement as the elements, so ``--view aisle`` works on the imported scene.
"""

from __future__ import annotations

import json

import numpy as np

VIEWPOINTS_PSET = "Mrcheck_Viewpoints"
KEYS = ("eye", "target", "up", "fov_y_deg", "width", "height")


def viewpoint_text(view: dict) -> str:
    """The IfcText of one viewpoint (module docstring): the keys of :data:`KEYS` it has."""
    return json.dumps({k: _plain(view[k]) for k in KEYS if k in view}, separators=(",", ":"))


def _plain(value):
    if isinstance(value, (list, tuple, np.ndarray)):
        return [float(v) for v in value]
    return int(value) if isinstance(value, (int, np.integer)) else float(value)


def file_viewpoints(model, world: np.ndarray, scale: float = 1.0) -> tuple[list[dict], list[str]]:
    """(viewpoint tables in the scene's frame, notes on the ones that cannot be read).
    ``world`` maps model coordinates (metres) into the scene's frame; ``scale`` is the
    ``--units`` factor applied to the elements."""
    import ifcopenshell.util.element

    project = (model.by_type("IfcProject") or [None])[0]
    if project is None:
        return [], []
    texts = ifcopenshell.util.element.get_psets(project).get(VIEWPOINTS_PSET, {})
    views, notes = [], []
    for name, text in texts.items():
        if name == "id":
            continue
        try:
            views.append(_viewpoint(str(name), json.loads(str(text)), world, scale))
        except (TypeError, ValueError, KeyError) as exc:  # malformed JSON or numbers
            notes.append(f"viewpoint {name!r} in {VIEWPOINTS_PSET} is unreadable ({exc}); left out")
    return views, notes


def _viewpoint(name: str, data: dict, world: np.ndarray, scale: float) -> dict:
    def point(key):
        value = np.asarray(data[key], np.float64)
        if value.shape != (3,) or not np.isfinite(value).all():
            raise ValueError(f"{key} is not three finite numbers")
        return [float(v) for v in (world[:3, :3] @ value + world[:3, 3]) * scale]  # as the elements

    view = {"name": name, "eye": point("eye"), "target": point("target")}
    up = np.asarray(data.get("up", (0.0, 0.0, 1.0)), np.float64)
    view["up"] = [float(v) for v in world[:3, :3] @ up]
    for key, kind in (("fov_y_deg", float), ("width", int), ("height", int)):
        if key in data:
            view[key] = kind(data[key])
    return view


__all__ = ["VIEWPOINTS_PSET", "viewpoint_text", "file_viewpoints"]
