"""E57 (ASTM E2807) scans through ``pye57`` (libE57Format): every scan of the file with its pose,
read in chunks of :data:`~mrcheck.scene.scans.record.CHUNK_POINTS` straight into the result.

pye57's own ``read_scan`` reads a whole scan at once (a 100 M-point scan held several times)
into 8-bit colour buffers, and refuses any point field it does not know ("Unsupported point
fields"; a las2e57 file's ``returnIndex`` or ``las:pointSourceId``). Here only the fields mrcheck
uses are read, through libE57's own buffers with conversion on: cartesian or spherical
coordinates, their invalid state, intensity, colours at whatever bit depth the file has
(ColourRepresentation.e57's 16-bit ``colorRed = 65280`` does not fit pye57's 8-bit buffer:
``ErrorValueNotRepresentable``). Any other field is listed in ``ScanCloud.skipped_fields`` and,
when pye57 itself would refuse it, named in a warning.
"""

from __future__ import annotations

import contextlib
import warnings

import numpy as np

from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.native_names import utf8_name
from mrcheck.core.progress import Progress
from mrcheck.scene.scans.record import CHUNK_POINTS, CloudBuilder, ScanCloud, ScanPose, chunks

CARTESIAN = ("cartesianX", "cartesianY", "cartesianZ")
SPHERICAL = ("sphericalRange", "sphericalAzimuth", "sphericalElevation")
COLOURS = ("colorRed", "colorGreen", "colorBlue")
INVALID = {CARTESIAN: "cartesianInvalidState", SPHERICAL: "sphericalInvalidState"}
FULL16 = 65535.0


def _node(node, name):
    from pye57.utils import get_node

    return get_node(node, name)


def _number(node) -> float:
    """A header number as float: E57 stores one as a FloatNode, an IntegerNode or a
    ScaledIntegerNode (raw * scale + offset) wherever the standard asks for a number, and
    libE57 gives the scaled one no ``value()``."""
    if hasattr(node, "scaledValue"):
        return float(node.scaledValue())
    return float(node.value())


def _pose(scan) -> np.ndarray:
    """The scan's pose (E57 1.0 8.4.11: a unit quaternion w, x, y, z and a translation), 4x4 float64."""
    T = np.eye(4)
    if not scan.isDefined("pose"):
        return T
    pose = _node(scan, "pose")
    if pose.isDefined("rotation"):
        q = _node(pose, "rotation")
        w, x, y, z = (_number(_node(q, k)) for k in "wxyz")
        n = np.sqrt(w * w + x * x + y * y + z * z) or 1.0
        w, x, y, z = w / n, x / n, y / n, z / n
        T[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    if pose.isDefined("translation"):
        t = _node(pose, "translation")
        T[:3, 3] = [_number(_node(t, k)) for k in "xyz"]
    return T


def _limits(scan, prototype, group: str, field: str, key: str) -> tuple[float, float]:
    """A field's value range: the scan's ``colorLimits`` / ``intensityLimits`` (E57 8.4.19,
    8.4.20), else the prototype's declared range (a 16-bit colour: 0..65535)."""
    if scan.isDefined(group):
        limits = _node(scan, group)
        if limits.isDefined(key + "Minimum") and limits.isDefined(key + "Maximum"):
            lo, hi = (_number(_node(limits, key + s)) for s in ("Minimum", "Maximum"))
            if hi > lo:
                return lo, hi
    node = _node(prototype, field)
    for lo_name, hi_name in (("scaledMinimum", "scaledMaximum"), ("minimum", "maximum")):
        if hasattr(node, hi_name):
            lo, hi = float(getattr(node, lo_name)()), float(getattr(node, hi_name)())
            if hi > lo and np.isfinite(hi - lo):
                return lo, hi
    return 0.0, 1.0


def _fields(path, names: list[str]):
    """(coordinate fields, their invalid-state field or None, colour?, intensity?, skipped fields)."""
    coords = CARTESIAN if set(CARTESIAN) <= set(names) else SPHERICAL if set(SPHERICAL) <= set(names) else None
    if coords is None:
        raise MrcheckError(f"E57 scan has no cartesian or spherical coordinates (fields: {', '.join(names)})", path)
    invalid = INVALID[coords] if INVALID[coords] in names else None
    colour, intensity = set(COLOURS) <= set(names), "intensity" in names
    used = {*coords, invalid, *(COLOURS if colour else ()), *(("intensity",) if intensity else ())}
    return coords, invalid, colour, intensity, tuple(n for n in names if n not in used)


class _ScanReader:
    """One scan's chunked reader: libE57 buffers of ``CHUNK_POINTS`` values per field, converted
    to float64 by libE57 itself (any integer or scaled-integer field fits)."""

    def __init__(self, e57, scan, path):
        from pye57 import libe57
        from pye57.utils import get_fields

        self.points = _node(scan, "points")
        prototype = libe57.StructureNode(self.points.prototype())
        self.coords, self.invalid, self.colour, self.intensity, self.skipped = _fields(path, get_fields(prototype))
        self.colour_limits = [_limits(scan, prototype, "colorLimits", c, c) for c in COLOURS] if self.colour else None
        self.intensity_limits = (
            _limits(scan, prototype, "intensityLimits", "intensity", "intensity") if self.intensity else None
        )
        self.image_file, self.buffers = e57.image_file, {}

    def start(self):
        """libE57's reader of this scan, into buffers allocated now (one scan's at a time: a file
        of 100 scans does not hold 100 sets)."""
        from pye57 import libe57

        names = [
            *self.coords,
            *([self.invalid] if self.invalid else []),
            *(COLOURS if self.colour else ()),
            *(("intensity",) if self.intensity else ()),
        ]
        self.buffers = {n: np.empty(CHUNK_POINTS, np.int8 if n == self.invalid else np.float64) for n in names}
        vector = libe57.VectorSourceDestBuffer()
        for name, array in self.buffers.items():
            vector.append(libe57.SourceDestBuffer(self.image_file, name, array, CHUNK_POINTS, True, True))
        return self.points.reader(vector)

    def read_into(self, reader, pose: np.ndarray, builder: CloudBuilder) -> bool:
        """The next chunk into ``builder``'s arrays (no per-chunk copies: the chunk's share of the
        read time was twice libE57's own), the pose applied and invalid points dropped; False at
        the end of the scan."""
        n = reader.read()
        if n == 0:
            return False
        b = {k: v[:n] for k, v in self.buffers.items()}
        if self.invalid is not None:  # 0: valid, 1: direction only, 2: invalid
            keep = b[self.invalid] == 0
            b = {k: v[keep] for k, v in b.items()} if not keep.all() else b
        m = len(b[self.coords[0]])
        xyz, colours, intensity = builder.reserve(m)
        if self.coords == CARTESIAN:
            for axis, name in enumerate(CARTESIAN):
                xyz[:, axis] = b[name]
        else:  # E57 8.4.18: azimuth in the xy plane from +x, elevation from the xy plane
            r, az, el = (b[c] for c in SPHERICAL)
            xyz[:] = np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1)
        # float64 throughout: map coordinates stay exact
        if not np.array_equal(pose[:3, :3], np.eye(3)):
            xyz[:] = xyz @ pose[:3, :3].T
        if pose[:3, 3].any():
            xyz += pose[:3, 3]
        if colours is not None:
            for axis, (name, limits) in enumerate(zip(COLOURS, self.colour_limits or [(0.0, 1.0)] * 3)):
                colours[:, axis] = np.rint(_scaled(b[name], limits) * FULL16) if self.colour else 0
        if intensity is not None:
            intensity[:] = _scaled(b["intensity"], self.intensity_limits) if self.intensity else 0.0
        builder.size += m
        return True


