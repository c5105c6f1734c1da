"""IFC files as real exporters write them, read whole: walls with openings, furnishings drawn
through their type's IfcMappedItem, a roof slab clipped by its pitch (tests/ifc_house.py builds
them with ifcopenshell, as Revit's IFC2X3 export has them). Every element with a body arrives,
or is listed as left out with its class, name and reason."""

from __future__ import annotations

import os
import shutil
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


# -- length units ---------------------------------------------------------------------------
def _wall_lengths(model) -> list[float]:
    return sorted(round(float(np.ptp(p.vertices, axis=0).max()), 6) for p in model.parts if "Wall" in p.name)


def test_millimetres_without_units_warn_and_name_the_option(tmp_path):
    path = tmp_path / "no_units.ifc"
    build_house(path, units=False, schema="IFC4")  # the numbers are millimetres, the file declares no unit
    as_read = read_model(path, ImportSettings(threads=1))
    assert _wall_lengths(as_read) == [4000.0, 4000.0, 6000.0, 6000.0]  # what IfcOpenShell makes of it
    (note,) = [n for n in as_read.notes if "implausibly large" in n]
    assert "no length unit declared" in note and "--units mm" in note
    fixed = read_model(path, ImportSettings(threads=1, units="mm"))
    assert _wall_lengths(fixed) == [4.0, 4.0, 6.0, 6.0]
    assert not [n for n in fixed.notes if "implausibly" in n]
    np.testing.assert_allclose(  # placements too: the tables stand 1.5 m apart
        sorted(i.matrix[0, 3] for p in fixed.parts for i in p.instances if i.name.startswith("Table")),
        [1.0, 2.5, 4.0],
        atol=1e-9,
    )


@pytest.mark.parametrize("unit", ["MILLIMETRE", "METRE"])
def test_declared_units_read_without_a_warning(tmp_path, unit):
    path = tmp_path / "house.ifc"
    build_house(path, length_unit=unit)
    model = read_model(path, ImportSettings(threads=1))
    assert _wall_lengths(model) == [4.0, 4.0, 6.0, 6.0]
    assert not [n for n in model.notes if "implausibly" in n]


def test_units_that_make_sizes_implausible_warn_too(tmp_path):
    path = tmp_path / "house.ifc"
    build_house(path, length_unit="MILLIMETRE")
    wrong = read_model(path, ImportSettings(threads=1, units="m"))  # millimetre numbers read as metres
    assert _wall_lengths(wrong) == [4000.0, 4000.0, 6000.0, 6000.0]
    assert any("implausibly large" in n and "read as m (--units)" in n and "--units mm" in n for n in wrong.notes)
    metres = tmp_path / "metres.ifc"
    build_house(metres, length_unit="METRE", units=False, schema="IFC4")  # no unit, metre numbers: plausible
    assert not [n for n in read_model(metres, ImportSettings(threads=1)).notes if "implausibly" in n]


def test_ifc2x3_project_without_units_is_one_line(tmp_path):
    """IFC2X3 requires the project's units; IfcOpenShell's iterator refuses a file without them."""
    path = tmp_path / "no_units_2x3.ifc"
    build_house(path, units=False)
    with pytest.raises(MrcheckError, match=r"no_units_2x3\.ifc: .*UnitsInContext") as caught:
        read_model(path, ImportSettings(threads=1))
    assert "\n" not in str(caught.value)


def test_units_on_a_step_file_is_refused():
    step = Path(__file__).parent / "data" / "cad" / "step" / "red_cube_blue_cylinder.step"
    with pytest.raises(MrcheckError, match=r"red_cube_blue_cylinder\.step: --units applies to an IFC file"):
        read_model(step, ImportSettings(units="mm"))


def test_scene_import_warns_and_units_fixes_it(tmp_path, capsys):
    from mrcheck.cli import main

    path = tmp_path / "no_units.ifc"
    build_house(path, units=False, schema="IFC4")
    assert main(["scene", "import", str(path), "-o", str(tmp_path / "as_read")]) == 0
    err = capsys.readouterr().err
    assert "9 elements in" in err and "0 left out" in err
    (warning,) = [line for line in err.splitlines() if "implausibly large" in line]
    assert warning.startswith("warning: ") and "no_units.ifc" in warning and "--units mm" in warning
    assert main(["scene", "import", str(path), "--units", "mm", "-o", str(tmp_path / "fixed")]) == 0
    assert "implausibly" not in capsys.readouterr().err


def test_scene_import_counts_what_it_left_out(tmp_path, capsys):
    from mrcheck.cli import main

    path = tmp_path / "house.ifc"
    build_house(path)
    wall = clip_away_first_wall(path)
    assert (
        main(["scene", "import", str(path), "-o", str(tmp_path / "out")]) == 0
    )  # the rest imports: a warning, not a failure
    err = capsys.readouterr().err
    assert "8 elements in" in err and "1 left out" in err
    assert f"IfcWallStandardCase 'Basic Wall 0' {wall} (its shape is empty" in err
    readme = (tmp_path / "out" / "README.md").read_text()
    assert f"IfcWallStandardCase 'Basic Wall 0' `{wall}`" in readme


# -- file names that are not UTF-8 ------------------------------------------------------------
NON_UTF8 = os.fsdecode(b"Halle_S\xfcd_")  # as tests/test_file_names.py: byte 0xFC, surrogate-escaped


def _renamed(tmp_path, source: Path) -> Path:
    target = tmp_path / f"{NON_UTF8}{source.name}"
    try:
        shutil.copyfile(source, target)
    except (OSError, UnicodeEncodeError):
        pytest.skip("this file system refuses names that are not valid UTF-8")
    return target


@pytest.mark.parametrize(
    "source", [SHIPPED / "wall-standard-case.ifc", SHIPPED.parent / "step" / "red_cube_blue_cylinder.step"]
)
def test_models_with_non_utf8_names_import(tmp_path, source):
    model = read_model(_renamed(tmp_path, source))
    assert model.parts and not model.failed


def test_scans_with_non_utf8_names_are_read(tmp_path):
    from mrcheck.scene.scans import read_scan

    scans = Path(__file__).parent / "data" / "scans" / "formats"
    assert len(read_scan(_renamed(tmp_path, scans / "bunnyInt32.e57"))) == 30571
    assert len(read_scan(_renamed(tmp_path, scans / "simple.laz"))) == 1065


def test_a_broken_ifc_with_a_non_utf8_name_says_where(tmp_path):
    path = _renamed(tmp_path, SHIPPED / "wall-standard-case.ifc")
    path.write_bytes(path.read_bytes().replace(b"IFCWALLSTANDARDCASE(", b"IFCWALLSTANDARDCASE(((", 1))
    with pytest.raises(MrcheckError, match=r"Halle_S\\xfcd_wall-standard-case\.ifc: cannot parse IFC: line \d+"):
        read_model(path)


def test_scene_import_of_a_non_utf8_name(tmp_path, capfdbinary):
    from mrcheck.cli import main

    path = _renamed(tmp_path, SHIPPED / "wall-standard-case.ifc")
    assert main(["scene", "import", str(path), "-o", str(tmp_path / "out")]) == 0
    assert b"1 element in 1 part" in capfdbinary.readouterr().err
    assert "Halle_S\\xfcd_wall-standard-case.ifc" in (tmp_path / "out" / "README.md").read_text(encoding="utf-8")
    assert main(["scene", "info", str(path)]) == 0  # the file itself, through the cache
    assert b"IfcWallStandardCase" in capfdbinary.readouterr().out
