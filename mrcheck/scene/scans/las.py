"""LAS / LAZ scans through ``laspy`` (LAZ decompressed by ``lazrs``), read in chunks of
:data:`~mrcheck.scene.scans.record.CHUNK_POINTS` straight into the result.

Coordinates are the file's integer records times the header's scale plus its offset, computed in
float64 (LAS 1.4 R15 2.4: X = Xrecord * scale + offset): a survey-coordinate LAZ at 5e6 m keeps
its 1 mm or 0.01 ft resolution. The CRS the file names (the OGC WKT VLR, else the GeoTIFF keys)
is reported, and its linear unit (feet, US survey feet) scales the points to metres when the
caller gives no units.
"""

from __future__ import annotations

import contextlib
import logging
import re

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.progress import Progress
from mrcheck.scene.scans.record import CHUNK_POINTS, CloudBuilder, ScanCloud, ScanPose, chunks

# GeoTIFF 1.1 keys and EPSG units (ProjLinearUnitsGeoKey) the LAS specification refers to
PROJECTED_CS, GEOGRAPHIC_CS, LINEAR_UNITS, USER_DEFINED = 3072, 2048, 3076, 32767
EPSG_UNITS = {9001: ("metre", 1.0), 9002: ("foot", 0.3048), 9003: ("US survey foot", 1200.0 / 3937.0)}
_WKT_UNIT = re.compile(r'(?:LENGTH)?UNIT\["([^"]+)"\s*,\s*([0-9.eE+-]+)')
_WKT_NAME = re.compile(r'^\s*(?:PROJCS|PROJCRS|GEOGCS|GEOGCRS|COMPD_CS|COMPOUNDCRS)\["([^"]+)"')
_ANGLES = ("degree", "radian", "grad")
# laspy logs a decoding error before raising it: without a handler, Python's last-resort handler
# would print it on stderr beside mrcheck's own one-line error
logging.getLogger("laspy").addHandler(logging.NullHandler())


def _wkt_crs(wkt: str):
    """(name, (unit name, metres per unit) or None) of an OGC WKT (1 or 2) string."""
    name = _WKT_NAME.match(wkt)
    lengths = [(u, float(f)) for u, f in _WKT_UNIT.findall(wkt) if not u.lower().startswith(_ANGLES)]
    return (name.group(1) if name else wkt.strip()[:80]), (lengths[-1] if lengths else None)


def _geokeys_crs(keys):
    """(name, unit) from the GeoKeyDirectory: ``EPSG:code`` of the projected (else geographic) CRS."""
    values = {k.id: k.value_offset for k in keys if k.tiff_tag_location == 0}
    code = next((values[k] for k in (PROJECTED_CS, GEOGRAPHIC_CS) if values.get(k, USER_DEFINED) != USER_DEFINED), None)
    linear = values.get(LINEAR_UNITS)
    unit = EPSG_UNITS.get(linear) if linear is not None else None
    name = f"EPSG:{code}" if code else ("user-defined (GeoTIFF keys)" if values else None)
    return name, unit


