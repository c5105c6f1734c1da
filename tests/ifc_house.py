"""A small IFC2X3 house as Revit exports one, built with ifcopenshell.api: walls
(IfcWallStandardCase) with IfcOpeningElement voids, furnishings whose shape is their type's
IfcRepresentationMap (IfcMappedItem), and a roof slab aggregated into an IfcRoof."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _placed(matrix_xyz) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = matrix_xyz
    return matrix


def build_house(path: Path, *, length_unit: str = "MILLIMETRE", schema: str = "IFC2X3", units: bool = True) -> dict:
    """Write the house to ``path``; {IFC class: count} of the physical elements in it.

    Lengths are written in ``length_unit`` (MILLIMETRE or METRE); without ``units`` the file
    has no IfcUnitAssignment at all (its numbers stay millimetres)."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.feature
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.type
    import ifcopenshell.api.unit

    s = 1000.0 if length_unit == "MILLIMETRE" else 1.0  # file units per metre
    a = 1.0 if units else s  # ifcopenshell.api takes metres and converts them to the declared unit
    f = ifcopenshell.api.project.create_file(version=schema)
    restore = owner_hooks(f) if schema == "IFC2X3" else None
    project = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="house")
    if units:
        raw = "MILLIMETERS" if length_unit == "MILLIMETRE" else "METERS"
        ifcopenshell.api.unit.assign_unit(f, length={"is_metric": True, "raw": raw})
    model = ifcopenshell.api.context.add_context(f, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
    )
    site = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="site")
    building = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuilding", name="house")
    storey = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Level 1")
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=project)
    ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
    ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=building)
    contained, counts = [], {}

    def count(element):
        counts[element.is_a()] = counts.get(element.is_a(), 0) + 1
        contained.append(element)

    # four walls of a 6 x 4 m house, 2.7 m high, each with a window opening
    for i, (x, y, angle, length) in enumerate([(0, 0, 0, 6), (6, 0, 90, 4), (6, 4, 180, 6), (0, 4, 270, 4)]):
        wall = ifcopenshell.api.root.create_entity(f, ifc_class="IfcWallStandardCase", name=f"Basic Wall {i}")
        rep = ifcopenshell.api.geometry.add_wall_representation(
            f, context=body, length=length * a, height=2.7 * a, thickness=0.2 * a
        )
        ifcopenshell.api.geometry.assign_representation(f, product=wall, representation=rep)
        c, sn = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        matrix = np.array([[c, -sn, 0, x * s], [sn, c, 0, y * s], [0, 0, 1, 0], [0, 0, 0, 1]], float)
        ifcopenshell.api.geometry.edit_object_placement(f, product=wall, matrix=matrix, is_si=False)
        opening = ifcopenshell.api.root.create_entity(f, ifc_class="IfcOpeningElement", name=f"window {i}")
        hole = ifcopenshell.api.geometry.add_wall_representation(
            f, context=body, length=1.0 * a, height=1.2 * a, thickness=0.6 * a
        )
        ifcopenshell.api.geometry.assign_representation(f, product=opening, representation=hole)
        # placed relative to its wall, as exporters write openings
        at = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((1.0 * s, -0.2 * s, 0.9 * s)), None, None)
        opening.ObjectPlacement = f.createIfcLocalPlacement(wall.ObjectPlacement, at)
        ifcopenshell.api.feature.add_feature(f, feature=opening, element=wall)
        count(wall)
    # a floor slab and the roof slab (the latter in an IfcRoof, as Revit writes roofs)
    for name, z, whole in (("Floor", -0.3, None), ("Roof", 2.7, "IfcRoof")):
        slab = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSlab", name=name, predefined_type=name.upper())
        points = [(0.0, 0.0), (6.0 * s, 0.0), (6.0 * s, 4.0 * s), (0.0, 4.0 * s)]
        rep = _slab_rep(f, body, points, 0.3 * s)
        if whole is not None:  # Revit's roofs: an extrusion clipped by the roof's pitch
            rep.Items = [f.createIfcBooleanClippingResult("DIFFERENCE", rep.Items[0], _pitch(f, 0.3 * s, 0.03))]
            rep.RepresentationType = "Clipping"
        ifcopenshell.api.geometry.assign_representation(f, product=slab, representation=rep)
        ifcopenshell.api.geometry.edit_object_placement(f, product=slab, matrix=_placed((0, 0, z * s)), is_si=False)
        if whole is None:
            count(slab)
            continue
        roof = ifcopenshell.api.root.create_entity(f, ifc_class=whole, name="Basic Roof")
        ifcopenshell.api.geometry.edit_object_placement(f, product=roof, matrix=np.eye(4), is_si=False)
        ifcopenshell.api.aggregate.assign_object(f, products=[slab], relating_object=roof)
        contained.append(roof)
        counts[slab.is_a()] = counts.get(slab.is_a(), 0) + 1
    # furnishings: one type, its shape a representation map, drawn at three places
    furniture = "IfcFurnishingElement" if schema == "IFC2X3" else "IfcFurniture"
    kind = ifcopenshell.api.root.create_entity(f, ifc_class="IfcFurnitureType", name="Table 1200x800")
    top = _box_rep(f, body, (1.2 * s, 0.8 * s, 0.75 * s))
    # and a side shelf clipped at the top: 0.2 m beyond the table's 1.2 m only if it is built
    shelf = _slab_rep(f, body, [(1.2 * s, 0.0), (1.4 * s, 0.0), (1.4 * s, 0.1 * s), (1.2 * s, 0.1 * s)], 0.7 * s)
    top.Items = [top.Items[0], f.createIfcBooleanClippingResult("DIFFERENCE", shelf.Items[0], _pitch(f, 0.5 * s))]
    ifcopenshell.api.geometry.assign_representation(f, product=kind, representation=top)
    for i in range(3):
        table = ifcopenshell.api.root.create_entity(f, ifc_class=furniture, name=f"Table {i}")
        ifcopenshell.api.geometry.edit_object_placement(
            f, product=table, matrix=_placed(((1 + 1.5 * i) * s, 1.5 * s, 0)), is_si=False
        )
        ifcopenshell.api.type.assign_type(f, related_objects=[table], relating_type=kind)
        count(table)
    ifcopenshell.api.spatial.assign_container(f, products=contained, relating_structure=storey)
    f.write(str(path))
    if restore is not None:
        restore()
    return counts


