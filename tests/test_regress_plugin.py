"""The pytest plugin of ``mrcheck regress`` (``mrcheck_snapshot``), run on a made-up planning
repo with pytester, in this process (its ``pytest11`` entry point, or ``-p mrcheck.apps.regress.pytest_plugin``
where the installed metadata predates it).

One view of the sample cell at 320x240: generate, check the same scene (passes), check the
scene with its conveyor moved 20 cm (fails, naming the view and the conveyor)."""

from __future__ import annotations

import importlib.metadata
import shutil

# pytester's in-process runs drop the modules a run imported; Open3D and FLIP's C++ extensions
# cannot be imported twice in one process, so they are imported here, before any run
import flip_evaluator  # noqa: F401
import open3d  # noqa: F401
import pytest

import mrcheck.apps.regress.run  # noqa: F401
from mrcheck.apps.regress.pytest_plugin import snapshot_key
from mrcheck.core.resources import sample_scene_path

pytest_plugins = ("pytester",)


def plugin_args() -> tuple[str, ...]:
    """``-p`` the plugin unless its entry point loads it already (an installed mrcheck whose
    metadata has it): a second registration under the module's name would be refused."""
    names = {ep.name for ep in importlib.metadata.entry_points(group="pytest11")}
    return () if "mrcheck_regress" in names else ("-p", "mrcheck.apps.regress.pytest_plugin")


PLUGIN = plugin_args()
TEST_FILE = """
def test_cell(mrcheck_snapshot):
    mrcheck_snapshot("cell/scene.toml", view="conveyor", size=(320, 240))
"""


def test_snapshot_keys_are_file_names():
    assert snapshot_key("tests/test_hall.py::test_hall", 1) == "test_hall"
    assert snapshot_key("t.py::TestHall::test_views[aisle/1]", 2) == "TestHall.test_views_aisle_1_2"


def test_without_its_options_a_snapshot_is_skipped(pytester):
    pytester.makepyfile(TEST_FILE)
    result = pytester.runpytest(*PLUGIN, "-ra")
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["*give --mrcheck-baseline DIR or --mrcheck-generate DIR*"])


@pytest.mark.slow
def test_generate_then_check_passes_and_a_moved_conveyor_fails(pytester):
    shutil.copytree(sample_scene_path().parent, pytester.path / "cell")
    pytester.makepyfile(TEST_FILE)
    base, report = pytester.path / "baseline", pytester.path / "report"
    pytester.runpytest(*PLUGIN, "--mrcheck-generate", str(base)).assert_outcomes(passed=1)
    assert (base / "test_cell" / "baseline.json").is_file()
    pytester.runpytest(*PLUGIN, "--mrcheck-baseline", str(base)).assert_outcomes(passed=1)

    manifest = pytester.path / "cell" / "scene.toml"
    manifest.write_text(manifest.read_text().replace("translate = [-5.8, -2.5, 0.0]", "translate = [-5.6, -2.5, 0.0]"))
    result = pytester.runpytest(*PLUGIN, "--mrcheck-baseline", str(base), "--mrcheck-report", str(report))
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*CHANGED  conveyor:*elements: conveyor*"])
    assert (report / "test_cell" / "report.html").is_file()
    assert 'href="test_cell/report.html"' in (report / "index.html").read_text()


def test_a_missing_baseline_fails_the_test_with_the_command_to_record_it(pytester):
    pytester.makepyfile(TEST_FILE)
    result = pytester.runpytest(*PLUGIN, "--mrcheck-baseline", str(pytester.path / "none"))
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["*no baseline*record it with --mrcheck-generate DIR*"])


def test_the_plugin_imports_no_renderer():
    """Every pytest run of an environment with mrcheck loads the plugin: it must not pull in
    numpy, GL, Open3D or FLIP (checked in a fresh interpreter)."""
    import subprocess
    import sys

    code = (
        "import sys, mrcheck.apps.regress.pytest_plugin; "
        "print(sorted(m for m in ('numpy', 'moderngl', 'open3d', 'flip_evaluator', 'cv2') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]", done.stdout