def las_crs(header):
    """``(description, (unit name, metres per unit) or None)`` of the CRS a LAS header names, or
    ``(None, None)``. The WKT wins over the GeoTIFF keys (LAS 1.4: WKT is the CRS of record)."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    records = [*header.vlrs, *(getattr(header, "evlrs", None) or ())]
    wkt = next((v for v in records if isinstance(v, WktCoordinateSystemVlr) and v.string.strip()), None)
    keys = next((v for v in records if isinstance(v, GeoKeyDirectoryVlr)), None)
    name, unit = _wkt_crs(wkt.string) if wkt is not None else (None, None)
    if keys is not None:
        key_name, key_unit = _geokeys_crs(keys.geo_keys)
        name, unit = name or key_name, unit or key_unit
    return name, unit


def _backends(path, header):
    """The LAZ backends to decompress with; a compressed file without one is a one-line error."""
    import laspy

    available = laspy.LazBackend.detect_available()
    if header.are_points_compressed and not available:
        raise MrcheckError(
            "the scan is LAZ-compressed but no LAZ backend is installed (install lazrs: pip install 'lazrs>=0.6')", path
        )
    return available


def _chunk(chunk, scale, offset, colour: bool):
    """float64 metres-to-be of one chunk: integer record * scale + offset (never float32)."""
    xyz = np.empty((len(chunk), 3), np.float64)
    for axis, name in enumerate("XYZ"):
        np.multiply(np.asarray(chunk[name], np.float64), scale[axis], out=xyz[:, axis])
        xyz[:, axis] += offset[axis]
    colours = np.stack([chunk.red, chunk.green, chunk.blue], axis=1).astype(np.uint16) if colour else None
    # LAS 1.4 R15 2.6: intensity is normalised to 16 bits
    return xyz, colours, np.asarray(chunk.intensity, np.float32) / 65535.0


def _eight_bit_colours(colours) -> None:
    """LAS colours are 16-bit (LAS 1.4 R15 2.6), but many writers store 8-bit values (laspy's
    simple.las: 0..249): a file whose colours never exceed 255 is taken as 8-bit and scaled by
    257 in place (as PDAL and CloudCompare read such files)."""
    if colours is not None and len(colours) and 0 < colours.max() <= 255:
        colours *= 257


def _read_chunks(path, reader, steps, builder: CloudBuilder, how) -> None:
    """Every chunk into ``builder``; a chunk that fails to decode is a truncated or corrupt file."""
    for _ in steps:
        try:
            chunk = reader.read_points(CHUNK_POINTS)
        except Exception as exc:  # lazrs: "IoError: failed to fill whole buffer"; laspy: LaspyException
            raise MrcheckError(
                f"truncated or corrupt LAS/LAZ: cannot read past point {builder.size} of "
                f"{reader.header.point_count} ({' '.join(str(exc).split())[:120]})",
                path,
            ) from None
        if len(chunk) == 0:
            break
        builder.add(*_chunk(chunk, *how))


def _check_scale(path, scale: np.ndarray) -> None:
    """A scale of 0 puts every point at the offset (one point, a deviation of 0 mm): refused,
    as is a NaN or infinite one."""
    bad = [f"{axis} {value!r}" for axis, value in zip("xyz", scale.tolist()) if value == 0.0 or not np.isfinite(value)]
    if bad:
        raise MrcheckError(
            f"LAS header has an unusable scale ({', '.join(bad)}): every coordinate is record * scale + offset, "
            "so the points would collapse; the file's writer is broken",
            path,
        )


def read_las(path, progress: Progress) -> ScanCloud:
    """A LAS or LAZ file's points in its own coordinates and units (``units`` and
    ``metres_per_unit`` of the result: the CRS's linear unit when it names one)."""
    import laspy

    with open(path, "rb") as handle:  # the header alone: opening a LAZ without a backend fails
        backends = _backends(path, laspy.LasHeader.read_from(handle))
    with laspy.open(str(path), laz_backend=backends or None) as reader:
        header = reader.header
        count = int(header.point_count)
        dims = set(header.point_format.dimension_names)
        colour = {"red", "green", "blue"} <= dims
        builder = CloudBuilder(count, colour, True)
        scale, offset = np.asarray(header.scales, np.float64), np.asarray(header.offsets, np.float64)
        _check_scale(path, scale)
        steps = progress(chunks(count, CHUNK_POINTS), f"reading {path.name}", "Mpt")
        with contextlib.closing(steps):
            _read_chunks(path, reader, steps, builder, (scale, offset, colour))
        crs, unit = las_crs(header)
    colours = builder.colours  # None unless the points have colour
    _eight_bit_colours(colours[: builder.size] if colours is not None else None)
    if builder.size < count:
        raise MrcheckError(
            f"truncated or corrupt LAS/LAZ: {builder.size} of the header's {count} points could be read", path
        )
    units, factor = unit if unit is not None else (None, None)
    return builder.cloud([ScanPose(path.stem, 0, builder.size)], crs=crs, units=units, metres_per_unit=factor)


__all__ = ["read_las", "las_crs"]
