"""``mrcheck deviation``: as-built vs as-planned from a laser scan (signed cloud-to-mesh distances,
per point and per part instance, as CloudCompare's C2M).

Modules, in the order the data flows:

* :func:`read_scan` (from :mod:`mrcheck.scene.scans`, where the bench reads scans too): every
  scan format into one :class:`~mrcheck.scene.scans.ScanCloud`, and the checks every scan passes;
* ``distances`` -- :func:`deviation` -> :class:`Deviation`: the placement checks (units,
  registration), :func:`signed_distances` and the ranked :class:`PartDeviation` rows; the
  distance's definition in its docstring;
* ``images`` -- the diverging colour map, the top / side splats and the shot's render / overlay;
* ``report`` -- :class:`DeviationReport` (``parts.json``), ``parts.md``, ``deviations.npy``;
* ``command`` -- :func:`deviation_command` -> :class:`DeviationRun` (what the CLI calls).
"""

from mrcheck.apps.deviation.command import DeviationRun, deviation_command
from mrcheck.apps.deviation.distances import (
    Deviation,
    PartDeviation,
    check_placement,
    deviation,
    part_statistics,
    signed_distances,
)
from mrcheck.apps.deviation.report import DeviationReport
from mrcheck.scene.scans import SCAN_SUFFIXES, ScanCloud, read_scan

__all__ = [
    "deviation_command",
    "DeviationRun",
    "deviation",
    "Deviation",
    "PartDeviation",
    "DeviationReport",
    "check_placement",
    "signed_distances",
    "part_statistics",
    "read_scan",
    "ScanCloud",
    "SCAN_SUFFIXES",
]
