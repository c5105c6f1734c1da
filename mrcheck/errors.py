"""The one exception type the command line turns into ``error: ...`` and a non-zero exit.

Anything a user can cause (a bad file, a bad option, a scene the camera sits inside) raises
:class:`MrcheckError` with a one-line message that names the file and the problem. Anything
else is a bug and keeps its traceback.
"""


class MrcheckError(Exception):
    """A user-facing error: one line, naming the file (when there is one) and the problem."""

    def __init__(self, message: str, path=None):
        self.path = path  # the file the message names, if any (a caller may add its own)
        message = " ".join(str(message).split())  # one line, always
        if path is not None:
            message = f"{path}: {message}"
        super().__init__(message)


def bug_reason(exc: BaseException) -> str:
    """An unexpected exception (a bug, not bad input) as one line for "internal error, please
    report it: ...": its type and at most 300 characters of its message."""
    return f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"


__all__ = ["MrcheckError", "bug_reason"]
