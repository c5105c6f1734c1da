"""Keeping C and C++ libraries quiet: what they print goes to the file descriptors, past Python.

OpenCV's codecs print ``[ WARN:0@0.05] global grfmt_png.cpp:793 ...`` lines, libpng
``libpng error: ...`` and libjpeg ``Corrupt JPEG data: ...`` straight to stderr; Open3D's PLY
reader (RPly) reports a corrupt file only by printing. :func:`native_output` points the file
descriptors at a temporary file while such a call runs and hands back what was printed, for
the caller to turn into its own one-line message (or drop).

Redirecting a descriptor is process-wide: the calls are serialised by one lock, and whatever
another thread writes to the same descriptor meanwhile is captured too (the decoders run for
milliseconds; no thread of mrcheck prints while another decodes).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
import threading

_LOCK = threading.RLock()
_COLOURS = re.compile(r"\x1b\[[0-9;]*m")  # Open3D colours its warnings


def _flush(stream) -> None:
    try:
        stream.flush()
    except Exception:  # noqa: BLE001 -- None, a closed pipe or stream: whatever it is, no reason to fail a read
        pass


@contextlib.contextmanager
def native_output(fds=(2,), python: bool = False):
    """Capture what is written to the file descriptors ``fds`` (1 stdout, 2 stderr) inside the
    block, and with ``python`` what Python code writes to sys.stdout/sys.stderr too; yields a
    list that holds the captured lines (colour codes removed) once the block has ended."""
    lines: list[str] = []
    printed = io.StringIO()
    with _LOCK, tempfile.TemporaryFile() as log, contextlib.ExitStack() as stack:
        for stream in (sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__):
            _flush(stream)  # what Python wrote before goes where it was meant to
        if python:
            stack.enter_context(contextlib.redirect_stdout(printed))
            stack.enter_context(contextlib.redirect_stderr(printed))
        saved = []
        try:
            for fd in fds:
                try:
                    saved.append((fd, os.dup(fd)))
                except OSError:  # not open (a daemon's closed stderr): nothing to keep quiet there
                    continue
                os.dup2(log.fileno(), fd)
            yield lines
        finally:
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            log.seek(0)
            text = log.read().decode("utf-8", "replace") + printed.getvalue()
            lines += [line for line in (_COLOURS.sub("", raw).strip() for raw in text.splitlines()) if line]


__all__ = ["native_output"]