def _slab_rep(f, body, points, depth):
    """An extruded area solid of a closed polyline profile (the slab's outline)."""
    poly = f.createIfcPolyline([f.createIfcCartesianPoint(p) for p in points + points[:1]])
    profile = f.createIfcArbitraryClosedProfileDef("AREA", None, poly)
    origin = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, 0.0)), None, None)
    solid = f.createIfcExtrudedAreaSolid(profile, origin, f.createIfcDirection((0.0, 0.0, 1.0)), depth)
    return f.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid])


def _pitch(f, height, slope=0.3):
    """The half space above a plane through (0, 0, height) that falls by ``slope`` along y."""
    location = f.createIfcAxis2Placement3D(
        f.createIfcCartesianPoint((0.0, 0.0, float(height))), f.createIfcDirection((0.0, slope, 1.0)), None
    )
    return f.createIfcHalfSpaceSolid(f.createIfcPlane(location), False)


def _box_rep(f, body, size):
    x, y, z = size
    return _slab_rep(f, body, [(0.0, 0.0), (x, 0.0), (x, y), (0.0, y)], z)


def clip_away_first_wall(path: Path) -> str:
    """Clip the first wall by a half space that holds all of it (it builds empty with every
    kernel); the wall's GlobalId."""
    import ifcopenshell

    model = ifcopenshell.open(str(path))
    wall = model.by_type("IfcWallStandardCase")[0]
    representation = wall.Representation.Representations[0]
    above = _pitch(model, 1e7)
    above.AgreementFlag = True
    representation.Items = [model.createIfcBooleanClippingResult("DIFFERENCE", representation.Items[0], above)]
    model.write(str(path))
    return str(wall.GlobalId)


def owner_hooks(f):
    """IFC2X3 requires an owner history on every rooted entity: a user and an application
    (ifcopenshell.api asks module-level hooks for them); what puts the hooks back."""
    import ifcopenshell.api.owner.settings

    hooks = ifcopenshell.api.owner.settings
    saved = (hooks.get_user, hooks.get_application)

    person = f.createIfcPerson(None, "Tester", None)
    organisation = f.createIfcOrganization(None, "mrcheck", None)
    user = f.createIfcPersonAndOrganization(person, organisation)
    application = f.createIfcApplication(organisation, "1", "mrcheck tests", "mrcheck")
    hooks.get_user = lambda file: user
    hooks.get_application = lambda file: application

    def restore():
        hooks.get_user, hooks.get_application = saved

    return restore
