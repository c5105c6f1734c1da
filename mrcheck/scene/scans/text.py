"""Point files without scan structure: ``.ply`` and ``.pcd`` through
``open3d.io.read_point_cloud``; ``.xyz``, ``.txt``, ``.pts`` as header-less text ``x y z [...]``
per line (separated by white space, commas or semicolons; no decimal commas). A ``.ply`` without
the ``ply`` magic on its first line is read as text too (the Stanford bunny's range scans are
such files). Each reader returns (N, 3) float64 points in the file's own units.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.quiet import native_output
from mrcheck.scene.scans.ply import read_binary_ply


def _is_ply_binary_or_header(path: Path) -> bool:
    with open(path, "rb") as handle:
        return handle.read(3) == b"ply"


def _read_cloud(path: Path, fmt: str) -> np.ndarray:
    """Points of a .ply / .pcd through Open3D, which reports a corrupt or truncated file only by
    printing (RPly's "Error reading 'x' of 'vertex' number 20125", then "Read PLY failed") and
    returns the cloud anyway, the unread points left as garbage: its output is captured (RPly's C
    library writes to the file descriptors, Open3D's warnings go through Python's sys.stdout) and
    a failure becomes the error."""
    import open3d as o3d

    with native_output(fds=(1, 2), python=True) as messages:
        # a str, which every supported Open3D takes (0.20's stubs name os.PathLike only)
        cloud = o3d.io.read_point_cloud(
            str(path),  # type: ignore[arg-type]
            format=fmt,
            remove_nan_points=False,
            remove_infinite_points=False,
        )
    failed = [line for line in messages if "failed" in line.lower() or "error" in line.lower()]
    if failed:
        raise MrcheckError(f"cannot read scan, corrupt or truncated ({failed[0]})", path)
    return np.asarray(cloud.points, np.float64)


# values are separated by white space, commas (CloudCompare's ASCII export writes x,y,z) or
# semicolons. Decimal commas are told apart by counting fields: "1,25 2,50 0,10" is three
# white-space fields with a comma inside each, which "1,2,3" and "1, 2, 3" never are (split at
# both, it was the six numbers 1, 25, 2, 50, 0, 10 and the point (1, 25, 2)). A line with a
# semicolon is split at semicolons only, so that "1,5;2,5;0,0" is refused, not read as (1, 5, 2).
_SEMICOLONS = re.compile(r"[\s;]+")
_COMMENTS = ("#", "//")


def _values(line: str) -> list[str] | None:
    """The values of one line, or None for a line with decimal commas."""
    if ";" in line:
        return [v for v in _SEMICOLONS.split(line.strip()) if v]
    if "," not in line:
        return line.split()
    fields = [f.strip() for f in line.split(",")]
    if any(len(f.split()) > 1 for f in fields):  # white space inside a comma-separated field
        return None
    return [f for f in fields if f]


def _text_problem(lines) -> str:
    """Why the first bad one of ``(line number, line)`` is not ``x y z``: decimal commas or non-numbers."""
    for number, line in lines:
        values = _values(line)
        if values is None or any("," in v for v in values[:3]):
            return f"line {number} {line.strip()[:60]!r}: decimal commas are not supported"
        try:
            [float(v) for v in values[:3]]
        except ValueError:
            return f"line {number} {line.strip()[:60]!r}: not numbers"
    return "a line with non-numbers"


def read_text_points(path: Path) -> np.ndarray:
    """Header-less ``x y z [more columns]`` lines, separated by white space, commas or semicolons.
    Lines with fewer than three values are skipped with a warning: header-stripped Stanford range
    scans keep their range-grid lines ("0", "1 17") after the points."""
    try:
        text = path.read_text(encoding="ascii")
    except UnicodeDecodeError:
        raise MrcheckError("not a text x y z point file (binary content)", path) from None
    lines = [
        (n, line)
        for n, line in enumerate(text.splitlines(), 1)
        if line.strip() and not line.lstrip().startswith(_COMMENTS)
    ]
    rows = [_values(line) for _, line in lines]
    points = [r[:3] for r in rows if r is not None and len(r) >= 3]
    try:
        if None in rows:
            raise ValueError("decimal commas")
        data = np.array(points, np.float64).reshape(-1, 3)  # "nan" parses: caught as NaN below
    except ValueError:
        raise MrcheckError(f"not a text x y z point file ({_text_problem(lines)})", path) from None
    if len(points) < len(rows):
        warnings.warn(MrcheckWarning(f"{path}: skipped {len(rows) - len(points)} lines with fewer than 3 values"))
    return data


def read_ply(path: Path) -> np.ndarray:
    # sniff, do not trust the suffix: header-less "x y z" files are often named .ply
    if not _is_ply_binary_or_header(path):
        return read_text_points(path)
    points = read_binary_ply(path)  # numpy for the plain binary case, else Open3D
    return _read_cloud(path, "ply") if points is None else points


def read_pcd(path: Path) -> np.ndarray:
    return _read_cloud(path, "pcd")


__all__ = ["read_text_points", "read_ply", "read_pcd"]
