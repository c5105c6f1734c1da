"""IFC files as real exporters write them, read whole: walls with openings, furnishings drawn
through their type's IfcMappedItem, a roof slab clipped by its pitch (tests/ifc_house.py builds
them with ifcopenshell, as Revit's IFC2X3 export has them). Every element with a body arrives,
or is listed as left out with its class, name and reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.importers import ImportSettings, read_model
from mrcheck.scene.importers.cache import failed_summary

from .ifc_house import build_house, clip_away_first_wall

SHIPPED = Path(__file__).parent / "data" / "cad" / "ifc"


@pytest.fixture(scope="module")
def house(tmp_path_factory) -> tuple[Path, dict]:
    path = tmp_path_factory.mktemp("house") / "house.ifc"
    return path, build_house(path)


def _classes(model) -> dict:
    counts: dict = {}
    for part in model.parts:
        for instance in part.instances:
            counts[instance.ifc_class] = counts.get(instance.ifc_class, 0) + 1
    return counts


def test_every_element_of_the_house_arrives(house):
    path, written = house
    model = read_model(path, ImportSettings(threads=1))
    assert not model.failed
    assert _classes(model) == written == {"IfcWallStandardCase": 4, "IfcSlab": 2, "IfcFurnishingElement": 3}


def test_walls_keep_their_openings(house):
    model = read_model(house[0], ImportSettings(threads=1))
    walls = [p for p in model.parts if p.ifc_class == "IfcWallStandardCase"]
    assert len(walls) == 4
    for wall in walls:  # a box has 12 triangles; the window hole adds its reveals
        assert len(wall.faces) > 12
        assert np.ptp(wall.vertices, axis=0).max() >= 4.0 - 1e-6


def test_a_mapped_shape_with_a_boolean_item_is_built_whole(house):
    # the table's type map holds a box and a clipped shelf that reaches 1.4 m: a kernel that
    # skips Booleans leaves the shelf out and the table 1.2 m long
    model = read_model(house[0], ImportSettings(threads=1))
    (table,) = [p for p in model.parts if p.ifc_class == "IfcFurnishingElement"]
    assert len(table.instances) == 3
    assert np.ptp(table.vertices, axis=0)[0] == pytest.approx(1.4, abs=1e-6)


def test_the_clipped_roof_slab_arrives(house):
    model = read_model(house[0], ImportSettings(threads=1))
    roofs = [i for p in model.parts for i in p.instances if i.name == "Roof"]
    assert len(roofs) == 1 and roofs[0].ifc_class == "IfcSlab"


def test_an_element_that_builds_empty_is_listed_with_class_name_and_reason(tmp_path):
    """A wall clipped away whole: no triangles with any kernel, so it is left out,
    and the list says which wall and why (not "0 left out")."""
    path = tmp_path / "house.ifc"
    build_house(path)
    wall = clip_away_first_wall(path)
    imported = read_model(path, ImportSettings(threads=1))
    assert [(f.ifc_class, f.name, f.id) for f in imported.failed] == [("IfcWallStandardCase", "Basic Wall 0", wall)]
    assert "empty" in imported.failed[0].reason
    line = failed_summary(imported.failed)  # what the import warns
    assert line.startswith("1 element(s) without geometry left out: IfcWallStandardCase 'Basic Wall 0' ")
    assert "(its shape is empty" in line
    assert _classes(imported)["IfcWallStandardCase"] == 3


@pytest.mark.parametrize("name", sorted(p.name for p in SHIPPED.glob("*.ifc") if "stirrup" not in p.name))
def test_shipped_ifc_files_still_import_without_losses(name):
    model = read_model(SHIPPED / name, ImportSettings(threads=1))
    assert model.parts and not model.failed


@pytest.mark.parametrize("scale", [0.0, -1.0])
def test_map_conversion_with_scale_zero_is_refused(tmp_path, scale):
    """A map conversion of scale 0 would put every element at the map origin (a zero matrix)."""
    import ifcopenshell
    import ifcopenshell.api.georeference

    model = ifcopenshell.open(str(SHIPPED / "wall-standard-case.ifc"))
    ifcopenshell.api.georeference.add_georeferencing(model, name="EPSG:25832")
    ifcopenshell.api.georeference.edit_georeferencing(
        model,
        projected_crs={"Name": "EPSG:25832"},
        coordinate_operation={"Eastings": 458658780.0, "Northings": 5438232790.0, "Scale": scale},
    )
    path = tmp_path / "flat_map.ifc"
    model.write(str(path))
    with pytest.raises(MrcheckError, match=r"flat_map\.ifc.*IfcMapConversion.*Scale") as caught:
        read_model(path, ImportSettings(coordinates="map"))
    assert "\n" not in str(caught.value)
    own = read_model(path)  # its own coordinates do not use the conversion: a note says what is wrong
    assert own.parts and any(f"Scale {scale!r}" in n and "--coordinates map refuses it" in n for n in own.notes)
