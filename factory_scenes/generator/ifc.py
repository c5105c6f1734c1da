"""IFC4 output of a generated scene (``mrcheck scene generate --format ifc``), through ifcopenshell.api.

Every part of the scene becomes one element type whose IfcRepresentationMap holds the part's
mesh as an IfcTriangulatedFaceSet (metres, relative to the mesh's own centre); every instance
becomes one element of that type, placed by an IfcLocalPlacement and drawn through an
IfcMappedItem of the type's map (``ifcopenshell.api.type.assign_type`` maps them). So the hall's
8,000 elements share 50 shapes, as the GLB scene's instances do, and an importer that keeps
mapped shapes as instances reads back the same parts.

Classes: columns are IfcColumn, walls IfcWall, the floor and roof deck IfcSlab, racks
IfcFurnishingElement, everything else IfcBuildingElementProxy; the generator's instance id
(``column-A03``) is the element's Name and Tag, its GlobalId is derived from the seed and that
id (the same arguments write the same bytes: the header's time stamp is fixed too). Colours are
IfcSurfaceStyle shading colours. All elements are contained in one storey, "Ground floor".
The scene's viewpoints (``aisle``, ...) go into the IfcProject's property set
:data:`~mrcheck.scene.importers.ifc_views.VIEWPOINTS_PSET`, which the importer reads back.
"""

from __future__ import annotations

import uuid
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError

TIME_STAMP = "2000-01-01T00:00:00"  # fixed: same arguments, same bytes
GUID_NAMESPACE = uuid.UUID("6f1c1f52-3a55-4f0e-9a8e-8f3c2b6a9d10")
STOREY = "Ground floor"
# part name prefix -> (element class, type class, predefined type); first match wins
CLASSES = (
    ("column", "IfcColumn", "IfcColumnType", "COLUMN"),
    ("wall", "IfcWall", "IfcWallType", "SOLIDWALL"),
    ("floor_pit", "IfcBuildingElementProxy", "IfcBuildingElementProxyType", "NOTDEFINED"),
    ("floor_marking", "IfcBuildingElementProxy", "IfcBuildingElementProxyType", "NOTDEFINED"),
    ("floor", "IfcSlab", "IfcSlabType", "FLOOR"),
    ("roof_deck", "IfcSlab", "IfcSlabType", "ROOF"),
    ("rack", "IfcFurnishingElement", "IfcFurnishingElementType", None),
)
DEFAULT_CLASS = ("IfcBuildingElementProxy", "IfcBuildingElementProxyType", "NOTDEFINED")
RIGID_TOLERANCE = 1e-9


def ifc_classes(part_name: str) -> tuple:
    """(element class, type class, predefined type) of a generated part."""
    for prefix, element, kind, predefined in CLASSES:
        if part_name.startswith(prefix):
            return element, kind, predefined
    return DEFAULT_CLASS


def guid(seed: int, instance_id: str) -> str:
    """A stable IFC GlobalId (22 characters) for a generated instance."""
    import ifcopenshell.guid

    return ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, f"{seed}:{instance_id}").hex)


def write_ifc(
    scene, path: Path, seed: int, description: str, progress=None, map_origin=None, crs: str = "EPSG:25832"
) -> Path:
    """Write ``scene`` (a loaded :class:`mrcheck.scene.model.Scene`, metres) as IFC4 to ``path``.

    ``map_origin`` (E, N, H metres) adds an IfcMapConversion to the projected CRS ``crs`` that
    puts the model's origin there (as a surveyed BIM model arrives). ``progress(done, total)``
    is called per part.
    """
    import ifcopenshell.api.context
    import ifcopenshell.api.project

    model = ifcopenshell.api.project.create_file(version="IFC4")
    model.header.file_name.time_stamp = TIME_STAMP
    model.header.file_description.description = (description[:250],)
    project = _entity(model, "IfcProject", scene.name, guid(seed, "project"))
    metre = model.createIfcSIUnit(None, "LENGTHUNIT", None, "METRE")  # by hand: the API orders units by a set
    project.UnitsInContext = model.createIfcUnitAssignment([metre])
    context = ifcopenshell.api.context.add_context(model, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        model, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=context
    )
    storey = _spatial(model, project, seed)
    if map_origin is not None:
        _georeference(model, map_origin, crs)
    _viewpoints(model, project, scene.viewpoints, seed)
    contained = []
    for index, part in enumerate(scene.parts):
        contained += _write_part(model, body, part, seed)
        if progress is not None:
            progress(index + 1, len(scene.parts))
    # relationships by hand, their lists in the scene's order (the API keeps them in sets, whose
    # order changes from run to run)
    model.createIfcRelContainedInSpatialStructure(guid(seed, "contained"), None, None, None, contained, storey)
    for relationship in model.by_type("IfcRelationship"):  # the API gives them random GlobalIds
        relationship.GlobalId = guid(seed, f"relationship#{relationship.id()}")
    model.write(str(path))
    return path


