"""Reading a JSON input file with the one-line errors of :class:`mrcheck.core.errors.MrcheckError`."""

from __future__ import annotations

import json
import math
from pathlib import Path

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input_text


def read_json(path, what: str):
    """The parsed JSON of ``path``; ``what`` names the file's role in errors ("camera",
    "marker map"): "camera file not found", "malformed camera JSON: ... at line 3"; the path's
    own problems as :func:`mrcheck.core.inputs.read_input_text` says them ("symlink loop", "empty")."""
    path = Path(path)
    text = read_input_text(path, f"{what} file")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        # some of json's messages end in "at" already ("Invalid control character at")
        raise MrcheckError(f"malformed {what} JSON: {exc.msg.removesuffix(' at')} at line {exc.lineno}", path) from None


def number_problem(value) -> str | None:
    """Why a parsed JSON or TOML value is not a finite number ("nan is not a finite number",
    "'2' is not a number"), or None when it is one: for messages naming the file, the key and
    this (``job.toml: alphas: nan is not a finite number``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{value!r} is not a number"
    if not math.isfinite(value):
        return f"{value} is not a finite number"
    return None


def is_number(value) -> bool:
    """A finite JSON number: not true/false (Python's bools are ints), not NaN or inf (Python's
    json reads them, and they make an output invalid JSON)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


__all__ = ["read_json", "is_number", "number_problem"]
