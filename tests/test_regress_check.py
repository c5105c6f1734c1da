"""``mrcheck regress record`` / ``check`` (issue 43) on the sample cell at 640x480, phong and vector.

The tolerances are not tuned here: they come from the no-change spread measured by
``python examples/regress/measure_spread.py`` (docs/regress.md; 2 cores, Mesa llvmpipe,
2026-12-07): renders byte-identical between runs and between LP_NUM_THREADS 0, 1, 2; under a
modelled driver difference (one 8-bit step of rounding noise, or the principal point moved by
1/256 px) the worst image had FLIP mean 0.0163, p99.9 0.091 and 4 pixels above FLIP 0.2, against
the defaults 0.03, 0.15 and 31 pixels. What a 2 cm move and a colour change then do is asserted
as measured: FLIP fails the conveyor and robot views (p99.9 0.29-0.46, 3900-6300 changed
pixels), not the overview, where 2 cm is about a pixel (p99.9 0.095, 2 changed pixels); the
ray-cast id buffers, which no GPU changes, fail it (the geometry criterion: pixels hitting
another element or depth, at most the same 31).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from mrcheck.apps.regress.attribution import attribute
from mrcheck.apps.regress.baseline import IdBuffer, pixel_hash, read_baseline, read_id_buffer
from mrcheck.apps.regress.run import check, record
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import write_camera
from mrcheck.core.resources import sample_scene_path

SIZE = (640, 480)
CONVEYOR_LINE = "translate = [-5.8, -2.5, 0.0]"  # the sample cell's one conveyor, in scene.toml
CABINET_COLOUR = "color = [0.78, 0.78, 0.75]"  # the control cabinet's colour line


def edited_scene(tmp_path: Path, name: str, old: str, new: str) -> Path:
    """A copy of the sample cell with one line of its scene.toml replaced."""
    folder = tmp_path / name
    shutil.copytree(sample_scene_path().parent, folder)
    manifest = folder / "scene.toml"
    text = manifest.read_text()
    assert text.count(old) == 1, old
    manifest.write_text(text.replace(old, new))
    return manifest


@pytest.fixture(scope="module")
def machine_camera(tmp_path_factory) -> Path:
    """A camera file looking down at the cabinet from the north-east: no conveyor in view."""
    camera = Camera.from_look_at([8.5, 2.5, 2.5], [6.8, 0.6, 0.5], [0, 0, 1], 35.0, *SIZE)
    return write_camera(tmp_path_factory.mktemp("cams") / "machine.json", camera)


@pytest.fixture(scope="module")
def baseline(tmp_path_factory, machine_camera):
    folder = tmp_path_factory.mktemp("regress") / "baseline"
    views = ["overview,conveyor,robot", str(machine_camera)]
    return record(sample_scene_path(), folder, views, size=SIZE)


def shows(baseline, view: str, part: str) -> int:
    """Pixels of ``view``'s baseline id buffer that show ``part``."""
    buffer = read_id_buffer(baseline.folder / f"{view}_ids.npz")
    rows = np.flatnonzero(buffer.labels[:, 0] == part)
    return int(np.isin(buffer.ids, rows).sum())


@pytest.mark.slow
def test_record_writes_images_id_buffers_and_manifest(baseline):
    again = read_baseline(baseline.folder)
    assert [v.name for v in again.views] == ["overview", "conveyor", "robot", "machine"]
    assert again.modes == ("phong", "vector") and (again.width, again.height) == SIZE
    assert "llvmpipe" in again.gl_renderer and len(again.scene_stamp) == 16
    manifest = json.loads((baseline.folder / "baseline.json").read_text())
    assert manifest["settings"]["seed"] == again.settings.seed
    for view in again.views:
        for mode, name in view.images.items():
            assert (baseline.folder / name).is_file()
        assert shows(again, view.name, "floor") > 0  # the id buffer names parts


