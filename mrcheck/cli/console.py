"""What the commands show on the console of what the code below them reports.

* a :class:`~mrcheck.core.errors.MrcheckWarning`: one ``warning: MESSAGE`` line on stderr, every
  time (:func:`mrcheck.cli.messages.warning_lines`);
* records of the ``mrcheck`` logger (a server's console: ``mrcheck.review``): ``LEVEL: MESSAGE``
  on stderr, ``error: ...`` for an error;
* progress: :class:`ProgressStream`, stderr for tqdm bars that a closed reader cannot stop.
"""

from __future__ import annotations

import contextlib
import logging
import sys

from mrcheck.cli.messages import warning_lines


def _line(text: str) -> None:
    """One line on the stderr of now (a test's captured one too)."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (BrokenPipeError, ValueError):   # nobody reads stderr any more: the work goes on
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
            except (BrokenPipeError, ValueError):   # ValueError: the stream itself was closed
                self.closed_reader = True

    def write(self, text: str) -> None:
        self._try(lambda: self.stream.write(text))

    def flush(self) -> None:
        self._try(self.stream.flush)

    def isatty(self) -> bool:
        return not self.closed_reader and self.stream.isatty()
