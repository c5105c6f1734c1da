"""``mrcheck regress``: image regression tests of a model (issue 43).

Minimal group for the ``diff`` branch: only ``regress diff`` (:mod:`mrcheck.cli.regress_diff`);
``record`` and ``check`` join it when the two halves are merged.
"""

from __future__ import annotations

from mrcheck.cli.group import cli
from mrcheck.cli.regress_diff import diff


@cli.group()
def regress():
    """Image regression tests: compare two revisions of a model.

    \b
    Example:
      mrcheck regress diff week48.ifc week49.ifc -o diff49
    """


regress.add_command(diff)