def _viewpoints(model, project, viewpoints: dict, seed: int) -> None:
    """The scene's viewpoints as the project's property set (IFC has no camera entity)."""
    from mrcheck.scene.importers.ifc_views import VIEWPOINTS_PSET, viewpoint_text

    if not viewpoints:
        return
    values = [
        model.createIfcPropertySingleValue(name, None, model.create_entity("IfcText", viewpoint_text(view)), None)
        for name, view in viewpoints.items()
    ]
    pset = model.createIfcPropertySet(guid(seed, "viewpoints"), None, VIEWPOINTS_PSET, None, values)
    model.createIfcRelDefinesByProperties(guid(seed, "viewpoints-of-project"), None, None, None, [project], pset)


def _georeference(model, origin, crs: str) -> None:
    import ifcopenshell.api.georeference

    ifcopenshell.api.georeference.add_georeferencing(model, name=crs)
    east, north, height = (float(v) for v in origin)
    ifcopenshell.api.georeference.edit_georeferencing(
        model,
        projected_crs={"Name": crs},
        coordinate_operation={
            "Eastings": east,
            "Northings": north,
            "OrthogonalHeight": height,
            "XAxisAbscissa": 1.0,
            "XAxisOrdinate": 0.0,
            "Scale": 1.0,
        },
    )


def _entity(model, ifc_class: str, name: str, global_id: str, **attributes):
    import ifcopenshell.api.root

    entity = ifcopenshell.api.root.create_entity(model, ifc_class=ifc_class, name=name, **attributes)
    entity.GlobalId = global_id
    return entity


def _spatial(model, project, seed: int):
    """Site -> building -> storey, each at the origin; returns the storey."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.geometry

    site = _entity(model, "IfcSite", "Site", guid(seed, "site"))
    building = _entity(model, "IfcBuilding", "Factory hall", guid(seed, "building"))
    storey = _entity(model, "IfcBuildingStorey", STOREY, guid(seed, "storey"))
    ifcopenshell.api.aggregate.assign_object(model, products=[site], relating_object=project)
    ifcopenshell.api.aggregate.assign_object(model, products=[building], relating_object=site)
    ifcopenshell.api.aggregate.assign_object(model, products=[storey], relating_object=building)
    for spatial in (site, building, storey):
        ifcopenshell.api.geometry.edit_object_placement(model, product=spatial, matrix=np.eye(4), is_si=True)
    return storey


def _write_part(model, body, part, seed: int) -> list:
    """The type of ``part`` with its mapped mesh, and one element per instance (returned)."""
    import ifcopenshell.api.geometry
    import ifcopenshell.api.style

    element_class, type_class, predefined = ifc_classes(part.name)
    extra = {"predefined_type": predefined} if predefined else {}
    kind = _entity(model, type_class, part.name, guid(seed, f"type:{part.name}"), **extra)
    representation = _mesh_representation(model, body, part)
    ifcopenshell.api.geometry.assign_representation(model, product=kind, representation=representation)
    style = ifcopenshell.api.style.add_style(model, name=part.name)
    ifcopenshell.api.style.add_surface_style(
        model,
        style=style,
        ifc_class="IfcSurfaceStyleShading",
        attributes={
            "SurfaceColour": {"Name": None, "Red": part.color[0], "Green": part.color[1], "Blue": part.color[2]}
        },
    )
    ifcopenshell.api.style.assign_representation_styles(model, shape_representation=representation, styles=[style])
    (mapping,) = kind.RepresentationMaps  # made by assign_representation
    identity = model.createIfcCartesianTransformationOperator3D(
        None, None, model.createIfcCartesianPoint((0.0, 0.0, 0.0)), 1.0, None
    )
    elements = []
    for instance_id, matrix in zip(part.instance_ids, part.transforms):
        item = model.createIfcMappedItem(mapping, identity)
        shape = model.createIfcProductDefinitionShape(
            None, None, [model.createIfcShapeRepresentation(body, "Body", "MappedRepresentation", [item])]
        )
        element = model.create_entity(
            element_class,
            GlobalId=guid(seed, instance_id),
            Name=instance_id,
            Tag=instance_id,
            ObjectPlacement=_placement(model, _rigid(matrix, instance_id)),
            Representation=shape,
            **({"PredefinedType": predefined} if predefined else {}),
        )
        elements.append(element)
    model.createIfcRelDefinesByType(guid(seed, f"typed:{part.name}"), None, None, None, elements, kind)
    return elements


def _placement(model, matrix: np.ndarray):
    """An IfcLocalPlacement (absolute) of a rigid (4, 4) matrix, metres."""
    location = model.createIfcCartesianPoint([float(v) for v in matrix[:3, 3]])
    axis = model.createIfcDirection([float(v) for v in matrix[:3, 2]])
    ref = model.createIfcDirection([float(v) for v in matrix[:3, 0]])
    return model.createIfcLocalPlacement(None, model.createIfcAxis2Placement3D(location, axis, ref))


def _mesh_representation(model, body, part):
    """An IfcShapeRepresentation of the part's triangles (IfcTriangulatedFaceSet, 1-based indices)."""
    vertices = np.asarray(part.vertices, np.float64)
    points = model.createIfcCartesianPointList3D(vertices.tolist())
    faces = (np.asarray(part.faces, np.int64) + 1).tolist()
    face_set = model.createIfcTriangulatedFaceSet(points, None, None, faces, None)
    return model.createIfcShapeRepresentation(body, "Body", "Tessellation", [face_set])


