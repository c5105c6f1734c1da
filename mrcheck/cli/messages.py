"""How the command line shows what the code below it reports: warnings as ``warning: ...`` lines.

Code below ``mrcheck/cli/`` never prints. It warns with :func:`mrcheck.core.errors.warn` (a
:class:`~mrcheck.core.errors.MrcheckWarning`); while a command runs, :func:`warning_lines` turns
each one into a line ``warning: MESSAGE`` on stderr, written with ``tqdm.write`` so that it lands
on a line of its own above a progress bar, never inside the bar's line. Every warning is shown,
also one repeated word for word (Python's default shows a warning once per place).
"""

from __future__ import annotations

import contextlib
import sys
import warnings

import click

from mrcheck.core.errors import MrcheckWarning


def warning_line(text: str) -> None:
    """``warning: TEXT`` on stderr, on a line of its own (above a progress bar, if one runs)."""
    from tqdm import tqdm

    try:
        tqdm.write(f"warning: {text}", file=sys.stderr)
    except (BrokenPipeError, ValueError):   # nobody reads stderr any more: the work goes on
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
    it), no bar when stderr is not a terminal (disable=None: pipes, logs, tests)."""
    from tqdm import tqdm

    with tqdm(items, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False) as bar:
        yield from bar


def echo_lines(lines, err: bool = False) -> None:
    """Each of ``lines`` on stdout (``err``: stderr)."""
    for line in lines:
        click.echo(line, err=err)


__all__ = ["warning_lines", "warning_line", "progress_bar", "echo_lines"]
