"""The bench's scan figures (issue 19): points read per second and the peak memory of
:func:`mrcheck.scene.scans.read_scan` on a large synthetic LAZ and E57, written here at map
coordinates (never committed: a 20 M-point LAZ is about 200 MB).

Each read runs in a fresh process (``spawn``), so that its peak resident memory (VmHWM) is the
reader's own, not the bench's: the figure to hold against "a 100 M-point scan stays within a few
GB". The result alone (float64 points, 16-bit colours, float32 intensity) is 34 bytes a point.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from statistics import median

import numpy as np

from mrcheck.eval.bench.peers import peak_rss_mb

SCAN_POINTS, QUICK_SCAN_POINTS = 20_000_000, 1_000_000
SCAN_REPEAT = 2  # reads per format (a 20 M-point read: tens of seconds)
SCAN_FORMATS = ("laz", "e57")
SCAN_ORIGIN = (458658.78, 5438232.79, 113.7)  # map coordinates, as issue 19's shifted model
WRITE_CHUNK = 1 << 21
HALL = (60.0, 40.0, 12.0)  # metres, the synthetic scanned hall
RESULT_BYTES_PER_POINT = 3 * 8 + 3 * 2 + 4


@dataclass
class ScanReadFigure:
    """One format's read: ``runs_s`` wall-clock seconds of each read, its peak memory (MiB)."""

    format: str
    points: int
    file_mb: float
    write_s: float
    runs_s: list = field(default_factory=list)
    peak_rss_mb: list = field(default_factory=list)  # of each read's process
    result_mb: float = 0.0  # the ScanCloud's arrays alone

    @property
    def points_per_s(self) -> float:
        return self.points / median(self.runs_s)

    def to_json(self) -> dict:
        return {
            **asdict(self),
            "median_s": median(self.runs_s),
            "points_per_s": self.points_per_s,
            "max_peak_rss_mb": max(self.peak_rss_mb),
        }


def _hall_points(rng, n: int) -> np.ndarray:
    """``n`` points of a scanned hall 60 x 40 x 12 m (floor, walls, ceiling, 2 mm noise), float64
    at map coordinates, in scan-line order (each face swept in rows, as a scanner writes them:
    LASzip's predictors and libE57's packets see the coherence of a real scan, not shuffled points)."""
    u = rng.uniform(0.0, 1.0, (n, 3)) * HALL
    face = np.sort(rng.integers(0, 6, n))
    axis = face // 2
    u[np.arange(n), axis] = np.where(face % 2 == 0, 0.0, np.asarray(HALL)[axis])
    # within a face: rows 5 cm apart along the face's first free axis, points sorted along the row
    first = np.where(axis == 0, 1, 0)
    second = np.where(axis == 2, 1, 2)
    rows = np.floor(u[np.arange(n), first] / 0.05)
    order = np.lexsort((u[np.arange(n), second], rows, face))
    return u[order] + rng.normal(0.0, 0.002, (n, 3)) + SCAN_ORIGIN


def _chunk_fields(rng, n: int):
    """Points, 16-bit colours and intensity that vary smoothly over the hall (a scan's, not noise)."""
    xyz = _hall_points(rng, n)
    local = (xyz - SCAN_ORIGIN) / HALL
    rgb = (np.clip(local, 0.0, 1.0) * 65535).astype(np.uint16)
    intensity = (np.clip(0.5 + 0.3 * np.sin(local[:, 0] * 20) + rng.normal(0, 0.02, n), 0, 1) * 65535).astype(np.uint16)
    return xyz, rgb, intensity


def write_laz(path: Path, points: int, seed: int = 0) -> None:
    """A LAZ (LAS 1.2, point format 3, 1 mm, offset at the map origin) written chunk by chunk."""
    import laspy

    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales, header.offsets = np.full(3, 0.001), np.round(SCAN_ORIGIN)
    with laspy.open(str(path), mode="w", header=header, do_compress=True) as writer:
        for start in range(0, points, WRITE_CHUNK):
            xyz, rgb, intensity = _chunk_fields(rng, min(WRITE_CHUNK, points - start))
            record = laspy.ScaleAwarePointRecord.zeros(len(xyz), header=header)
            record.x, record.y, record.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            record.red, record.green, record.blue = rgb[:, 0], rgb[:, 1], rgb[:, 2]
            record.intensity = intensity
            writer.write_points(record)


