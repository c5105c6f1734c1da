"""The pytest plugin of ``mrcheck regress`` (entry point ``pytest11``: installed with mrcheck).

A planning repo writes::

    def test_hall(mrcheck_snapshot):
        mrcheck_snapshot("hall.ifc", view="aisle")

and runs ``pytest --mrcheck-generate baseline/`` once (records each test's views into
``baseline/TEST_NAME/``, as pytest-mpl's ``--mpl-generate-path``), then ``pytest
--mrcheck-baseline baseline/ --mrcheck-report report/`` in CI: each call renders the views
again and fails the test, naming the changed views and elements, when one is over tolerance;
``report/TEST_NAME/report.html`` shows it and ``report/index.html`` lists every test's report.
Without either option the snapshots are skipped (as pytest-mpl compares only with ``--mpl``).

Importing this module is cheap (pytest and the standard library): it is loaded in every pytest
run of an environment with mrcheck, mrcheck's own too; the renderer loads when a snapshot is taken.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

GENERATE = "--mrcheck-generate"
BASELINE = "--mrcheck-baseline"
REPORT = "--mrcheck-report"
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
_RESULTS = pytest.StashKey[list]()  # (test key, passed, report path) of every check in the session


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("mrcheck", "image regression tests of CAD views (mrcheck regress)")
    group.addoption(GENERATE, metavar="DIR", help="record each mrcheck_snapshot's views as the baseline DIR/TEST/")
    group.addoption(BASELINE, metavar="DIR", help="compare each mrcheck_snapshot with its baseline DIR/TEST/")
    group.addoption(
        REPORT,
        metavar="DIR",
        help="write each check's HTML report to DIR/TEST/ and DIR/index.html [default: a temporary folder]",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.stash[_RESULTS] = []


def snapshot_key(nodeid: str, count: int) -> str:
    """The baseline's sub-folder of a test: its node name made a file name (``test_hall``,
    ``test_views_aisle_``), and ``_2``, ``_3`` for its second and third snapshot."""
    name = _UNSAFE.sub("_", nodeid.split("::", 1)[-1].replace("::", ".")).strip("_") or "snapshot"
    return name if count == 1 else f"{name}_{count}"


class Snapshotter:
    """The ``mrcheck_snapshot`` fixture's value: call it with a scene and its views."""

    def __init__(self, request: pytest.FixtureRequest):
        self.request = request
        self.config = request.config
        self.calls = 0

    def _scene(self, scene) -> Path:
        """A relative scene path is looked for beside the test file first, as pytest-mpl's baselines are."""
        path = Path(scene)
        beside = Path(self.request.node.path).parent / path
        return beside if not path.is_absolute() and beside.exists() else path

    def __call__(self, scene, view=None, views=None, modes=("phong", "vector"), size=(640, 480), tolerances=None):
        """Record or check ``scene``'s ``view`` (a viewpoint name or camera file) or ``views``
        (a list of them; default: every viewpoint). Returns the baseline (generate) or the
        check's result (compare); fails the test when a view changed."""
        generate, baseline = self.config.getoption(GENERATE), self.config.getoption(BASELINE)
        if not generate and not baseline:
            pytest.skip(f"mrcheck image regression: give {BASELINE} DIR or {GENERATE} DIR")
        self.calls += 1
        key = snapshot_key(self.request.node.nodeid, self.calls)
        chosen = [view] if view is not None else list(views or [])
        from mrcheck.apps.regress.run import check, record
        from mrcheck.core.errors import MrcheckError

        try:
            if generate:
                return record(self._scene(scene), Path(generate) / key, chosen, modes, tuple(size))
            return self._check(check, self._scene(scene), Path(baseline) / key, key, tolerances)
        except MrcheckError as exc:
            pytest.fail(f"mrcheck: {exc}", pytrace=False)

    def _check(self, check, scene: Path, baseline: Path, key: str, tolerances):
        if not (baseline / "baseline.json").is_file():
            pytest.fail(f"mrcheck: no baseline {baseline} (record it with {GENERATE} DIR)", pytrace=False)
        report_root = self.config.getoption(REPORT)
        report = Path(report_root) / key if report_root else self.request.getfixturevalue("tmp_path") / "mrcheck-report"
        result = check(scene, baseline, report, tolerances)
        self.config.stash[_RESULTS].append((key, result.passed, result.report))
        if not result.passed:
            lines = [line for line in result.summary() if not line.startswith("ok")]
            pytest.fail("mrcheck: view(s) changed\n" + "\n".join(lines) + f"\nreport: {result.report}", pytrace=False)
        return result


@pytest.fixture
def mrcheck_snapshot(request: pytest.FixtureRequest) -> Snapshotter:
    """Record (``--mrcheck-generate DIR``) or check (``--mrcheck-baseline DIR``) a scene's views:
    ``mrcheck_snapshot("hall.ifc", view="aisle")``."""
    return Snapshotter(request)


def pytest_sessionfinish(session: pytest.Session) -> None:
    """``--mrcheck-report DIR``: DIR/index.html lists every check of the session and its report."""
    report_root = session.config.getoption(REPORT)
    results = session.config.stash.get(_RESULTS, [])
    if not report_root or not results:
        return
    from mrcheck.apps.regress.report import index_html
    from mrcheck.core.output import write_text

    write_text(Path(report_root) / "index.html", index_html(results, Path(report_root)))
