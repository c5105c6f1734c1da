"""The lock files ``bootstrap.sh`` installs from (docs/dependencies.md): every requirement of
pyproject.toml, each extra and the build backend pinned within its range, with hashes, and the
default set-up's lock the bench lock's versions. A dependency edited in pyproject.toml without
``./bootstrap.sh lock`` fails here, not on a fresh machine."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parent.parent
LOCK = ROOT / "requirements.lock"
BENCH_LOCK = ROOT / "requirements-bench.lock"
DEFAULT_EXTRAS = ("test", "review", "cluster")  # what bootstrap.sh installs from requirements.lock

PIN = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+)")


def pins(text: str) -> dict[str, set[str]]:
    """Package name -> the versions pinned for it (more than one where markers fork by Python)."""
    found: dict[str, set[str]] = {}
    for line in text.splitlines():
        if match := PIN.match(line):
            found.setdefault(canonicalize_name(match[1]), set()).add(match[2])
    return found


def requirements(pyproject: dict, extras) -> list[Requirement]:
    listed = pyproject["project"]["dependencies"] + pyproject["build-system"]["requires"]
    for extra in extras:
        listed += pyproject["project"]["optional-dependencies"][extra]
    return [Requirement(r) for r in listed]


def unmet(pyproject: dict, extras, lock_text: str) -> list[str]:
    """The requirements the lock does not pin, or pins outside their range."""
    locked = pins(lock_text)
    problems = []
    for req in requirements(pyproject, extras):
        versions = locked.get(canonicalize_name(req.name), set())
        if not versions or not all(req.specifier.contains(v, prereleases=True) for v in versions):
            problems.append(f"{req} (locked: {', '.join(sorted(versions)) or 'none'})")
    return problems


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_locks_pin_every_requirement_within_its_range():
    project = pyproject()
    every_extra = tuple(project["project"]["optional-dependencies"])
    assert set(DEFAULT_EXTRAS) < set(every_extra)
    assert unmet(project, every_extra, BENCH_LOCK.read_text()) == [], "run ./bootstrap.sh lock --keep"
    assert unmet(project, DEFAULT_EXTRAS, LOCK.read_text()) == [], "run ./bootstrap.sh lock --keep"


def test_a_requirement_the_lock_does_not_meet_is_named():
    project = pyproject()
    project["project"]["dependencies"] = [*project["project"]["dependencies"], "numpy>=3", "not-a-locked-package"]
    (numpy,) = pins(LOCK.read_text())["numpy"]
    assert unmet(project, (), LOCK.read_text()) == [
        f"numpy>=3 (locked: {numpy})",
        "not-a-locked-package (locked: none)",
    ]


def test_the_default_lock_is_the_bench_lock_without_the_bench_extra():
    default, bench = pins(LOCK.read_text()), pins(BENCH_LOCK.read_text())
    assert {name: bench.get(name) for name in default} == default
    assert "pyvista" in bench and "pyvista" not in default


def test_every_pin_has_hashes():
    """pip installs a lock with --require-hashes only when every file's hash is listed."""
    for lock in (LOCK, BENCH_LOCK):
        entries = [entry for entry in re.split(r"\n(?=\S)", lock.read_text()) if PIN.match(entry)]
        assert len(entries) > 100 and all("--hash=sha256:" in entry for entry in entries), lock.name
