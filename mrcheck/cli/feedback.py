"""What the commands report while they work, turned into lines and bars on stderr.

The work below ``mrcheck/cli/`` never prints: it warns with ``warnings.warn(MrcheckWarning(...))``
and reports progress through a callback ``progress(stage, done, total)``. Here the CLI shows
each warning as one ``warning: ...`` line and each stage as a tqdm bar (on a terminal only).
"""

from __future__ import annotations

import sys
import warnings
from contextlib import contextmanager

import click

from mrcheck.core.errors import MrcheckWarning


@contextmanager
def warnings_as_lines():
    """Inside: every :class:`MrcheckWarning` is printed at once as ``warning: MESSAGE`` on
    stderr, each time it is raised (no "once per place" filter); other libraries' warnings are
    shown as Python shows them."""
    with warnings.catch_warnings():
        warnings.filterwarnings("always", category=MrcheckWarning)
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, MrcheckWarning):
                click.echo(f"warning: {message}", err=True)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


class ProgressBars:
    """A ``progress(stage, done, total)`` callback drawing one tqdm bar per stage on stderr;
    ``units`` names a stage's unit (``{"reference AO": "ray"}``; "it" otherwise). A bar closes
    when its stage is done; :meth:`close` closes any left open (the work failed)."""

    def __init__(self, units: dict | None = None):
        self.units = units or {}
        self._bars = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        from tqdm import tqdm

        bar = self._bars.get(stage)
        if bar is None:
            # disable=None: a bar on a terminal, nothing in a log or a pipe
            bar = self._bars[stage] = tqdm(total=total, desc=stage, unit=self.units.get(stage, "it"),
                                           unit_scale=True, file=sys.stderr, disable=None)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()
            del self._bars[stage]

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()
        self._bars.clear()


@contextmanager
def progress_bars(units: dict | None = None):
    """A :class:`ProgressBars` callback, closed on the way out."""
    bars = ProgressBars(units)
    try:
        yield bars
    finally:
        bars.close()


__all__ = ["warnings_as_lines", "ProgressBars", "progress_bars"]
