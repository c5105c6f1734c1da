"""The one exception type the command line turns into ``error: ...`` and a non-zero exit.

Anything a user can cause (a bad file, a bad option, a scene the camera sits inside) raises
:class:`MrcheckError` with a one-line message that names the file and the problem. Anything
else is a bug and keeps its traceback.

File names that are not valid UTF-8 (Linux allows any bytes but ``/`` and NUL) reach Python as
``str`` with surrogate escapes (:pep:`383`: byte 0xFC is ``'\\udcfc'``), which no UTF-8 output
can encode. :func:`display` shows each such byte as ``\\xfc`` (``Halle_S\\xfcd.png``), as the
shell and ``ls -b`` do; messages, warnings and human-readable files use it.
"""

import codecs
import errno
import warnings

DISPLAY_ERRORS = "mrcheck.display"  # the codec error handler of display(), for streams and encode()


def _display_errors(exc: UnicodeError):
    """Undecodable bytes of a file name (surrogate escapes U+DC80..U+DCFF) as ``\\xNN``, any
    other character the codec cannot encode as ``\\uNNNN``."""
    if not isinstance(exc, UnicodeEncodeError):
        raise exc
    chars = exc.object[exc.start : exc.end]
    return "".join(
        f"\\x{ord(c) - 0xDC00:02x}" if 0xDC80 <= ord(c) <= 0xDCFF else f"\\u{ord(c):04x}" for c in chars
    ), exc.end


codecs.register_error(DISPLAY_ERRORS, _display_errors)


def display(text) -> str:
    """``text`` (a message, a path) printable on any UTF-8 output: a file name's undecodable
    bytes shown as ``\\xNN``; anything else unchanged."""
    text = str(text)
    return text if text.isascii() else text.encode("utf-8", DISPLAY_ERRORS).decode("utf-8")


# what an OSError's errno means for an input file, in the words a planner reads
_REASONS = {
    errno.ENOENT: "not found",
    errno.ELOOP: "symlink loop (the link leads back to itself, directly or through other links)",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EISDIR: "is a folder, not a file",
    errno.ENOTDIR: "not found (a folder on its path is a file)",
    errno.ENAMETOOLONG: "file name too long",
    errno.EIO: "input/output error (a failing disk or a disconnected network share?)",
}


def os_reason(exc: OSError) -> str:
    """The problem of an OSError on a file, without the file name (the message names it once)."""
    reason = _REASONS.get(exc.errno) if exc.errno is not None else None
    return reason or exc.strerror or " ".join(str(exc).split()) or type(exc).__name__


class MrcheckError(Exception):
    """A user-facing error: one line, naming the file (when there is one) and the problem."""

    def __init__(self, message: str, path=None):
        self.path = path  # the file the message names, if any (a caller may add its own)
        message = " ".join(str(message).split())  # one line, always
        self.problem = display(message)  # the message without the file's name (a caller's list names it)
        if path is not None:
            message = f"{path}: {message}"
        super().__init__(display(message))


class MrcheckWarning(UserWarning):
    """Something the user should hear about that does not stop the work (a photo skipped, parts
    without units). The command line prints each as one ``warning: MESSAGE`` line on stderr
    (:func:`mrcheck.cli.messages.warning_lines`); code below the CLI never prints."""


def warn(message: str, path=None) -> None:
    """Warn the user (:class:`MrcheckWarning`): ``PATH: message`` when a file is named, one line."""
    # not display()ed here: the CLI's stderr shows a name's undecodable bytes as \xNN itself
    warnings.warn(f"{path}: {message}" if path is not None else str(message), MrcheckWarning, stacklevel=2)


def bug_reason(exc: BaseException) -> str:
    """An unexpected exception (a bug, not bad input) as one line for "internal error, please
    report it: ...": its type and at most 300 characters of its message."""
    return display(f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}")


__all__ = ["MrcheckError", "MrcheckWarning", "warn", "bug_reason", "display", "os_reason", "DISPLAY_ERRORS"]
