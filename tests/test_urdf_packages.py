"""URDF meshes named ``package://NAME/...`` resolve through --package-path, a manifest's
package_path, ROS_PACKAGE_PATH and the URDF's own package; unresolved ones say what to do."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import robot_assets_dir
from mrcheck.scene import packages
from mrcheck.scene.model import load_scene

UR5 = robot_assets_dir() / "ur5"


@pytest.fixture(autouse=True)
def no_configured_path(monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    packages.set_package_path([])
    yield
    packages.set_package_path([])


def _workspace(tmp_path, package="ur_description", prefix="") -> tuple[Path, Path]:
    """(workspace src folder holding the package, a URDF elsewhere naming package://PACKAGE/PREFIX meshes)."""
    src = tmp_path / "ws" / "src"
    shutil.copytree(UR5 / "meshes", src / package.replace("-", "_") / "meshes")
    urdf = tmp_path / "elsewhere" / "ur5.urdf"
    urdf.parent.mkdir()
    text = (
        (UR5 / "robot.urdf").read_text().replace('filename="meshes/', f'filename="package://{package}/{prefix}meshes/')
    )
    urdf.write_text(text)
    return src, urdf


def test_unresolved_package_says_how_to_give_its_folder(tmp_path):
    _, urdf = _workspace(tmp_path)
    with pytest.raises(
        MrcheckError,
        match=r"not found: package://ur_description/meshes/visual/base\.dae.*"
        r"give --package-path DIR .*ROS_PACKAGE_PATH",
    ):
        load_scene(urdf)


def test_package_path_option(tmp_path):
    src, urdf = _workspace(tmp_path)
    packages.set_package_path([str(src)])
    assert load_scene(urdf).triangle_count > 10_000


def test_ros_package_path(tmp_path, monkeypatch):
    src, urdf = _workspace(tmp_path)
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"/nonexistent:{src}")
    assert load_scene(urdf).triangle_count > 10_000


def test_manifest_package_path_relative_to_the_manifest(tmp_path):
    _, urdf = _workspace(tmp_path)
    manifest = tmp_path / "scene.toml"
    manifest.write_text(
        'package_path = ["ws/src"]\n\n[[parts]]\nname = "arm"\nmesh = "elsewhere/ur5.urdf"\nunits = "m"\n'
    )
    assert load_scene(manifest).triangle_count > 10_000


def test_hyphenated_name_and_a_partly_copied_package(tmp_path):
    # as the shared UR5 of example-robot-data: package://example-robot-data/robots/ur_description/...
    # with the files in a folder example_robot_data/ that holds only ur_description/
    src, urdf = _workspace(tmp_path, package="example-robot-data", prefix="robots/ur_description/")
    package = src / "example_robot_data"
    (package / "ur_description").mkdir()
    shutil.move(str(package / "meshes"), str(package / "ur_description" / "meshes"))
    packages.set_package_path([str(src)])
    assert load_scene(urdf).triangle_count > 10_000


def test_a_urdf_inside_its_package_needs_no_path(tmp_path):
    src, urdf = _workspace(tmp_path)
    inside = src / "ur_description" / "urdf" / "ur5.urdf"
    inside.parent.mkdir()
    shutil.move(str(urdf), str(inside))
    assert load_scene(inside).triangle_count > 10_000


def test_export_copies_package_meshes_too(tmp_path):
    from mrcheck.scene.manifest import mesh_files

    src, urdf = _workspace(tmp_path)
    packages.set_package_path([str(src)])
    files = mesh_files(urdf)
    assert any(f.name == "base.dae" and f.is_relative_to(src) for f in files)
