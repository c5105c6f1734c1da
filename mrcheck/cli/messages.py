"""How the command line shows what the code below it reports: warnings as ``warning: ...`` lines.

Code below ``mrcheck/cli/`` never prints. It warns with :func:`mrcheck.core.errors.warn` (a
:class:`~mrcheck.core.errors.MrcheckWarning`); while a command runs, :func:`warning_lines` turns
each one into a line ``warning: MESSAGE`` on stderr, written with ``tqdm.write`` so that it lands
on a line of its own above a progress bar, never inside the bar's line. Every warning is shown,
also one repeated word for word (Python's default shows a warning once per place).
"""

from __future__ import annotations

import contextlib
import logging
import sys
import warnings
from contextlib import contextmanager

import click

from mrcheck.core.errors import MrcheckWarning


def warning_line(text: str) -> None:
    """``warning: TEXT`` on stderr, on a line of its own (above a progress bar, if one runs)."""
    from tqdm import tqdm

    try:
        tqdm.write(f"warning: {text}", file=sys.stderr)
    except (BrokenPipeError, ValueError):  # nobody reads stderr any more: the work goes on
        pass


@contextlib.contextmanager
def warning_lines():
    """While the block runs, every :class:`MrcheckWarning` is a ``warning: ...`` line on stderr;
    other warnings (a library's) are shown as Python shows them."""
    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, MrcheckWarning):
            warning_line(str(message))
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter("always", MrcheckWarning)
        warnings.showwarning = show
        yield


def progress_bar(items, desc: str, unit: str):
    """A :data:`mrcheck.core.progress.Progress` for the terminal: a tqdm bar on stderr while the
    items are worked through, erased when done or on an error (leave=False; the caller closes
    it), no bar when stderr is not a terminal (disable=None: pipes, logs, tests), and none for
    work done within half a second (delay)."""
    from tqdm import tqdm

    with tqdm(items, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False, delay=0.5) as bar:
        yield from bar


def echo_lines(lines, err: bool = False) -> None:
    """Each of ``lines`` on stdout (``err``: stderr)."""
    for line in lines:
        click.echo(line, err=err)


# -- log records (a server's console) and the export's stream --------------------------------
def _line(text: str) -> None:
    """One line on the stderr of now (a test's captured one too)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (BrokenPipeError, ValueError):  # nobody reads stderr any more: the work goes on
        pass


class _Lines(logging.Handler):
    """A log record as ``LEVEL: MESSAGE``."""

    def emit(self, record) -> None:
        _line(f"{record.levelname.lower()}: {self.format(record)}")


@contextlib.contextmanager
def console():
    """Show mrcheck's warnings (:func:`mrcheck.cli.messages.warning_lines`) and log records as
    lines on stderr while the block runs."""
    logger, handler = logging.getLogger("mrcheck"), _Lines()
    logger.addHandler(handler)
    level, logger.level = logger.level, logging.INFO
    try:
        with warning_lines():
            yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


class ProgressStream:
    """stderr for the progress bar and lines, which a closed reader cannot stop: with
    ``mrcheck export ... 2>&1 | head`` the export still finishes and writes its manifest and
    report (the bar's writes fail with EPIPE and are dropped from then on)."""

    def __init__(self, stream):
        self.stream, self.closed_reader = stream, False

    def _try(self, call) -> None:
        if not self.closed_reader:
            try:
                call()
            except (BrokenPipeError, ValueError):  # ValueError: the stream itself was closed
                self.closed_reader = True

    def write(self, text: str) -> None:
        self._try(lambda: self.stream.write(text))

    def flush(self) -> None:
        self._try(self.stream.flush)

    def isatty(self) -> bool:
        return not self.closed_reader and self.stream.isatty()


# -- progress(stage, done, total) callbacks as bars --------------------------------------------
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
            bar = self._bars[stage] = tqdm(
                total=total,
                desc=stage,
                unit=self.units.get(stage, "it"),
                unit_scale=True,
                file=sys.stderr,
                disable=None,
            )
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


__all__ = [
    "warning_lines",
    "warning_line",
    "progress_bar",
    "echo_lines",
    "console",
    "ProgressStream",
    "ProgressBars",
    "progress_bars",
]
