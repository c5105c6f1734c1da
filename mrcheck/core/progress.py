"""Progress reporting without printing: long loops take a ``progress`` callback.

A :data:`Progress` is ``progress(items, desc, unit) -> generator``: it yields ``items`` one by
one and shows the progress however it likes (the command line: a tqdm bar on stderr, see
:func:`mrcheck.cli.messages.progress_bar`). The default, :func:`no_progress`, shows nothing.
The loop runs it inside ``contextlib.closing`` so that a bar is taken down on an error too,
before the error's line is printed.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Generator, Iterable
from typing import Any

# a generator, not any iterator: the loops close it (contextlib.closing)
Progress = Callable[[Iterable, str, str], Generator[Any, None, None]]


def no_progress(items: Iterable, desc: str = "", unit: str = "") -> Generator[Any, None, None]:
    """The items, showing nothing (a generator, so that ``contextlib.closing`` can close it)."""
    yield from items


# The display of the loops deep inside that no caller hands a callback to (loading a scene's
# parts, building levels of detail): threading one through every function that loads a scene
# would add a parameter to a dozen signatures for a bar. The command line sets it for the whole
# command (mrcheck.cli.main); a library caller sees nothing unless it sets one.
_SHOWN: contextvars.ContextVar[Progress] = contextvars.ContextVar("mrcheck_progress", default=no_progress)


def shown_progress() -> Progress:
    """The :data:`Progress` the caller installed with :func:`showing_progress` (default: none)."""
    return _SHOWN.get()


@contextlib.contextmanager
def showing_progress(progress: Progress):
    """While the block runs, :func:`shown_progress` is ``progress``."""
    token = _SHOWN.set(progress)
    try:
        yield
    finally:
        _SHOWN.reset(token)


__all__ = ["Progress", "no_progress", "shown_progress", "showing_progress"]
