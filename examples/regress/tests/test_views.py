"""The agreed views of the hall as pytest tests (mrcheck's pytest plugin, installed with mrcheck):

    pytest tests/ --mrcheck-generate baseline-pytest/          # once, from the agreed revision
    MODEL=model/rev2/scene.toml pytest tests/ --mrcheck-baseline baseline-pytest/ --mrcheck-report report-pytest/

One test per view, so the CI's test tab names each view that changed; the failure message names
the elements under the changed pixels, report-pytest/index.html links every view's report.
"""

import os

import pytest

MODEL = os.environ.get("MODEL", "model/rev1/scene.toml")  # relative to the repo's root (pytest's cwd)


@pytest.mark.parametrize("view", ["aisle", "line", "racks"])
def test_agreed_view(mrcheck_snapshot, view):
    mrcheck_snapshot(MODEL, view=view)
