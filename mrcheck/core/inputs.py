"""Checking and reading input files, with one-line errors that say what is wrong with the path.

Every input file goes through :func:`check_input` before a reader (trimesh, Open3D, OpenCV,
json) sees it, or through :func:`read_input` when its bytes are read here. ``Path.exists()``
and ``is_file()`` answer False for a symlink loop, a folder that cannot be searched or a
broken link alike, and a reader's own error for such a path is "not found" at best; a FIFO or
a device would block a reader forever. ``os.stat`` says which it is.

Paths may be ``str`` with surrogate escapes (a file name that is not valid UTF-8); Python's
file API takes them as they are, and messages show them with :func:`mrcheck.core.errors.display`.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from mrcheck.core.errors import MrcheckError, os_reason

# st_mode kinds that are not regular files, as ls -l would call them
_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def check_input(path, what: str = "file", folder_ok: bool = False) -> os.stat_result:
    """The ``os.stat`` of an input file, or MrcheckError naming ``path`` and the problem:
    "{what} not found" (a broken symlink says where it points), a symlink loop, permission
    denied, "{what} is a folder, not a file" (unless ``folder_ok``), not a regular file."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise MrcheckError(_stat_problem(path, what, exc), path) from None
    if stat.S_ISDIR(st.st_mode):
        if folder_ok:
            return st
        raise MrcheckError(f"{what} is a folder, not a file", path)
    if not stat.S_ISREG(st.st_mode):
        kind = next((name for test, name in _KINDS if test(st.st_mode)), "something else")
        raise MrcheckError(f"{what} is not a regular file but {kind}", path)
    if not os.access(path, os.R_OK):  # said here, in these words, whichever library would read it
        raise MrcheckError(f"cannot read {what}: permission denied", path)
    return st


def _stat_problem(path, what: str, exc: OSError) -> str:
    if exc.errno == errno.ENOTDIR:
        return f"{what} not found (a folder on its path is a file)"
    if exc.errno == errno.ENOENT:
        try:
            target = os.readlink(path)
        except OSError:
            return f"{what} not found"
        return f"{what} not found (a symlink to {target}, which does not exist)"
    return f"cannot read {what}: {os_reason(exc)}"


def read_input(path, what: str = "file", empty_ok: bool = False) -> bytes:
    """The bytes of an input file (checked by :func:`check_input`); an empty file is an error
    unless ``empty_ok``: "{what} is empty (0 bytes)"."""
    check_input(path, what)
    try:
        with open(path, "rb") as handle:
            data = handle.read()
    except OSError as exc:
        raise MrcheckError(_stat_problem(path, what, exc), path) from None
    if not data and not empty_ok:
        raise MrcheckError(f"{what} is empty (0 bytes)", path)
    return data


def read_input_text(path, what: str = "file", encoding: str = "utf-8") -> str:
    """The text of an input file (:func:`read_input`); a file that is not text in ``encoding``
    is an error naming the byte offset."""
    data = read_input(path, what)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise MrcheckError(
            f"cannot read {what}: not {encoding.upper().removesuffix('-SIG')} text (byte "
            f"0x{data[exc.start]:02x} at offset {exc.start})",
            path,
        ) from None


def real_path(path) -> Path:
    """The absolute path of ``path`` with its symlinks resolved as far as they go: unlike
    ``Path.resolve()`` (Python 3.11), a symlink loop is no RuntimeError, and is left for
    :func:`check_input` to report."""
    return Path(os.path.realpath(path))


__all__ = ["check_input", "read_input", "read_input_text", "real_path"]