@pytest.mark.slow
def test_a_render_is_byte_identical_to_the_recorded_one(baseline):
    """The AO kernel and rotation tile are seeded: the same view renders to the same pixels."""
    from mrcheck.apps.regress.snapshots import SnapshotRenderer
    from mrcheck.scene.model import load_scene

    view = baseline.views[0]
    with SnapshotRenderer(load_scene(sample_scene_path()), baseline.modes, baseline.settings) as renderer:
        snap = renderer.render(view.name, view.camera)
    assert {m: pixel_hash(snap.images[m]) for m in baseline.modes} == view.hashes


@pytest.mark.slow
def test_checks_pass_between_runs_and_llvmpipe_thread_counts_within_30_s(baseline, tmp_path):
    """A check in this process (llvmpipe's default here: one thread per core, 2) and one in a
    fresh process with LP_NUM_THREADS=1 (set before the GL context is made) against the fresh
    baseline: both pass with every FLIP mean exactly 0 (byte-identical renders). The one here is
    timed: identical images skip FLIP, and the command took 3.75-3.85 s at a load average of 3
    (7.0-7.2 s with FLIP on all six images, the conveyor moved); 30 s is the issue's target for
    the 3 viewpoints, and this baseline has 4 views."""
    start = time.perf_counter()
    result = check(sample_scene_path(), baseline.folder, tmp_path / "report")
    seconds = time.perf_counter() - start
    assert result.passed and all(m.mean == 0.0 for v in result.views for m in v.modes)
    assert seconds < 30.0, seconds
    env = {**os.environ, "LP_NUM_THREADS": "1"}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "mrcheck.cli",
            "regress",
            "check",
            str(sample_scene_path()),
            "--baseline",
            str(baseline.folder),
            "-o",
            str(tmp_path / "report1"),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("ok       ") == 4
    suite = ET.parse(tmp_path / "report1" / "junit.xml").getroot()
    assert suite.get("tests") == "4" and suite.get("failures") == "0"


@pytest.mark.slow
def test_a_conveyor_moved_2cm_fails_the_views_that_see_it_and_is_named(baseline, tmp_path):
    moved = edited_scene(tmp_path, "moved", CONVEYOR_LINE, "translate = [-5.78, -2.5, 0.0]")
    result = check(moved, baseline.folder, tmp_path / "report")
    failed = {v.name for v in result.changed}
    seeing = {v.name for v in baseline.views if shows(baseline, v.name, "conveyor") > 0}
    assert "machine" not in seeing and failed == seeing == {"conveyor", "robot", "overview"}
    overview = next(v for v in result.changed if v.name == "overview")
    assert all(m.passed for m in overview.modes) and not overview.geometry_passed  # FLIP lets 2 cm pass there
    for view in result.changed:
        assert view.elements[0].part == "conveyor", view.elements[:3]
    report = (tmp_path / "report" / "report.html").read_text()
    assert "conveyor" in report and "3 of 4 view(s) changed" in report
    suite = ET.parse(tmp_path / "report" / "junit.xml").getroot()
    failures = {c.get("name"): c.find("failure") for c in suite.iter("testcase")}
    assert failures["robot"] is not None and "conveyor" in failures["robot"].text
    assert failures["machine"] is None


@pytest.mark.slow
def test_a_colour_change_of_one_part_is_found_and_named(baseline, tmp_path):
    red = edited_scene(tmp_path, "red", CABINET_COLOUR, "color = [0.8, 0.2, 0.2]")
    result = check(red, baseline.folder, tmp_path / "report")
    seeing = {v.name for v in baseline.views if shows(baseline, v.name, "control_cabinet") > 0}
    assert "machine" in seeing and {v.name for v in result.changed} == seeing
    for view in result.changed:
        assert view.elements[0].part == "control_cabinet", view.elements[:3]


