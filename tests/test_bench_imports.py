"""The bench's import figures measure what they say (on small files: the real figures come from
`mrcheck bench` on the generated 5 M-triangle hall)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrcheck.eval.bench.imports import format_imports, measure_cache, measure_ifc, measure_step

DATA = Path(__file__).parent / "data" / "cad"


@pytest.mark.slow
def test_import_figures_are_measured_and_reported(tmp_path):
    ifc = measure_ifc(DATA / "ifc" / "basin-faceted-brep.ifc", rounds=2)
    assert set(ifc.rounds) == {1, 2} and all(len(r) == 2 and min(r) > 0 for r in ifc.rounds.values())
    assert ifc.seconds[1] == min(ifc.rounds[1]) and ifc.elements == 1
    cache = measure_cache(DATA / "ifc" / "wall-standard-case.ifc", tmp_path / "cache")
    assert 0 < cache.reload_s and 0 < cache.first_s and (tmp_path / "cache" / "imports").is_dir()
    step = measure_step([DATA / "step" / "red_cube_blue_cylinder.step"])
    assert step.files[0][0] == "red_cube_blue_cylinder.step" and step.files[0][3] > 0
    lines = format_imports(ifc, cache, step)
    assert any("elements/s" in line and "MB/s" in line for line in lines)
    assert any("two threads / one" in line and "target" in line for line in lines)
    assert any("cached reload" in line for line in lines) and any("s per MB" in line for line in lines)


@pytest.mark.slow
def test_bench_command_measures_the_hall_as_ifc(tmp_path, monkeypatch):
    """bench's import section: the hall written once as IFC beside the generated scene (a
    stand-in generator here: the real one makes the 5 M-triangle hall), imported and reported."""
    import tempfile

    from factory_scenes.generator import generate
    from factory_scenes.generator.ifc import write_ifc
    from mrcheck.eval.bench import run as bench
    from mrcheck.eval.bench.scenes import HallGenerator, hall_ifc_path

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # the bench's cache of halls: this test's
    source = tmp_path / "source"
    source.mkdir()
    (source / "stand_in.py").write_text("# a generator of its own: its own cache key\n")

    def small(preset, folder, seed=0, target_triangles=None, progress=False):
        return generate("cell", folder, seed=seed, target_triangles=50_000, progress=progress)

    hall = HallGenerator(small, source, write_ifc)
    path = hall_ifc_path(hall, 1_000_000)
    assert path.name == "hall.ifc" and path.stat().st_size > 0
    assert hall_ifc_path(hall, 1_000_000) == path  # written once
    report = bench.import_figures(True, hall)
    data = report.to_json()
    assert data["ifc"]["elements"] > 100 and set(data["ifc"]["seconds"]) == {1, 2}
    assert data["cache"]["reload_s"] > 0 and data["step"]["seconds_per_mb"] > 0
