"""File names for C++ libraries that take them as UTF-8 text (IfcOpenShell, OpenCascade, libE57).

Linux allows any bytes in a name, and Python gives a name that is not valid UTF-8 as ``str``
with surrogate escapes (:pep:`383`), which these bindings refuse ("incompatible function
arguments", "Wrong number or type of arguments"). Such a file is opened through a symlink of
an ASCII name in a private temporary folder; messages keep naming the file itself.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator


def _utf8(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


@contextlib.contextmanager
def utf8_name(path) -> Iterator[str]:
    """A name of ``path``'s file that encodes as UTF-8: the path itself when it does, else a
    symlink to it (same extension, libraries tell formats by it) for the ``with`` block."""
    text = os.fspath(path)
    if _utf8(text):
        yield text
        return
    suffix = os.path.splitext(text)[1]
    with tempfile.TemporaryDirectory(prefix="mrcheck-name-") as folder:
        link = os.path.join(folder, "file" + (suffix if _utf8(suffix) else ""))
        os.symlink(os.path.abspath(text), link)
        yield link


__all__ = ["utf8_name"]
