"""``mrcheck scene info``: the numbers a planner reads before rendering, and the report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path
from mrcheck.scene.info import describe, format_info
from mrcheck.scene.model import load_scene

SAMPLE = sample_scene_path()
KEYS = {
    "scene",
    "source",
    "triangles",
    "unique_triangles",
    "bounds_m",
    "parts",
    "viewpoints",
    "units_declared",
    "parts_without_units",
    "files_bytes",
}
PART_KEYS = {"name", "mesh", "units", "instances", "triangles", "triangles_drawn", "bounds_m"}
VIEW_KEYS = {"name", "eye", "target", "fov_y_deg", "width", "height"}


@pytest.fixture(scope="module")
def sample_info() -> dict:
    return describe(SAMPLE)


def test_sample_numbers_add_up_and_match_the_loaded_scene(sample_info):
    info, scene = sample_info, load_scene(SAMPLE)
    assert KEYS <= set(info) and all(PART_KEYS <= set(p) for p in info["parts"])
    assert info["triangles"] == sum(p["triangles"] * p["instances"] for p in info["parts"]) == scene.triangle_count
    assert info["triangles"] == sum(p["triangles_drawn"] for p in info["parts"])
    assert info["unique_triangles"] == sum(p["triangles"] for p in info["parts"]) < info["triangles"]
    assert info["bounds_m"] == scene.bounds().tolist()
    parts = {p["name"]: p for p in info["parts"]}
    assert len(parts) == 16 and parts["column"]["instances"] == 6 and parts["fence_post"]["instances"] == 20
    assert parts["conveyor"]["units"] == "mm" and parts["conveyor"]["mesh"] == "meshes/conveyor.glb"
    assert parts["robot"]["mesh"] == "robots/kuka_iiwa/model.urdf"
    assert info["units_declared"] == ["m", "mm"] and info["parts_without_units"] == []
    # every part's bounds are inside the scene's, and the floor's are the slab's
    lo, hi = np.array(info["bounds_m"])
    assert all(
        np.all(np.array(p["bounds_m"][0]) >= lo) and np.all(np.array(p["bounds_m"][1]) <= hi) for p in info["parts"]
    )
    assert np.allclose(parts["floor"]["bounds_m"], [[-12, -8, -0.2], [12, 8, 0]], atol=1e-5)
    assert [v["name"] for v in info["viewpoints"]] == ["overview", "robot", "conveyor"]
    assert info["viewpoints"][1] == {
        "name": "robot",
        "eye": [3.4, -6.2, 1.7],
        "target": [3.0, -2.5, 0.75],
        "fov_y_deg": 35.0,
        "width": 1024,
        "height": 768,
    }
    json.dumps(info)  # JSON-ready as it is


def test_files_bytes_counts_meshes_and_what_they_load_once(sample_info):
    folder = SAMPLE.parent
    robot = folder / "robots" / "kuka_iiwa"
    files = [*(folder / "meshes").glob("*.glb"), robot / "model.urdf", *(robot / "meshes").glob("link_*.*")]
    assert sample_info["files_bytes"] == sum(f.stat().st_size for f in files)


def box(path: Path, size=(1000.0, 500.0, 250.0)) -> Path:
    trimesh.creation.box(size, trimesh.transformations.translation_matrix((0, 0, size[2] / 2))).export(path)
    return path


def test_a_mesh_file_with_units_mm(tmp_path):
    mesh = box(tmp_path / "crate.stl")
    info = describe(mesh, units="mm")
    assert info["triangles"] == info["unique_triangles"] == 12
    assert np.allclose(info["bounds_m"], [[-0.5, -0.25, 0.0], [0.5, 0.25, 0.25]], atol=1e-6)
    assert info["parts"][0] | {"bounds_m": None} == {
        "name": "crate",
        "mesh": str(mesh),
        "units": "mm",
        "instances": 1,
        "triangles": 12,
        "triangles_drawn": 12,
        "bounds_m": None,
    }
    assert info["units_declared"] == ["mm"] and info["parts_without_units"] == [] and info["viewpoints"] == []
    assert info["files_bytes"] == mesh.stat().st_size
    assert "WARNING" not in format_info(info)
    # without --units the file's coordinates are taken as they are -- and the report says so
    bare = describe(mesh)
    assert bare["parts_without_units"] == ["crate"] and np.isclose(bare["bounds_m"][1][0], 500.0)
    assert "WARNING" in format_info(bare)


def test_a_part_without_units_is_flagged(tmp_path):
    box(tmp_path / "crate.glb")
    (tmp_path / "scene.toml").write_text(
        'name = "forgot"\n\n'
        '[[parts]]\nname = "crate_mm"\nmesh = "crate.glb"\nunits = "mm"\ninstances = [{}, { translate = [3.0, 0.0, 0.0] }]\n\n'
        '[[parts]]\nname = "crate_raw"\nmesh = "crate.glb"\ntranslate = [0.0, 5.0, 0.0]\n\n'
        '[[viewpoints]]\nname = "v"\neye = [5.0, 5.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\n'
    )
    info = describe(tmp_path / "scene.toml")
    assert (
        info["scene"] == "forgot" and info["parts_without_units"] == ["crate_raw"] and info["units_declared"] == ["mm"]
    )
    assert [p["units"] for p in info["parts"]] == ["mm", None]
    assert info["triangles"] == 36 and info["unique_triangles"] == 24
    assert info["files_bytes"] == (tmp_path / "crate.glb").stat().st_size  # one file, two parts: counted once
    assert info["viewpoints"] == [
        {
            "name": "v",
            "eye": [5.0, 5.0, 5.0],
            "target": [0.0, 0.0, 0.0],
            "fov_y_deg": 60.0,
            "width": 1024,
            "height": 768,
        }
    ]
    text = format_info(info)
    warnings = [line for line in text.splitlines() if line.startswith("WARNING")]
    assert len(warnings) == 1 and "crate_raw" in warnings[0] and "crate_mm" not in warnings[0]


def test_report_is_an_aligned_table_with_totals_bounds_and_views(sample_info):
    text = format_info(sample_info)
    lines = text.splitlines()
    assert "53,633" in text and "29,045" in text
    assert any(line.startswith("extent") and "24.000 x 16.000 x 6.600 m" in line for line in lines)
    header = next(i for i, line in enumerate(lines) if line.startswith("part "))
    rows = lines[header + 2 : header + 2 + 16]
    assert [r.split()[0] for r in rows] == [p["name"] for p in sample_info["parts"]]
    # right-aligned numbers: every row's "drawn" column ends where the header's does
    end = lines[header].index("drawn") + len("drawn")
    assert all(r[end - 1].isdigit() and r[end] == " " for r in rows)
    assert "overview" in text and "1024 x 768" in text and "WARNING" not in text


def test_cli_json_and_text(capsys):
    assert main(["scene", "info", str(SAMPLE), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert KEYS <= set(info) and info["triangles"] == load_scene(SAMPLE).triangle_count
    assert all(VIEW_KEYS <= set(v) for v in info["viewpoints"])
    assert main(["scene", "info", str(SAMPLE)]) == 0
    assert capsys.readouterr().out.startswith("scene       sample_cell\n")


def test_cli_missing_scene_is_one_error_line(tmp_path, capsys):
    assert main(["scene", "info", str(tmp_path / "nope.toml"), "--json"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and captured.err.startswith("error: ")


@pytest.mark.slow
def test_describe_needs_no_gl():
    code = (
        "import sys; from mrcheck.scene.info import describe; from mrcheck.core.resources import sample_scene_path; "
        "describe(sample_scene_path()); assert 'moderngl' not in sys.modules, 'GL imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
