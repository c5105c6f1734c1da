"""The import cache behind `mrcheck <command> MODEL.ifc|.step`: keyed by content and settings, never
half-written; and `scene import`'s output folder rules."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.core.progress import no_progress
from mrcheck.scene.importers import ImportSettings, cache
from mrcheck.scene.importers.cache import cache_root, cached_manifest, import_scene
from mrcheck.scene.model import load_scene

DATA = Path(__file__).parent / "data" / "cad"
WALL = DATA / "ifc" / "wall-standard-case.ifc"


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    """A cache of this test's own (the session's is shared by every test)."""
    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture
def counted(monkeypatch):
    """How often the importer really parses a file."""
    calls = []
    real = cache.read_model

    def read_model(path, settings=None, progress=no_progress):
        calls.append(Path(path).name)
        return real(path, settings, progress)

    monkeypatch.setattr(cache, "read_model", read_model)
    return calls


def test_second_load_of_an_unchanged_file_is_a_cache_hit(tmp_path, counted):
    first = cached_manifest(WALL)
    again = cached_manifest(WALL)
    assert counted == ["wall-standard-case.ifc"] and not first.cached and again.cached
    assert again.manifest == first.manifest and first.manifest.is_relative_to(cache_root())


def test_the_key_is_the_content_not_the_name_and_the_settings_count(tmp_path, counted):
    cached_manifest(WALL)
    renamed = tmp_path / "renamed.ifc"
    shutil.copyfile(WALL, renamed)
    assert cached_manifest(renamed).cached  # same bytes: a hit
    renamed.write_text(renamed.read_text().replace("5000.0,270.0", "4000.0,270.0"))
    assert not cached_manifest(renamed).cached  # edited: a miss
    assert not cached_manifest(WALL, ImportSettings(coordinates="map")).cached
    assert len(counted) == 3


def test_load_scene_takes_the_model_file_itself(tmp_path):
    scene = load_scene(DATA / "step" / "red_cube_blue_cylinder.step")
    assert scene.source == DATA / "step" / "red_cube_blue_cylinder.step"
    assert {p.name for p in scene.parts} == {"red_cube", "blue_cylinder"} and "overview" in scene.viewpoints
    with pytest.raises(MrcheckError, match="--units applies to a mesh file"):
        load_scene(WALL, units="mm")


def test_a_failed_import_writes_nothing(tmp_path):
    broken = tmp_path / "cut.ifc"
    broken.write_bytes(WALL.read_bytes()[:1000])
    out = tmp_path / "out"
    with pytest.raises(MrcheckError, match="truncated"):
        import_scene(broken, out)
    assert not out.exists()
    with pytest.raises(MrcheckError, match="truncated"):
        cached_manifest(broken)
    assert not cache_root().exists() or not any(cache_root().iterdir())


def test_import_replaces_an_earlier_import_but_no_other_folder(tmp_path):
    out = tmp_path / "out"
    import_scene(WALL, out)
    (out / "notes.txt").write_text("mine")
    result = import_scene(DATA / "ifc" / "beam-extruded-solid.ifc", out)
    assert result.elements == 1 and (out / "notes.txt").read_text() == "mine"
    assert "IPE600" in (out / "scene.toml").read_text()
    other = tmp_path / "other"
    other.mkdir()
    (other / "photo.jpg").write_bytes(b"x")
    with pytest.raises(MrcheckError, match="not empty and holds no imported scene"):
        import_scene(WALL, other)


def test_many_instances_go_to_a_json_file_beside_the_mesh(tmp_path):
    import json

    import numpy as np
    import trimesh

    from factory_scenes.generator.ifc import write_ifc
    from mrcheck.scene.model import Scene, make_part

    box = trimesh.creation.box()
    T = np.tile(np.eye(4), (40, 1, 1))
    T[:, 0, 3] = np.arange(40) * 3.0
    T[:, 1, 3] = 5e6  # far out: the matrices keep it exactly
    scene = Scene("rows", tmp_path, [make_part("column", tmp_path, np.asarray(box.vertices), np.asarray(box.faces), T)])
    model = write_ifc(scene, tmp_path / "rows.ifc", 0, "rows")
    out = tmp_path / "rows"
    import_scene(model, out)
    table = json.loads((out / "meshes" / "column.instances.json").read_text())
    assert len(table) == 40 and "instances_file" in (out / "scene.toml").read_text()
    loaded = load_scene(out)
    np.testing.assert_array_equal(np.sort(loaded.parts[0].transforms[:, 0, 3]), np.arange(40) * 3.0)
    assert np.all(loaded.parts[0].transforms[:, 1, 3] == 5e6)
    from mrcheck.scene.manifest import read_manifest

    assert len(read_manifest(out / "scene.toml")["parts"][0]["instances"]) == 40  # what asbuilt & co. read
    (out / "meshes" / "column.instances.json").write_text("[{")
    with pytest.raises(MrcheckError, match=r"column\.instances\.json: malformed instances file"):
        load_scene(out)
