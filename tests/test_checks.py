"""The static checks configured in pyproject.toml, run as a contributor runs them:

* ``ruff check``: pycodestyle, pyflakes, import order, and no ``print`` below the command line (T20);
* ``ruff format --check``: the tree is formatted;
* ``mypy``: ``mrcheck/core``, ``scene`` and ``render`` type-check (``[tool.mypy]``: ``files``,
  ``check_untyped_defs``, ``warn_unused_ignores``).

Each passes on the tree, and each fails on a module written to break it, checked with the same
configuration (a copy of pyproject.toml beside the bad module, or ``--config-file``).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

# mypy runs of 2-3 s each: slow by tests/conftest.py's rule (./bootstrap.sh check runs the tree's checks anyway)
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parent.parent
PYPROJECT = REPO / "pyproject.toml"


def _tool(name: str) -> str:
    """The executable ``name`` of the environment running the tests (beside its python), else on PATH."""
    beside = Path(sys.executable).with_name(name)
    found = str(beside) if beside.exists() else shutil.which(name)
    if found is None:
        pytest.fail(f"{name} not found beside {sys.executable} or on PATH: install the test extra")
    return found


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=300)


def _project(tmp_path: Path, files: dict[str, str]) -> Path:
    """A project in ``tmp_path`` with the repository's pyproject.toml and ``files`` (path: text)."""
    shutil.copy(PYPROJECT, tmp_path / "pyproject.toml")
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tmp_path


# -- the tree passes -------------------------------------------------------------------------------
def test_ruff_lint_passes_on_the_tree():
    run = _run([_tool("ruff"), "check", "--no-cache", "."], REPO)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_the_tree_is_formatted():
    run = _run([_tool("ruff"), "format", "--check", "--no-cache", "."], REPO)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]


def test_mypy_passes_on_the_configured_packages():
    """A bare ``mypy`` checks what ``[tool.mypy] files`` names: core, scene and render at least."""
    run = _run([_tool("mypy")], REPO)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert run.stdout.startswith("Success: no issues found"), run.stdout
    checked = int(run.stdout.split(" in ")[1].split()[0])
    expected = sum(1 for package in ("core", "scene", "render") for _ in (REPO / "mrcheck" / package).rglob("*.py"))
    assert checked >= expected, f"mypy checked {checked} files, core, scene and render hold {expected}"


# -- a bad module fails each -----------------------------------------------------------------------
def test_ruff_refuses_a_print_below_the_command_line(tmp_path):
    """T20 with the per-file ignores: a print in a library module fails, the same print in the
    command line's package passes (and so the failure is the print, not something else)."""
    printing = 'def report(value):\n    print("value", value)\n'
    project = _project(tmp_path, {"mrcheck/render/bad.py": printing, "mrcheck/cli/fine.py": printing})
    bad = _run([_tool("ruff"), "check", "--no-cache", "mrcheck/render/bad.py"], project)
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "T201" in bad.stdout and "mrcheck/render/bad.py:2:5" in bad.stdout, bad.stdout
    fine = _run([_tool("ruff"), "check", "--no-cache", "mrcheck/cli/fine.py"], project)
    assert fine.returncode == 0, fine.stdout + fine.stderr


def test_ruff_refuses_an_unused_import(tmp_path):
    project = _project(tmp_path, {"mrcheck/core/bad.py": "import os\n"})
    run = _run([_tool("ruff"), "check", "--no-cache", "mrcheck/core/bad.py"], project)
    assert run.returncode == 1 and "F401" in run.stdout, run.stdout + run.stderr


def test_the_format_check_refuses_an_unformatted_module(tmp_path):
    """Badly formatted code fails ``ruff format --check``; the same code formatted passes."""
    project = _project(
        tmp_path,
        {
            "mrcheck/core/bad.py": "x = {  'a':1 }\ndef f( y ) :\n  return y\n",
            "mrcheck/core/good.py": 'x = {"a": 1}\n\n\ndef f(y):\n    return y\n',
        },
    )
    bad = _run([_tool("ruff"), "format", "--check", "--no-cache", "mrcheck/core/bad.py"], project)
    assert bad.returncode == 1 and "bad.py" in bad.stdout, bad.stdout + bad.stderr
    good = _run([_tool("ruff"), "format", "--check", "--no-cache", "mrcheck/core/good.py"], project)
    assert good.returncode == 0, good.stdout + good.stderr


def test_mypy_refuses_type_errors_with_the_projects_settings(tmp_path):
    """An annotated function returning the wrong type, an unannotated one assigning a str to an
    int (reported only with check_untyped_defs) and an ignore that hides nothing (reported only
    with warn_unused_ignores): each is an error under the project's configuration."""
    bad = tmp_path / "bad_module.py"
    bad.write_text(
        "def annotated() -> int:\n"
        '    return "one"\n'
        "\n"
        "\n"
        "def untyped():\n"
        '    count: int = "two"\n'
        "    return count\n"
        "\n"
        "\n"
        "value: int = 3  # type: ignore[assignment]\n"
    )
    run = _run(
        [_tool("mypy"), "--config-file", str(PYPROJECT), "--cache-dir", str(tmp_path / "cache"), str(bad)], tmp_path
    )
    assert run.returncode == 1, run.stdout + run.stderr
    for line in (2, 6, 10):
        assert f"bad_module.py:{line}: error" in run.stdout, run.stdout
    assert "Found 3 errors in 1 file" in run.stdout, run.stdout