def _scaled(values: np.ndarray, limits) -> np.ndarray:
    """0..1 of the field's range (E57 8.4.19-20: the limits bound every value of the field)."""
    lo, hi = limits
    return np.clip((values - lo) / (hi - lo), 0.0, 1.0)


def _skip_warning(path, skipped: set[str]) -> None:
    """Name the fields pye57's own reader refuses ("Unsupported point fields") that were skipped."""
    from pye57.e57 import SUPPORTED_POINT_FIELDS

    refused = sorted(f for f in skipped if f not in SUPPORTED_POINT_FIELDS)
    if refused:
        warnings.warn(MrcheckWarning(f"{path}: skipped per-point fields mrcheck does not use: {', '.join(refused)}"))


def read_e57(path, progress: Progress) -> ScanCloud:
    """Every scan of an E57 file, its pose applied, in the file's frame (metres, E57's unit)."""
    import pye57

    with utf8_name(path) as name:
        e57 = pye57.E57(name)
    with contextlib.closing(e57):
        scans = [_node(e57.data3d, i) for i in range(len(e57.data3d))]
        counts = [int(_node(s, "points").childCount()) for s in scans]
        readers = [_ScanReader(e57, s, path) for s in scans]
        builder = CloudBuilder(sum(counts), any(r.colour for r in readers), any(r.intensity for r in readers))
        poses, skipped = [], set()
        steps = progress(
            [(i, c) for i, n in enumerate(counts) for c in chunks(n, CHUNK_POINTS)], f"reading {path.name}", "Mpt"
        )
        with contextlib.closing(steps):
            current = reader = None
            for index, _ in steps:
                if index != current:
                    _close(reader)
                    current, reader = index, readers[index].start()
                    poses.append(ScanPose(_name(scans[index], index), builder.size, 0, _pose(scans[index])))
                    skipped.update(readers[index].skipped)
                readers[index].read_into(reader, poses[-1].pose, builder)
                last = poses[-1]
                poses[-1] = ScanPose(last.name, last.start, builder.size - last.start, last.pose)
            _close(reader)
    _skip_warning(path, skipped)
    return builder.cloud(poses, skipped_fields=tuple(sorted(skipped)))


def _close(reader) -> None:
    if reader is not None:
        reader.close()


def _name(scan, index: int) -> str:
    return str(_node(scan, "name").value()) if scan.isDefined("name") else f"scan {index}"


__all__ = ["read_e57"]
