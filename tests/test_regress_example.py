"""examples/regress/, the planning repo of docs/regress.md, run as its README says: the
baseline recorded from rev1, its check of rev1 (passes; in this process, to save a start-up)
and its ci.sh on rev2 (exit 1, naming conveyor
CV-02 by its GlobalId first, and passing the racks view, which sees neither change), and its
pytest file through mrcheck's plugin."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import flip_evaluator  # noqa: F401  (before pytester's in-process run: see test_regress_plugin.py)
import open3d  # noqa: F401
import pytest

import mrcheck.apps.regress.run  # noqa: F401

from .test_regress_plugin import PLUGIN

pytest_plugins = ("pytester",)
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "regress"
CV02 = "conveyor 2CvA0000000000000000A2 (CV-02 IfcTransportElement)"


@pytest.fixture()
def repo(tmp_path) -> Path:
    """A copy of the example, and a `mrcheck` on PATH that is this checkout's."""
    copy = tmp_path / "repo"
    shutil.copytree(EXAMPLE, copy)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "mrcheck"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m mrcheck.cli "$@"\n')
    shim.chmod(0o755)
    return copy


def ci(repo: Path, model: str | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{repo.parent / 'bin'}{os.pathsep}{os.environ['PATH']}"}
    if model:
        env["MODEL"] = model
    return subprocess.run(["./ci.sh"], cwd=repo, env=env, capture_output=True, text=True, timeout=180)


@pytest.mark.slow
def test_ci_passes_on_the_agreed_revision_and_names_the_change_of_the_next(repo):
    assert ci(repo).returncode == 2  # no baseline yet: bad input, and the command to record it
    run = mrcheck.apps.regress.run
    run.record(repo / "model/rev1/scene.toml", repo / "baseline")
    assert run.check(repo / "model/rev1/scene.toml", repo / "baseline", repo / "report").passed  # ci.sh's check, here
    changed = ci(repo)
    assert changed.returncode == 1, changed.stdout + changed.stderr
    lines = {line.split()[1].rstrip(":"): line for line in changed.stdout.splitlines() if line[:2] in ("ok", "CH")}
    assert lines["racks"].startswith("ok")
    assert f"elements: {CV02}" in lines["line"]
    assert "SC-01 switch cabinet" in lines["aisle"] and CV02 in lines["aisle"]
    assert (repo / "report" / "junit.xml").is_file()


@pytest.mark.slow
def test_the_example_pytest_file_through_the_plugin(repo, pytester, monkeypatch):
    for item in repo.iterdir():
        shutil.move(str(item), pytester.path / item.name)
    plugin = (*PLUGIN, "tests/test_views.py", "-k", "line")
    pytester.runpytest(*plugin, "--mrcheck-generate", "baseline-pytest").assert_outcomes(passed=1, deselected=2)
    monkeypatch.setenv("MODEL", "model/rev2/scene.toml")
    result = pytester.runpytest(*plugin, "--mrcheck-baseline", "baseline-pytest")
    result.assert_outcomes(failed=1, deselected=2)
    result.stdout.fnmatch_lines([f"*CHANGED  line:*elements: {CV02}*"])