def write_e57(path: Path, points: int, seed: int = 0) -> None:
    """An E57 of two scans (half the points each), the second with a pose (pye57 writes whole scans)."""
    import pye57

    rng = np.random.default_rng(seed)
    with pye57.E57(str(path), mode="w") as e57:
        for i, half in enumerate((points // 2, points - points // 2)):
            xyz, rgb, intensity = _chunk_fields(rng, half)
            xyz -= SCAN_ORIGIN  # the station's own frame; the pose puts it back
            data = {
                "cartesianX": xyz[:, 0],
                "cartesianY": xyz[:, 1],
                "cartesianZ": xyz[:, 2],
                "intensity": intensity / 65535.0,
                "colorRed": (rgb[:, 0] >> 8).astype(np.uint8),
                "colorGreen": (rgb[:, 1] >> 8).astype(np.uint8),
                "colorBlue": (rgb[:, 2] >> 8).astype(np.uint8),
            }
            del xyz
            e57.write_scan_raw(
                data, name=f"station {i}", rotation=np.array([1.0, 0, 0, 0]), translation=np.asarray(SCAN_ORIGIN)
            )


WRITERS = {"laz": write_laz, "e57": write_e57}


def _read_child(path: str, connection) -> None:
    """In a fresh process: read the scan, send (seconds, points, peak MiB, result MiB)."""
    from mrcheck.scene.scans import read_scan

    start = time.perf_counter()
    cloud = read_scan(path)
    seconds = time.perf_counter() - start
    result = sum(a.nbytes for a in (cloud.points, cloud.colours, cloud.intensity) if a is not None) / 2**20
    connection.send((seconds, len(cloud), peak_rss_mb(), result))
    connection.close()


def timed_read(path: Path) -> tuple[float, int, float, float]:
    """One read of ``path`` in a fresh process: (seconds, points, peak resident MiB, result MiB)."""
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe(duplex=False)
    child = context.Process(target=_read_child, args=(str(path), theirs))
    child.start()
    theirs.close()
    try:
        answer = ours.recv()
    except EOFError:
        raise RuntimeError(
            f"reading {path} failed in its worker (exit code {child.join() or child.exitcode})"
        ) from None
    child.join()
    return answer


def measure_scan_reading(workdir: Path, points: int, repeat: int, formats=SCAN_FORMATS) -> list[ScanReadFigure]:
    """Write a synthetic scan of ``points`` points per format into ``workdir`` (deleted after),
    then time ``repeat`` reads of it, each in its own process."""
    figures = []
    for fmt in formats:
        path = Path(workdir) / f"bench_scan_{points}.{fmt}"
        start = time.perf_counter()
        WRITERS[fmt](path, points)
        figure = ScanReadFigure(fmt, points, os.path.getsize(path) / 2**20, time.perf_counter() - start)
        try:
            for _ in range(repeat):
                seconds, count, peak, result = timed_read(path)
                if count != points:
                    raise RuntimeError(f"read {count} of the {points} points written to {path}")
                figure.runs_s.append(seconds)
                figure.peak_rss_mb.append(peak)
                figure.result_mb = result
        finally:
            path.unlink(missing_ok=True)
        figures.append(figure)
    return figures


def scan_figures_text(figures: list[ScanReadFigure]) -> list[str]:
    """The lines ``mrcheck bench`` prints for the scan reads."""
    lines = []
    for f in figures:
        lines.append(
            f"scan read {f.format.upper()} {f.points / 1e6:g} M points ({f.file_mb:.0f} MB file): "
            f"{f.points_per_s / 1e6:.2f} M points/s (median of {len(f.runs_s)}, "
            f"{', '.join(f'{t:.1f}' for t in f.runs_s)} s), peak RSS {max(f.peak_rss_mb):.0f} MB "
            f"(the points, colours and intensity alone: {f.result_mb:.0f} MB)"
        )
    return lines


def scan_reading(quick: bool, repeat: int) -> tuple[list[dict], list[str]]:
    """The bench's scan section: the figures as JSON and as printed lines, on a synthetic scan of
    :data:`QUICK_SCAN_POINTS` / :data:`SCAN_POINTS` points in the temporary directory."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="mrcheck-bench-scan-") as workdir:
        figures = measure_scan_reading(
            Path(workdir), QUICK_SCAN_POINTS if quick else SCAN_POINTS, min(repeat, SCAN_REPEAT)
        )
    return [f.to_json() for f in figures], scan_figures_text(figures)


__all__ = [
    "scan_reading",
    "scan_figures_text",
    "measure_scan_reading",
    "timed_read",
    "write_laz",
    "write_e57",
    "ScanReadFigure",
    "SCAN_POINTS",
    "QUICK_SCAN_POINTS",
]