def _rigid(matrix: np.ndarray, instance_id: str) -> np.ndarray:
    """``matrix`` when it is a rotation and translation (an IfcLocalPlacement holds no scale)."""
    rotation = matrix[:3, :3]
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=RIGID_TOLERANCE) or np.linalg.det(rotation) < 0:
        raise MrcheckError(f"instance {instance_id!r} is scaled or mirrored: an IFC placement cannot hold that")
    return matrix


__all__ = ["write_ifc", "ifc_classes", "guid", "STOREY"]


# -- the command: generate the GLB scene, write it as IFC -----------------------------------------
IFC_OWN = ("scene.ifc", "README.md", "licences")
IFC_MARKER = "Generated by mrcheck scene generate"


def check_ifc_outdir(outdir: Path) -> None:
    """Refuse to replace a folder that holds other things than a generated IFC scene."""
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("output exists and is not a folder", outdir)
    if outdir.is_dir() and any(outdir.iterdir()):
        model = outdir / "scene.ifc"
        head = model.read_bytes()[:2000].decode("ascii", "replace") if model.is_file() else ""
        if IFC_MARKER not in head:
            raise MrcheckError(
                "output folder is not empty and holds no generated IFC scene; "
                "not replacing it (pick a new folder or empty it)",
                outdir,
            )


def generate_ifc(preset: str, outdir: Path, seed: int = 0, progress: bool = True, **options) -> Path:
    """``generate`` (same arguments) written as ``outdir/scene.ifc`` (IFC4) with a README and the
    robots' licences; returns the IFC file's path."""
    import os
    import shutil
    import tempfile

    from mrcheck.scene.manifest import notice_files, write_generated
    from mrcheck.scene.model import load_scene

    from . import generate

    outdir = Path(os.path.abspath(outdir))
    check_ifc_outdir(outdir)
    with tempfile.TemporaryDirectory(prefix="mrcheck-ifc-") as temp:
        manifest = generate(preset, Path(temp) / "scene", seed=seed, progress=progress, **options)
        scene = load_scene(manifest)
        readme = (manifest.parent / "README.md").read_text()
        header = manifest.read_text().splitlines()[0].lstrip("# ")

        def fill(work: Path):
            description = f"{header} --format ifc"
            write_ifc(scene, work / "scene.ifc", seed, description)
            urdfs = sorted({p.source for p in scene.parts if p.source.suffix.lower() == ".urdf"})
            for urdf in urdfs:
                for notice in notice_files(urdf):
                    target = work / "licences" / urdf.parent.name / notice.name
                    target.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(notice, target)
            (work / "README.md").write_text(_ifc_readme(readme, description))

        write_generated(outdir, fill, stale=IFC_OWN)
    return outdir / "scene.ifc"


def _ifc_readme(readme: str, description: str) -> str:
    return (
        f"{readme.rstrip()}\n\n## IFC\n\nThis folder holds the scene as IFC4 (`scene.ifc`, written by `{description}`):"
        " one element type per part with its mesh as a mapped IfcTriangulatedFaceSet, one element per instance "
        "(Name and Tag = the instance id above). The robots' licences are in `licences/`.\n"
    )
