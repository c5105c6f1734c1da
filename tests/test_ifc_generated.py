"""The generator's IFC output read back by the importer: the round trip (generate -> IFC -> import
-> render gives the GLB scene's image) and map coordinates (the same model at its own
coordinates and shifted by (458658.78, 5438232.79, 113.7) renders the same image from the same
relative camera, also through a camera JSON in map coordinates)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.importers import ImportSettings
from mrcheck.scene.importers.cache import import_scene
from mrcheck.scene.model import load_scene

from .test_golden import TOLERANCE

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

SHIFT = np.array([458658.78, 5438232.79, 113.7])
W, H = 320, 240


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """(GLB scene, IFC of it at its own coordinates, IFC of it with a map conversion to SHIFT)."""
    from factory_scenes.generator import generate
    from factory_scenes.generator.ifc import generate_ifc, write_ifc

    folder = tmp_path_factory.mktemp("generated")
    manifest = generate("cell", folder / "glb", seed=2, target_triangles=50_000, progress=False)
    own = generate_ifc("cell", folder / "ifc", seed=2, target_triangles=50_000, progress=False)
    mapped = write_ifc(load_scene(manifest), folder / "map.ifc", 2, "map test", map_origin=SHIFT)
    return manifest, own, mapped


def _image(ctx, scene, camera) -> np.ndarray:
    return Renderer(scene, ctx=ctx).render(camera, ["vector"], RenderSettings())["vector"].image


def _assert_same_image(a, b):
    diff = np.abs(a.astype(np.int16) - b.astype(np.int16))
    mean, share = diff.mean() / 255.0, (diff > 8).mean()
    assert mean <= TOLERANCE[0] and share <= TOLERANCE[1], (mean, share)


def _shifted_camera(scene, view, shift) -> Camera:
    vp = scene.viewpoints[view]
    return Camera.from_look_at(
        np.asarray(vp["eye"]) + shift,
        np.asarray(vp["target"]) + shift,
        vp.get("up", (0, 0, 1)),
        vp.get("fov_y_deg", 60.0),
        W,
        H,
    )


@pytest.mark.slow
def test_round_trip_renders_the_glb_scenes_image(ctx, generated):
    manifest, own, _ = generated
    glb, ifc = load_scene(manifest), load_scene(own)  # the .ifc itself, through the import cache
    # a robot's float32 mesh has a couple of triangles that float32 made zero-area: written to
    # the IFC as they are, the loader drops them on the way back (invisible either way)
    assert abs(ifc.triangle_count - glb.triangle_count) <= 1e-4 * glb.triangle_count
    assert sorted(p.name for p in ifc.parts) == sorted(p.name for p in glb.parts)
    for view in ("overview", "robot"):
        if view in glb.viewpoints:
            camera = glb.camera(view, W, H)
            _assert_same_image(_image(ctx, glb, camera), _image(ctx, ifc, camera))


def test_generated_ifc_classes_and_ids(generated):
    from factory_scenes.generator.ifc import STOREY

    _, own, _ = generated
    scene = load_scene(own)
    column = next(p for p in scene.parts if p.name == "column")
    assert column.ifc_class == "IfcColumn" and column.storey == STOREY
    assert all(len(i) == 22 for i in column.instance_ids)  # GlobalIds
    assert {info.name for info in column.instance_info} >= {"column-A01"}  # the generator's ids as names
    assert scene.element(column.instance_ids[0])[2].ifc_class == "IfcColumn"


@pytest.mark.slow
def test_generated_ifc_is_the_same_bytes_for_the_same_arguments(generated, tmp_path):
    from factory_scenes.generator.ifc import write_ifc

    manifest, own, _ = generated
    header = own.read_bytes().split(b"FILE_DESCRIPTION(('", 1)[1].split(b"'", 1)[0].decode()
    again = write_ifc(load_scene(manifest), tmp_path / "again.ifc", 2, header)
    assert again.read_bytes() == own.read_bytes()  # GlobalIds, relationship order, time stamp: all fixed


@pytest.mark.slow
def test_map_coordinates_render_the_same_image_from_the_same_relative_camera(ctx, generated, tmp_path):
    manifest, _, mapped = generated
    glb = load_scene(manifest)
    at_map = load_scene(import_scene(mapped, tmp_path / "map", ImportSettings(coordinates="map")).manifest)
    at_own = load_scene(import_scene(mapped, tmp_path / "own", ImportSettings(coordinates="model")).manifest)
    assert tuple(at_map.origin) == tuple(SHIFT) and at_map.crs == "EPSG:25832"  # float64, exact
    np.testing.assert_allclose(at_map.bounds() - SHIFT, at_own.bounds(), atol=1e-6)
    near = _image(ctx, at_own, glb.camera("overview", W, H))
    far = _image(ctx, at_map, _shifted_camera(glb, "overview", SHIFT))
    _assert_same_image(near, far)
    # the manifest's viewpoint is relative to its origin: in world coordinates it is at the map
    np.testing.assert_allclose(
        np.asarray(at_map.viewpoints["overview"]["eye"]) - SHIFT, at_own.viewpoints["overview"]["eye"], atol=1e-6
    )


@pytest.mark.slow
def test_a_camera_json_in_map_coordinates_works_unchanged(generated, tmp_path, capsys):
    from mrcheck.cli import main

    manifest, _, mapped = generated
    glb = load_scene(manifest)
    camera = _shifted_camera(glb, "overview", SHIFT)
    path = tmp_path / "camera.json"
    from mrcheck.core.camerafiles import write_camera

    write_camera(path, camera)
    assert np.abs(camera.center - SHIFT).max() < 1e3  # the file holds map coordinates
    scene = import_scene(mapped, tmp_path / "map", ImportSettings(coordinates="map")).manifest
    out_map, out_own = tmp_path / "map.png", tmp_path / "own.png"
    assert main(["render", str(scene), "--camera", str(path), "--mode", "vector", "-o", str(out_map)]) == 0
    assert (
        main(
            [
                "render",
                str(manifest),
                "--view",
                "overview",
                "--width",
                str(W),
                "--height",
                str(H),
                "--mode",
                "vector",
                "-o",
                str(out_own),
            ]
        )
        == 0
    )
    from mrcheck.core.images import read_image

    _assert_same_image(read_image(out_map), read_image(out_own))


@pytest.mark.slow
def test_a_manifest_origin_shifts_every_placement_and_viewpoint(ctx, generated, tmp_path):
    import tomllib

    from mrcheck.scene.manifest import dumps_manifest

    manifest, _, _ = generated
    data = tomllib.loads(Path(manifest).read_text())
    data["origin"] = [float(v) for v in SHIFT]
    shifted = manifest.parent / "scene_at_map.toml"
    shifted.write_text(dumps_manifest(data))
    near, far = load_scene(manifest), load_scene(shifted)
    np.testing.assert_allclose(far.bounds() - SHIFT, near.bounds(), atol=1e-6)
    _assert_same_image(_image(ctx, near, near.camera("overview", W, H)), _image(ctx, far, far.camera("overview", W, H)))


@pytest.mark.slow
def test_ray_casting_and_deviation_at_map_coordinates(generated, tmp_path):
    """The discrepancy check's ray cast (which instance each pixel sees) and the scan deviation
    (cloud-to-mesh distance) of the model at map coordinates equal those at its own, to 0.1 mm."""
    from mrcheck.apps.deviation.distances import signed_distances
    from mrcheck.apps.discrepancies.ids import object_ids

    manifest, _, mapped = generated
    glb = load_scene(manifest)
    at_map = load_scene(import_scene(mapped, tmp_path / "map", ImportSettings(coordinates="map")).manifest)
    at_own = load_scene(import_scene(mapped, tmp_path / "own", ImportSettings(coordinates="model")).manifest)
    near_ids = object_ids(at_own, glb.camera("overview", W, H))
    far_ids = object_ids(at_map, _shifted_camera(glb, "overview", SHIFT))
    assert (np.asarray(near_ids[0]) == np.asarray(far_ids[0])).mean() > 0.999
    rng = np.random.default_rng(0)
    lo, hi = at_own.bounds()
    points = rng.uniform(lo, hi, size=(2000, 3))
    near, _ = signed_distances(at_own, points)
    far, _ = signed_distances(at_map, points + SHIFT)
    np.testing.assert_allclose(far, near, atol=1e-4)


def test_viewpoints_survive_the_ifc_round_trip(ctx, generated, tmp_path):
    """The generated scene's viewpoints (aisle, ...) come back from its IFC, in the scene's order
    and in map coordinates too; --view aisle renders the GLB scene's image."""
    manifest, own, mapped = generated
    glb, ifc = load_scene(manifest), load_scene(own)
    assert list(ifc.viewpoints) == list(glb.viewpoints) and "aisle" in ifc.viewpoints
    for name, view in glb.viewpoints.items():
        for key in ("eye", "target"):
            np.testing.assert_allclose(ifc.viewpoints[name][key], view[key], atol=1e-9)
        assert ifc.viewpoints[name]["fov_y_deg"] == view["fov_y_deg"]
    camera = ifc.camera("aisle", W, H)
    _assert_same_image(_image(ctx, glb, camera), _image(ctx, ifc, camera))
    at_map = load_scene(import_scene(mapped, tmp_path / "map", ImportSettings(coordinates="map")).manifest)
    np.testing.assert_allclose(np.asarray(at_map.viewpoints["aisle"]["eye"]) - SHIFT, glb.viewpoints["aisle"]["eye"])
