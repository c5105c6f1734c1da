"""`mrcheck scene import`, commands given an .ifc/.step file directly, `mrcheck --package-path`:
what a planner sees on the command line."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrcheck.cli import main
from mrcheck.core.resources import robot_assets_dir

DATA = Path(__file__).parent / "data" / "cad"
UR5 = robot_assets_dir() / "ur5"


def test_scene_import_writes_a_scene_every_command_reads(tmp_path, capsys):
    out = tmp_path / "wall"
    assert main(["scene", "import", str(DATA / "ifc" / "wall-standard-case.ifc"), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == str(out / "scene.toml")
    assert "1 element in 1 part, 12 triangles, 0 left out" in captured.err
    assert main(["scene", "info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "IfcWallStandardCase" in info and "Double_Brick_-_270" in info


def test_render_takes_the_step_file_itself(tmp_path, capsys):
    image = tmp_path / "parts.png"
    assert (
        main(
            [
                "render",
                str(DATA / "step" / "red_cube_blue_cylinder.step"),
                "--view",
                "overview",
                "--width",
                "160",
                "--height",
                "120",
                "--mode",
                "phong",
                "-o",
                str(image),
            ]
        )
        == 0
    )
    assert image.stat().st_size > 0


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda d: (
                (d / "cut.ifc").write_bytes((DATA / "ifc" / "wall-standard-case.ifc").read_bytes()[:2000])
                and d / "cut.ifc"
            ),
            "truncated IFC4 file",
        ),
        (
            lambda d: shutil.copyfile(DATA / "step" / "red_cube_blue_cylinder.step", d / "part.ifc"),
            "not IFC: rename it",
        ),
        (lambda d: DATA / "ifc" / "reinforcing-stirrup.ifc", "IfcReinforcingBar 381QpY9RP89gKaSFbzIfbP"),
    ],
)
def test_bad_model_is_one_line_exit_1_and_nothing_written(tmp_path, capsys, make, message):
    model = Path(make(tmp_path))
    out = tmp_path / "out"
    assert main(["scene", "import", str(model), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {model}: ") and message in err and "\n" not in err
    assert not out.exists()


def test_generate_ifc_refuses_mixed_units(tmp_path, capsys):
    assert (
        main(["scene", "generate", "--preset", "cell", "--format", "ifc", "--units-mix", "-o", str(tmp_path / "x")])
        == 1
    )
    assert "an IFC file declares one unit" in capsys.readouterr().err


def test_package_path_option(tmp_path, capsys):
    src = tmp_path / "src"
    shutil.copytree(UR5 / "meshes", src / "ur_description" / "meshes")
    urdf = tmp_path / "ur5.urdf"
    urdf.write_text(
        (UR5 / "robot.urdf").read_text().replace('filename="meshes/', 'filename="package://ur_description/meshes/')
    )
    assert main(["scene", "info", str(urdf)]) == 1
    assert "give --package-path DIR" in capsys.readouterr().err
    assert main(["--package-path", str(src), "scene", "info", str(urdf)]) == 0


def test_help_has_examples(capsys):
    for command in (["scene", "import"], ["scene", "generate"]):
        assert main([*command, "--help"]) == 0
        assert "Examples:" in capsys.readouterr().out
