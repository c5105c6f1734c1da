"""STEP import on files written by other software (tests/data/cad/step: NIST CAx-IF test cases,
CadQuery and build123d files) and on an assembly made here: units, assembly paths as ids,
instancing, colours, tessellation tolerance, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.importers import ImportSettings, read_model

DATA = Path(__file__).parent / "data" / "cad" / "step"


def _extent(part) -> np.ndarray:
    return np.ptp(part.vertices, axis=0)


def test_metre_file_two_products_with_their_colours():
    model = read_model(DATA / "red_cube_blue_cylinder.step")  # AP214, CONVERSION_BASED_UNIT('METRE')
    parts = {p.name: p for p in model.parts}
    assert set(parts) == {"red_cube", "blue_cylinder"}
    np.testing.assert_allclose(_extent(parts["red_cube"]), [0.01, 0.01, 0.01], atol=1e-6)
    red, blue = parts["red_cube"].color, parts["blue_cylinder"].color
    assert red[0] > 3 * max(red[1:]) and blue[2] > 3 * max(blue[:2])
    assert parts["red_cube"].instances[0].id == "red_cube"


@pytest.mark.parametrize(
    "name, longest",
    [
        ("nist_ctc_01_asme1_rd.stp", 0.8),  # AP203 ed.2, mm
        ("nist_ctc_03_asme1_ap242-e2.stp", 0.4854),  # AP242 ed.2, mm (an inch unit declared too)
        ("M6-1x12-countersunk-screw.step", 0.012),  # AP214 from OpenCascade, mm, B-splines
    ],
)
def test_millimetre_files_land_in_metres(name, longest):
    model = read_model(DATA / name)
    assert max(_extent(p).max() for p in model.parts) == pytest.approx(longest, rel=0.02)
    assert not model.failed


def test_wireframe_only_shapes_are_left_out_with_a_note():
    model = read_model(DATA / "nist_ctc_01_asme1_rd.stp")  # a solid and a bounded wireframe
    assert len(model.parts) == 1 and model.parts[0].instances[0].id == "nist_ctc_01_asme1_rd/SOLID"
    assert any("without faces" in note for note in model.notes)


def test_a_finer_tolerance_gives_more_triangles():
    coarse = read_model(DATA / "M6-1x12-countersunk-screw.step", ImportSettings(tolerance_px=2.0))
    fine = read_model(DATA / "M6-1x12-countersunk-screw.step", ImportSettings(tolerance_px=0.5, distance_m=0.2))
    assert fine.triangle_count > coarse.triangle_count


def _assembly(path: Path, unit: str = "MM") -> Path:
    """A STEP assembly ``rig`` with one 20 x 10 x 5 mm block used twice (at x = 0 and 100 mm)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = TDocStd_Document(TCollection_ExtendedString("MDTV-XCAF"))
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    block = shapes.AddShape(BRepPrimAPI_MakeBox(20.0, 10.0, 5.0).Shape(), False)
    TDataStd_Name.Set_s(block, TCollection_ExtendedString("block"))
    rig = shapes.NewShape()
    TDataStd_Name.Set_s(rig, TCollection_ExtendedString("rig"))
    for x in (0.0, 100.0):
        move = gp_Trsf()
        move.SetTranslation(gp_Vec(x, 0.0, 0.0))
        shapes.AddComponent(rig, block, TopLoc_Location(move))
    shapes.UpdateAssemblies()
    Interface_Static.SetCVal_s("write.step.unit", unit)
    writer = STEPCAFControl_Writer()
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    writer.Write(str(path))
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    return path


def test_assembly_repeats_are_instances_with_assembly_paths(tmp_path):
    model = read_model(_assembly(tmp_path / "rig.step"))
    (part,) = model.parts
    assert part.name == "block" and len(part.instances) == 2
    assert all(i.id.startswith("rig/") for i in part.instances) and len({i.id for i in part.instances}) == 2
    offsets = sorted(i.matrix[0, 3] for i in part.instances)
    np.testing.assert_allclose(offsets, [0.0, 0.1], atol=1e-9)  # 100 mm
    np.testing.assert_allclose(_extent(part), [0.02, 0.01, 0.005], atol=1e-9)


def test_inch_file_lands_in_metres(tmp_path):
    model = read_model(_assembly(tmp_path / "rig_inch.step", unit="IN"))
    np.testing.assert_allclose(_extent(model.parts[0]), [0.02, 0.01, 0.005], atol=1e-6)


# -- bad input --------------------------------------------------------------------------------
def test_truncated_step(tmp_path):
    data = (DATA / "red_cube_blue_cylinder.step").read_bytes()
    path = tmp_path / "cut.step"
    path.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(MrcheckError, match=r"cut\.step: truncated STEP AP214 file"):
        read_model(path)


def test_step_without_any_shape(tmp_path):
    text = (DATA / "red_cube_blue_cylinder.step").read_text()
    head, data = text.split("DATA;", 1)
    path = tmp_path / "empty.step"
    path.write_text(head + "DATA;\nENDSEC;\nEND-ISO-10303-21;\n")
    with pytest.raises(MrcheckError, match=r"empty\.step: .*(holds no shape|cannot read STEP)"):
        read_model(path)


def test_step_that_does_not_tessellate(tmp_path):
    # every B-rep face of the cube and cylinder loses its surface: nothing can be meshed
    import re

    text = (DATA / "red_cube_blue_cylinder.step").read_text()
    broken = re.sub(r"ADVANCED_FACE\( '([^']*)', \( ([^)]*) \), #\d+,", r"ADVANCED_FACE( '\1', ( \2 ), $,", text)
    assert broken != text
    path = tmp_path / "flat.step"
    path.write_text(broken)
    with pytest.raises(MrcheckError, match=r"flat\.step: .*(tessellates|holds no shape|cannot read STEP)"):
        read_model(path)
