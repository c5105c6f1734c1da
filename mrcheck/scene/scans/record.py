"""What :func:`~mrcheck.scene.scans.read_scan` returns: :class:`ScanCloud`, the points of every
scan of a file in one float64 frame, and what a reader fills it with chunk by chunk
(:class:`CloudBuilder`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CHUNK_POINTS = 1 << 20  # points per read: a chunk's temporaries stay ~100 MB whatever the scan's size


@dataclass(frozen=True)
class ScanPose:
    """One scan of a file (an E57 file holds many; LAS and the others one): its name, its points
    ``cloud.points[start:start + count]`` and the scan-to-file pose that was applied to them."""

    name: str
    start: int
    count: int
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))  # (4, 4) float64, already applied


@dataclass
class ScanCloud:
    """The points of a scan file, in the file's world frame (every scan's pose applied).

    ``points`` are float64 metres (after ``units``) at the file's own coordinates, map
    coordinates included: nothing is re-centred or rounded to float32 here (the closest-point
    queries take them relative to the scan's centre, see ``mrcheck.scene.raycast``).
    ``colours`` are 16-bit (0..65535 is the file's full colour range: 8-bit colours are scaled by
    257), ``intensity`` is 0..1 of the file's intensity range; both None when the file has none.
    """

    points: np.ndarray  # (N, 3) float64, metres
    colours: np.ndarray | None = None  # (N, 3) uint16
    intensity: np.ndarray | None = None  # (N,) float32, 0..1
    scans: list[ScanPose] = field(default_factory=list)
    crs: str | None = None  # the coordinate reference system the file names (LAS), else None
    units: str | None = None  # the unit of the file's numbers (given, or the CRS's); None: metres
    metres_per_unit: float | None = None  # the factor applied to them (a reader: the file's own, None: unknown)
    skipped_fields: tuple[str, ...] = ()  # per-point fields of the file that were not read (E57)

    def __len__(self) -> int:
        return len(self.points)


class CloudBuilder:
    """Arrays allocated once for ``capacity`` points and filled chunk by chunk (a 100 M-point
    scan is never held twice), trimmed to the points actually kept (E57 invalid points)."""

    def __init__(self, capacity: int, colours: bool, intensity: bool):
        self.points = np.empty((capacity, 3), np.float64)
        self.colours = np.empty((capacity, 3), np.uint16) if colours else None
        self.intensity = np.empty(capacity, np.float32) if intensity else None
        self.size = 0

    def add(self, points: np.ndarray, colours=None, intensity=None) -> None:
        end = self.size + len(points)
        self.points[self.size : end] = points
        if self.colours is not None:
            self.colours[self.size : end] = colours
        if self.intensity is not None:
            self.intensity[self.size : end] = intensity
        self.size = end

    def reserve(self, n: int):
        """Views of the next ``n`` rows (points, colours or None, intensity or None) for a reader
        to fill in place; it then adds ``n`` to :attr:`size`."""
        end = self.size + n
        return (
            self.points[self.size : end],
            None if self.colours is None else self.colours[self.size : end],
            None if self.intensity is None else self.intensity[self.size : end],
        )

    def cloud(self, scans: list[ScanPose], **extra) -> ScanCloud:
        """The filled part as a :class:`ScanCloud` (views, no copy)."""
        n = self.size
        return ScanCloud(
            self.points[:n],
            None if self.colours is None else self.colours[:n],
            None if self.intensity is None else self.intensity[:n],
            scans,
            **extra,
        )


def chunks(total: int, chunk: int = CHUNK_POINTS) -> list[tuple[int, int]]:
    """``(start, count)`` of the reads of ``total`` points."""
    return [(start, min(chunk, total - start)) for start in range(0, total, chunk)]


__all__ = ["ScanCloud", "ScanPose", "CloudBuilder", "chunks", "CHUNK_POINTS"]