@pytest.mark.slow
def test_bad_input_exits_2_with_one_line(tmp_path, baseline):
    cli = [sys.executable, "-m", "mrcheck.cli", "regress", "check", str(sample_scene_path())]
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "baseline.json").write_text('{"format": 1}')
    for folder, message in ((tmp_path / "none", "baseline folder not found"), (broken, "malformed baseline")):
        done = subprocess.run(
            [*cli, "--baseline", str(folder), "-o", str(tmp_path / "r")], capture_output=True, text=True
        )
        assert done.returncode == 2 and message in done.stderr and len(done.stderr.splitlines()) == 1, done.stderr
    # relative paths, as a CI script writes them: the same folder all the same
    done = subprocess.run(
        [*cli, "--baseline", "baseline", "-o", "./baseline/"],
        cwd=baseline.folder.parent,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2 and "the report folder is the baseline folder" in done.stderr


@pytest.mark.slow
def test_a_baseline_edited_or_incomplete_is_refused_before_rendering(baseline, tmp_path):
    from mrcheck.core.errors import MrcheckError
    from mrcheck.core.images import read_image
    from mrcheck.core.output import write_image

    edited = tmp_path / "edited"
    shutil.copytree(baseline.folder, edited)
    image = read_image(edited / "robot_vector.png")
    image[0, 0] ^= 1  # one bit of one pixel, as a lossy re-encoding would change many
    write_image(edited / "robot_vector.png", image)
    with pytest.raises(MrcheckError, match="pixels differ from their hash in baseline.json"):
        check(sample_scene_path(), edited, tmp_path / "r1")
    (edited / "overview_ids.npz").unlink()
    with pytest.raises(MrcheckError, match="baseline file overview_ids.npz named in baseline.json is missing"):
        check(sample_scene_path(), edited, tmp_path / "r2")
    assert not (tmp_path / "r2").exists()  # refused before any output


def test_attribution_names_the_nearer_element_where_the_two_renders_differ():
    """A part moved one pixel right over the floor: the pixels it left and the ones it covers
    are the part's, not the floor's; a pixel of the same element in both is that element's."""
    labels = np.array([["floor", "floor", "", ""], ["box", "box", "", ""]])
    ids_before = np.zeros((1, 4), np.int32)
    ids_before[0, 1] = 1
    ids_now = np.zeros((1, 4), np.int32)
    ids_now[0, 2] = 1
    depth_before = np.where(ids_before == 1, 2.0, 5.0).astype(np.float32)
    depth_now = np.where(ids_now == 1, 2.0, 5.0).astype(np.float32)
    changed = np.array([[False, True, True, True]])
    found = attribute(changed, IdBuffer(ids_before, depth_before, labels), IdBuffer(ids_now, depth_now, labels))
    assert [(e.part, e.pixels) for e in found] == [("box", 2), ("floor", 1)]


@pytest.mark.slow
def test_views_rendered_by_local_workers_are_the_views_rendered_here(tmp_path):
    """Two spawned workers (the export's pool: each with its own EGL context and
    LP_NUM_THREADS=1) record the same pixels as this process, in the order asked for. (A Dask
    cluster runs the same tasks: checked by hand with a LocalCluster of 2 workers, docs/regress.md.)"""
    views = ["robot,conveyor"]
    here = record(sample_scene_path(), tmp_path / "here", views, size=(320, 240))
    there = record(sample_scene_path(), tmp_path / "there", views, size=(320, 240), workers=2)
    assert [v.name for v in there.views] == ["robot", "conveyor"]
    assert [v.hashes for v in there.views] == [v.hashes for v in here.views]


def test_camera_file_views_are_named_after_their_file_and_names_must_differ(tmp_path):
    from mrcheck.apps.regress.views import resolve_views
    from mrcheck.core.errors import MrcheckError
    from mrcheck.scene.model import Scene

    camera = Camera.from_look_at([0, -5, 1.7], [0, 0, 1], [0, 0, 1], 50.0, 64, 48)
    shot = write_camera(tmp_path / "hall_walk_3" / "SHOT.json", camera)
    plain = write_camera(tmp_path / "north gate.json", camera)
    scene = Scene("empty", tmp_path / "scene.toml", [])
    views = resolve_views(scene, [f"{shot},{plain}"], 32, 24)
    assert [(name, cam.width, cam.height) for name, cam in views] == [("hall_walk_3", 32, 24), ("north_gate", 32, 24)]
    with pytest.raises(MrcheckError, match="two views named 'north_gate'"):
        resolve_views(scene, [str(plain), str(plain)], 32, 24)
    with pytest.raises(MrcheckError, match="no viewpoints"):
        resolve_views(scene, [], 32, 24)
