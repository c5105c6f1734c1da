""":func:`read_scan`: every scan format behind one function, and the checks every scan passes (a
missing, empty or unreadable file, an unsupported format, a file whose content is another
format than its suffix says, no points, NaN/infinite points: one-line
:class:`~mrcheck.core.errors.MrcheckError` naming the file)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input
from mrcheck.core.progress import Progress, shown_progress
from mrcheck.scene.part_tables import unit_scale
from mrcheck.scene.scans.e57 import read_e57
from mrcheck.scene.scans.las import read_las
from mrcheck.scene.scans.record import ScanCloud, ScanPose
from mrcheck.scene.scans.text import read_pcd, read_ply, read_text_points

# suffix -> the format its content must be ("text" accepts anything that is not a known binary)
FORMATS = {
    ".e57": "E57",
    ".las": "LAS/LAZ",
    ".laz": "LAS/LAZ",
    ".ply": "PLY",
    ".pcd": "PCD",
    ".xyz": "text",
    ".txt": "text",
    ".pts": "text",
}
SCAN_SUFFIXES = tuple(FORMATS)
_SUFFIX_OF = {"E57": ".e57", "LAS/LAZ": ".las or .laz", "PLY": ".ply", "PCD": ".pcd"}


def _points_only(read):
    def reader(path: Path, progress: Progress) -> ScanCloud:
        points = np.asarray(read(path), np.float64).reshape(-1, 3)
        return ScanCloud(points, scans=[ScanPose(path.stem, 0, len(points))])

    return reader


# format -> reader(path, progress) -> ScanCloud in the file's own units
READERS = {
    "E57": read_e57,
    "LAS/LAZ": read_las,
    "PLY": _points_only(read_ply),
    "PCD": _points_only(read_pcd),
    "text": _points_only(read_text_points),
}


def sniff(path: Path) -> str | None:
    """The format the file's first bytes say (E57, LAS/LAZ, PLY, PCD), None for anything else."""
    with open(path, "rb") as handle:
        head = handle.read(512)
    if head.startswith(b"ASTM-E57"):
        return "E57"
    if head.startswith(b"LASF"):
        return "LAS/LAZ"
    if head.startswith(b"ply"):
        return "PLY"
    first = next((line.strip() for line in head.splitlines() if line.strip()), b"")
    return "PCD" if first.startswith((b"# .PCD", b"VERSION")) else None


def _check_content(path: Path, wanted: str) -> None:
    found = sniff(path)
    if found == wanted or (wanted == "PLY" and found is None):  # header-less "x y z" named .ply
        return
    suffix = path.suffix.lower()
    if found is not None:
        raise MrcheckError(
            f"the file's content is {found}, not {wanted} as its {suffix} suffix says "
            f"(rename it to {_SUFFIX_OF[found]})",
            path,
        )
    if wanted != "text":
        raise MrcheckError(f"not an {wanted} file (its first bytes are not the {wanted} signature)", path)


def _metres(cloud: ScanCloud, units: str | None, path) -> None:
    """Scale the points to metres in place: by ``units`` when given, else by the unit the file
    names (a LAS CRS in feet), else not at all."""
    if units is not None:
        cloud.units, cloud.metres_per_unit = units, unit_scale(units, path)
    elif cloud.metres_per_unit is None:
        cloud.metres_per_unit = 1.0
    if cloud.metres_per_unit != 1.0:
        cloud.points *= cloud.metres_per_unit


def read_scan(path, units: str | None = None, progress: Progress | None = None) -> ScanCloud:
    """The scan file ``path`` as a :class:`ScanCloud`: float64 points in metres (``units``: the
    file's, else the unit its CRS names, else metres), every scan's pose applied, colours and
    intensity when the file has them. Long reads report to ``progress`` (default: the display
    the caller installed, :func:`mrcheck.core.progress.shown_progress`). Every bad input raises
    :class:`MrcheckError`."""
    path = Path(path)
    size = check_input(path, "scan file").st_size
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise MrcheckError(f"unsupported scan format {suffix or '(none)'} (use {', '.join(SCAN_SUFFIXES)})", path)
    if size == 0:
        raise MrcheckError("scan file is empty (no points)", path)
    unit_scale(units, path)  # an unknown unit before the read
    _check_content(path, FORMATS[suffix])
    try:
        cloud = READERS[FORMATS[suffix]](path, progress or shown_progress())
    except MrcheckError:
        raise
    except Exception as exc:  # the readers raise many types for corrupt files
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise MrcheckError(f"cannot read scan ({reason})", path) from None
    if len(cloud.points) == 0:
        raise MrcheckError("scan has no points (empty or unreadable cloud)", path)
    finite = np.isfinite(cloud.points)
    if not finite.all():  # (all() of the whole array first: 10x faster than per row)
        bad = ~np.all(finite, axis=1)
        raise MrcheckError(f"scan has {int(bad.sum())} points with NaN or infinite coordinates", path)
    _metres(cloud, units, path)
    return cloud


__all__ = ["read_scan", "sniff", "READERS", "FORMATS", "SCAN_SUFFIXES"]
