"""Laser scans: :func:`read_scan` reads every supported format (E57, LAS/LAZ, PLY, PCD, text x y z)
into one :class:`ScanCloud` (float64 points in metres at the file's own coordinates, every
scan's pose applied, colours, intensity, the CRS), in chunks with a progress display.

Modules: ``record`` (:class:`ScanCloud`, :class:`ScanPose`), ``reading`` (:func:`read_scan`,
the format checks), one reader per format (``e57``, ``las``, ``text``). They live in the scene
layer because the bench (``mrcheck.eval``) measures them as well as ``mrcheck deviation``.
"""

from mrcheck.scene.scans.reading import SCAN_SUFFIXES, read_scan
from mrcheck.scene.scans.record import ScanCloud, ScanPose

__all__ = ["read_scan", "ScanCloud", "ScanPose", "SCAN_SUFFIXES"]
