"""Scene loading: every mesh format the manifest accepts, every unit, instancing, URDF."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import sample_scene_path
from mrcheck.render import gl
from mrcheck.scene.model import UNITS, load_scene


@pytest.mark.parametrize("suffix", [".glb", ".gltf", ".obj", ".stl", ".ply", ".off"])
def test_every_mesh_format_loads_to_the_same_geometry(tmp_path, suffix):
    mesh = trimesh.creation.box((2.0, 3.0, 4.0), trimesh.transformations.translation_matrix((5, 6, 7)))
    path = tmp_path / f"box{suffix}"
    mesh.export(path)
    scene = load_scene(path)
    assert scene.triangle_count == 12
    assert np.allclose(scene.bounds(), [[4, 4.5, 5], [6, 7.5, 9]], atol=1e-5)


@pytest.mark.parametrize("unit", sorted(UNITS))
def test_a_part_in_any_unit_lands_at_the_right_place_and_size_in_metres(tmp_path, unit):
    size = 1.0 / UNITS[unit]  # one metre, in that unit
    trimesh.creation.box((size, size, size), trimesh.transformations.translation_matrix((size, 0, 0))).export(
        tmp_path / "box.stl"
    )
    (tmp_path / "scene.toml").write_text(
        f'[[parts]]\nname = "box"\nmesh = "box.stl"\nunits = "{unit}"\ntranslate = [10.0, 0.0, 0.0]\n'
        "instances = [{}, { translate = [0.0, 5.0, 0.0] }]\n"
    )
    scene = load_scene(tmp_path / "scene.toml")
    boxes = scene.parts[0].instance_bounds()
    assert np.allclose(boxes[0], [[10.5, -0.5, -0.5], [11.5, 0.5, 0.5]], atol=1e-5)
    assert np.allclose(boxes[1], boxes[0] + [0, 5, 0], atol=1e-5)
    assert scene.triangle_count == 24  # instances counted


def test_sample_scene_mixes_units_and_poses_its_robot_from_the_urdf():
    scene = load_scene(sample_scene_path())
    parts = {p.name: p for p in scene.parts}
    assert {p.units for p in scene.parts} >= {"m", "mm"}
    conveyor = parts["conveyor"].instance_bounds()[0]
    assert 7.5 < conveyor[1, 0] - conveyor[0, 0] < 8.5  # an 8 m conveyor authored in millimetres
    robot = parts["robot"].instance_bounds()[0]
    pedestal = parts["robot_pedestal"].instance_bounds()[0]
    # standing on its pedestal's top plate (the pedestal's bounds include its bolt heads)
    assert pedestal[1, 2] - 0.05 < robot[0, 2] <= pedestal[1, 2]
    assert scene.triangle_count < 200_000 and set(scene.viewpoints) == {"overview", "robot", "conveyor"}


def test_missing_opengl_is_one_line_naming_what_to_install(monkeypatch):
    def no_egl(**kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file:\nNo such file or directory")

    monkeypatch.setattr(gl.moderngl, "create_standalone_context", no_egl)
    with pytest.raises(MrcheckError) as caught:
        gl.create_context()
    message = str(caught.value)
    assert "\n" not in message and "libegl1" in message and "libgl1-mesa-dri" in message


@pytest.mark.parametrize(
    "urdf, message",
    [
        (
            '<robot name="r"><link name="a"><visual><geometry><mesh filename="nope.stl"/></geometry></visual></link></robot>',
            "URDF mesh file(s) not found: nope.stl",
        ),
        (
            '<robot name="r"><link name="a"><visual><geometry><mesh/></geometry></visual></link></robot>',
            "cannot read URDF",
        ),
    ],
)
def test_a_broken_urdf_is_one_line(tmp_path, capsys, urdf, message):
    """yourdfpy logs what is wrong and carries on; mrcheck says it in its one error line instead
    of printing the logger's lines around it."""
    from mrcheck.cli import main

    path = tmp_path / "robot.urdf"
    path.write_text(urdf)
    assert main(["scene", "info", str(path)]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
    assert captured.err.startswith(f"error: {path}: {message}")


def test_a_manifest_with_a_utf8_bom_loads(tmp_path):
    """Windows Notepad saves UTF-8 with a byte-order mark; CRLF line ends come with it."""
    from mrcheck.scene.manifest import read_manifest

    trimesh.creation.box((1.0, 1.0, 1.0)).export(tmp_path / "box.stl")
    text = '[[parts]]\r\nname = "box"\r\nmesh = "box.stl"\r\nunits = "m"\r\n'
    (tmp_path / "scene.toml").write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert load_scene(tmp_path / "scene.toml").triangle_count == 12
    assert read_manifest(tmp_path / "scene.toml")["parts"][0]["name"] == "box"  # as `scene asbuilt` reads it


def test_the_readme_instance_example_does_what_it_says(tmp_path):
    """The documented manifest example (docs/formats.md): the first instance at (-5.8, -2.5), C-2
    turned in place at (-5.8, 3.5) -- not swung about the origin by a part translate."""
    import re
    import tomllib
    from pathlib import Path

    readme = (Path(__file__).parents[1] / "docs" / "formats.md").read_text()
    section = readme[readme.index("## Scene manifest (TOML)") :]
    example = tomllib.loads(re.search(r"```toml\n(.*?)```", section, re.S).group(1))
    part = next(p for p in example["parts"] if p.get("instances"))
    trimesh.creation.box((4000.0, 1000.0, 500.0)).export(tmp_path / "conveyor.stl")  # 4 x 1 m in mm, centred
    part = {**part, "mesh": "conveyor.stl"}
    lines = [f"{k} = {v!r}".replace("'", '"') for k, v in part.items() if k != "instances"]
    instances = ", ".join(
        "{ " + ", ".join(f"{k} = {v!r}".replace("'", '"') for k, v in i.items()) + " }" for i in part["instances"]
    )
    (tmp_path / "scene.toml").write_text("[[parts]]\n" + "\n".join(lines) + f"\ninstances = [{instances}]\n")
    loaded = load_scene(tmp_path / "scene.toml").parts[0]
    assert loaded.instance_ids[1] == "C-2"
    centres = loaded.instance_bounds().mean(axis=1)
    assert np.allclose(centres[:, :2], [[-5.8, -2.5], [-5.8, 3.5]], atol=1e-6)
    sizes = np.ptp(loaded.instance_bounds(), axis=1)
    assert np.allclose(sizes[:, :2], [[1.0, 4.0], [1.0, 4.0]], atol=1e-6)  # turned 90 and 270 degrees
