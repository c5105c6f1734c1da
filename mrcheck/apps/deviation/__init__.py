"""``mrcheck deviation``: as-built vs as-planned from a laser scan (signed cloud-to-mesh distances,
per point and per part instance, as CloudCompare's C2M).

Modules, in the order the data flows:

* ``scans`` -- :func:`read_scan`: every scan format (one reader per suffix in ``READERS``) and
  the checks every scan file passes;
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
from mrcheck.apps.deviation.scans import SCAN_SUFFIXES, read_scan

__all__ = ["deviation_command", "DeviationRun", "deviation", "Deviation", "PartDeviation", "DeviationReport",
           "check_placement", "signed_distances", "part_statistics", "read_scan", "SCAN_SUFFIXES"]
