"""Revisions of real IFC files as a planning team's weekly exports differ, edited with
ifcopenshell.api: a wall moved, a door deleted, a column added (tests/test_regress_diff.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .ifc_house import owner_hooks


def _body(model):
    import ifcopenshell.util.representation

    return ifcopenshell.util.representation.get_context(model, "Model", "Body", "MODEL_VIEW")


def _box(model, size, name: str, ifc_class: str, at, storey=None):
    """A new element of ``ifc_class`` drawn as a box of ``size`` metres with its corner ``at``."""
    import ifcopenshell.api.geometry
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.util.unit

    s = 1.0 / ifcopenshell.util.unit.calculate_unit_scale(model)  # file units per metre
    element = ifcopenshell.api.root.create_entity(model, ifc_class=ifc_class, name=name)
    x, y, z = (v * s for v in size)
    points = [(0.0, 0.0), (x, 0.0), (x, y), (0.0, y), (0.0, 0.0)]
    profile = model.createIfcArbitraryClosedProfileDef(
        "AREA", None, model.createIfcPolyline([model.createIfcCartesianPoint(p) for p in points])
    )
    origin = model.createIfcAxis2Placement3D(model.createIfcCartesianPoint((0.0, 0.0, 0.0)), None, None)
    solid = model.createIfcExtrudedAreaSolid(profile, origin, model.createIfcDirection((0.0, 0.0, 1.0)), z)
    rep = model.createIfcShapeRepresentation(_body(model), "Body", "SweptSolid", [solid])
    ifcopenshell.api.geometry.assign_representation(model, product=element, representation=rep)
    matrix = np.eye(4)
    matrix[:3, 3] = at
    ifcopenshell.api.geometry.edit_object_placement(model, product=element, matrix=matrix)
    if storey is not None:
        ifcopenshell.api.spatial.assign_container(model, products=[element], relating_structure=storey)
    return element


def _edit(path: Path, out: Path, change) -> dict:
    """Open ``path``, apply ``change(model)`` (returns what it did), write ``out``."""
    import ifcopenshell

    model = ifcopenshell.open(str(path))
    restore = owner_hooks(model) if model.schema == "IFC2X3" else None
    try:
        done = change(model)
    finally:
        if restore is not None:
            restore()
    model.write(str(out))
    return done


def move(model, element, offset, angle_deg: float = 0.0) -> None:
    """Turn ``element`` about its placement's vertical axis, then shift it (metres), with its
    openings (what moving a wall in an authoring tool does)."""
    import ifcopenshell.api.geometry
    import ifcopenshell.util.placement
    import ifcopenshell.util.unit

    matrix = np.array(ifcopenshell.util.placement.get_local_placement(element.ObjectPlacement), float)
    matrix[:3, 3] *= ifcopenshell.util.unit.calculate_unit_scale(model)  # file units -> metres
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    matrix[:3, :3] = turn @ matrix[:3, :3]
    matrix[:3, 3] += np.asarray(offset, float)
    ifcopenshell.api.geometry.edit_object_placement(
        model, product=element, matrix=matrix, is_si=True, should_transform_children=True
    )


def house_with_door(path: Path, out: Path) -> str:
    """The house of ``path`` with a door (IfcDoor, 0.9 x 0.1 x 2.1 m) inside it; its GlobalId."""

    def add(model):
        storey = model.by_type("IfcBuildingStorey")[0]
        return _box(model, (0.9, 0.1, 2.1), "Door 1", "IfcDoor", (3.0, 2.5, 0.0), storey).GlobalId

    return _edit(path, out, add)


def edit_house(path: Path, out: Path) -> dict:
    """The house's next revision: wall 'Basic Wall 1' 0.5 m along +x, the door deleted, a
    column added; {kind: GlobalId} of the three changes."""

    def change(model):
        import ifcopenshell.api.root

        wall = next(w for w in model.by_type("IfcWallStandardCase") if w.Name == "Basic Wall 1")
        move(model, wall, (0.5, 0.0, 0.0))
        door = model.by_type("IfcDoor")[0]
        gone = door.GlobalId
        ifcopenshell.api.root.remove_product(model, product=door)
        storey = model.by_type("IfcBuildingStorey")[0]
        column = _box(model, (0.3, 0.3, 2.7), "Column 1", "IfcColumn", (2.0, 3.0, 0.0), storey)
        return {"moved": wall.GlobalId, "removed": gone, "added": column.GlobalId}

    return _edit(path, out, change)


def edit_wall_file(path: Path, out: Path, offset=(0.25, -0.4, 0.0), angle_deg: float = 15.0) -> dict:
    """buildingSMART's wall-standard-case.ifc with its wall turned and moved, and a column added."""

    def change(model):
        wall = model.by_type("IfcWall")[0]
        move(model, wall, offset, angle_deg)
        column = _box(model, (0.4, 0.4, 3.0), "Column 1", "IfcColumn", (2.0, 3.0, 0.0))
        return {"moved": wall.GlobalId, "added": column.GlobalId}

    return _edit(path, out, change)


def edit_hall(path: Path, out: Path) -> dict:
    """The generated hall's next revision (docs/regress-diff.md's speed figure): three elements
    moved 0.3, 1.3 and 2.3 m (turned 0, 10 and 20 degrees), two deleted, a column added;
    {kind: [GlobalId, ...]}."""

    def change(model):
        import ifcopenshell.api.root

        proxies, furniture = model.by_type("IfcBuildingElementProxy"), model.by_type("IfcFurnishingElement")
        moved = [proxies[3], proxies[40], furniture[5]]
        for i, element in enumerate(moved):
            move(model, element, (0.3 + i, 0.5, 0.0), 10.0 * i)
        gone = [proxies[100], furniture[20]]
        removed = [e.GlobalId for e in gone]
        for element in gone:
            ifcopenshell.api.root.remove_product(model, product=element)
        storey = model.by_type("IfcBuildingStorey")[0]
        column = _box(model, (0.4, 0.4, 8.0), "column-new", "IfcColumn", (10.0, 10.0, 0.0), storey)
        return {"moved": [e.GlobalId for e in moved], "removed": removed, "added": [column.GlobalId]}

    return _edit(path, out, change)


if __name__ == "__main__":  # python -m tests.ifc_revisions HALL.ifc OUT.ifc: the docs' hall revision
    import sys

    print(edit_hall(Path(sys.argv[1]), Path(sys.argv[2])))
