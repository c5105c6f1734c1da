"""Progress reporting without printing: long loops take a ``progress`` callback.

A :data:`Progress` is ``progress(items, desc, unit) -> iterator``: it yields ``items`` one by
one and shows the progress however it likes (the command line: a tqdm bar on stderr, see
:func:`mrcheck.cli.messages.progress_bar`). The default, :func:`no_progress`, shows nothing.
The loop runs it inside ``contextlib.closing`` so that a bar is taken down on an error too,
before the error's line is printed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

Progress = Callable[[Iterable, str, str], Iterator]


def no_progress(items: Iterable, desc: str = "", unit: str = "") -> Iterator:
    """The items, showing nothing (a generator, so that ``contextlib.closing`` can close it)."""
    yield from items


__all__ = ["Progress", "no_progress"]
