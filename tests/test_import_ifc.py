"""IFC import on buildingSMART's IFC4 specification examples (tests/data/cad/ifc, CC BY 4.0) and
on small files made here: units, ids, classes, storeys, colours, failures, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.importers import ImportSettings, read_model

DATA = Path(__file__).parent / "data" / "cad" / "ifc"


def _extent(model) -> np.ndarray:
    points = []
    for part in model.parts:
        for instance in part.instances:
            points.append(part.vertices @ instance.matrix[:3, :3].T + instance.matrix[:3, 3])
    points = np.concatenate(points)
    return np.ptp(points, axis=0)


@pytest.mark.parametrize(
    "name, extent",
    [
        ("wall-standard-case.ifc", (5.0, 0.27, 2.0)),  # mm file: 5000 x 270 x 2000
        ("beam-extruded-solid.ifc", (0.22, 10.0, 0.6)),  # metre file: IPE600, 10 m along y
        ("tessellation-with-individual-colors.ifc", (1.0, 1.0, 2.0)),  # a vertex at (1000, 1, 2000) mm
        ("bath-csg-solid.ifc", (2.0, 0.8, 0.8)),  # CSG: block minus an extrusion
    ],
)
def test_sample_files_land_in_metres(name, extent):
    model = read_model(DATA / name, ImportSettings(threads=1))
    np.testing.assert_allclose(_extent(model), extent, atol=2e-3)
    assert model.schema == "IFC4" and not model.failed


def test_every_instance_is_its_element_with_globalid_class_and_type_name():
    model = read_model(DATA / "wall-standard-case.ifc")
    (part,) = model.parts
    (instance,) = part.instances
    assert instance.id == "0czCsOQ5z4dg8QGBRFInu2"  # the element's GlobalId
    assert instance.ifc_class == part.ifc_class == "IfcWallStandardCase"
    assert part.name == "Double_Brick_-_270"  # its type's name, safe as a file name


def test_mapped_type_shape_is_one_part():
    # the bath is drawn through its type's IfcRepresentationMap (IfcMappedItem)
    model = read_model(DATA / "bath-csg-solid.ifc")
    assert len(model.parts) == 1 and model.parts[0].instances[0].ifc_class == "IfcSanitaryTerminal"


def test_element_without_buildable_geometry_is_named_in_the_error():
    with pytest.raises(MrcheckError, match=r"IfcReinforcingBar 381QpY9RP89gKaSFbzIfbP"):
        read_model(DATA / "reinforcing-stirrup.ifc")


def _two_element_model(tmp_path, bad_second: bool) -> Path:
    """A wall that builds and, with ``bad_second``, a proxy whose extrusion has no profile area."""
    import ifcopenshell.api.aggregate
    import ifcopenshell.api.context
    import ifcopenshell.api.geometry
    import ifcopenshell.api.project
    import ifcopenshell.api.root
    import ifcopenshell.api.spatial
    import ifcopenshell.api.unit

    f = ifcopenshell.api.project.create_file(version="IFC4")
    project = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="two")
    ifcopenshell.api.unit.assign_unit(f, length={"is_metric": True, "raw": "METERS"})
    model = ifcopenshell.api.context.add_context(f, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model
    )
    site = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="site")
    storey = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Level 2")
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=project)
    ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=site)
    wall = ifcopenshell.api.root.create_entity(f, ifc_class="IfcWall", name="W1")
    rep = ifcopenshell.api.geometry.add_wall_representation(f, context=body, length=4.0, height=3.0, thickness=0.2)
    ifcopenshell.api.geometry.assign_representation(f, product=wall, representation=rep)
    ifcopenshell.api.geometry.edit_object_placement(f, product=wall, matrix=np.eye(4))
    products = [wall]
    if bad_second:
        proxy = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuildingElementProxy", name="broken")
        points = f.createIfcCartesianPointList3D([[0.0, 0.0, 0.0]])
        bad = f.createIfcTriangulatedFaceSet(points, None, None, [[1, 7, 9]], None)  # indices past the points
        shape = f.createIfcShapeRepresentation(body, "Body", "Tessellation", [bad])
        ifcopenshell.api.geometry.assign_representation(f, product=proxy, representation=shape)
        ifcopenshell.api.geometry.edit_object_placement(f, product=proxy, matrix=np.eye(4))
        products.append(proxy)
    ifcopenshell.api.spatial.assign_container(f, products=products, relating_structure=storey)
    path = tmp_path / "two.ifc"
    f.write(str(path))
    return path


def test_storey_and_a_failed_element_is_counted_the_rest_imports(tmp_path):
    model = read_model(_two_element_model(tmp_path, bad_second=True))
    assert [i.storey for p in model.parts for i in p.instances] == ["Level 2"]
    assert [(f.ifc_class, f.id) for f in model.failed] == [
        ("IfcBuildingElementProxy", next(e.id for e in model.failed))
    ]
    assert model.element_count == 1


def test_one_and_two_threads_give_the_same_model(tmp_path):
    path = _two_element_model(tmp_path, bad_second=False)
    one, two = (read_model(path, ImportSettings(threads=n)) for n in (1, 2))
    assert [(p.name, len(p.faces)) for p in one.parts] == [(p.name, len(p.faces)) for p in two.parts]
    np.testing.assert_array_equal(one.parts[0].instances[0].matrix, two.parts[0].instances[0].matrix)


# -- bad input: one line naming the file, nothing imported -------------------------------------
def _with(tmp_path, name, text) -> Path:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


def test_truncated_ifc(tmp_path):
    data = (DATA / "basin-faceted-brep.ifc").read_bytes()
    path = _with(tmp_path, "cut.ifc", data[: len(data) // 2])
    with pytest.raises(MrcheckError, match=r"cut\.ifc: truncated IFC4 file"):
        read_model(path)


def test_syntactically_broken_ifc(tmp_path):
    text = (DATA / "wall-standard-case.ifc").read_text().replace("IFCWALLSTANDARDCASE(", "IFCWALLSTANDARDCASE((((", 1)
    path = _with(tmp_path, "broken.ifc", text)
    with pytest.raises(MrcheckError, match=r"broken\.ifc: cannot parse IFC: line \d+: .* \(\d+ errors in all\)"):
        read_model(path)


def test_unknown_ifc_schema(tmp_path):
    text = (DATA / "wall-standard-case.ifc").read_text().replace("FILE_SCHEMA (('IFC4'))", "FILE_SCHEMA (('IFC9'))")
    with pytest.raises(MrcheckError, match=r"unknown IFC schema 'IFC9'"):
        read_model(_with(tmp_path, "future.ifc", text))


def test_model_without_body_representation(tmp_path):
    import ifcopenshell.api.project
    import ifcopenshell.api.root

    f = ifcopenshell.api.project.create_file(version="IFC4")
    ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="empty")
    ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="site")
    path = tmp_path / "empty.ifc"
    f.write(str(path))
    with pytest.raises(MrcheckError, match=r"empty\.ifc: no element has a body representation"):
        read_model(path)


@pytest.mark.parametrize(
    "name, source, message",
    [
        ("part.ifc", "../step/red_cube_blue_cylinder.step", r"STEP AP214 CAD file .* not IFC: rename it to \.step"),
        ("model.step", "wall-standard-case.ifc", r"IFC model \(IFC4\), not a STEP part: rename it to \.ifc"),
    ],
)
def test_wrong_extension_for_the_content(tmp_path, name, source, message):
    path = _with(tmp_path, name, (DATA / source).read_bytes())
    with pytest.raises(MrcheckError, match=message):
        read_model(path)


@pytest.mark.parametrize(
    "content, message",
    [
        (b"glTF\x02\x00\x00\x00", "GLB mesh"),
        (b"PK\x03\x04rest", "ZIP archive"),
        (b"<?xml version='1.0'?><ifcXML/>", "XML"),
        (b"", "model file is empty"),
    ],
)
def test_not_a_step_physical_file(tmp_path, content, message):
    with pytest.raises(MrcheckError, match=message):
        read_model(_with(tmp_path, "model.ifc", content))


def test_map_conversion_rotation_and_the_project_unit(tmp_path):
    """IfcMapConversion with a 90-degree rotation in a millimetre project without a MapUnit: the
    offsets are in the project's unit (mm), rotation about z, the origin kept in float64."""
    import ifcopenshell
    import ifcopenshell.api.georeference

    model = ifcopenshell.open(str(DATA / "wall-standard-case.ifc"))
    ifcopenshell.api.georeference.add_georeferencing(model, name="EPSG:25832")
    ifcopenshell.api.georeference.edit_georeferencing(
        model,
        projected_crs={"Name": "EPSG:25832"},
        coordinate_operation={
            "Eastings": 458658780.0,
            "Northings": 5438232790.0,
            "OrthogonalHeight": 113700.0,
            "XAxisAbscissa": 0.0,
            "XAxisOrdinate": 1.0,
            "Scale": 1.0,
        },
    )
    path = tmp_path / "wall_map.ifc"
    model.write(str(path))
    at_map = read_model(path, ImportSettings(coordinates="map"))
    assert tuple(at_map.origin) == (458658.78, 5438232.79, 113.7) and at_map.crs == "EPSG:25832"
    (part,) = at_map.parts
    matrix = part.instances[0].matrix
    world = part.vertices @ matrix[:3, :3].T + matrix[:3, 3]  # relative to the origin
    # the wall runs 5 m along the model's x: rotated by 90 degrees it runs along the map's north
    np.testing.assert_allclose(np.ptp(world, axis=0), [0.27, 5.0, 2.0], atol=1e-6)
    np.testing.assert_allclose(world.min(axis=0), [-0.27, 0.0, 0.0], atol=1e-6)
    at_own = read_model(path)
    assert not np.any(at_own.origin) and any("--coordinates map" in n for n in at_own.notes)
