"""``mrcheck discrepancies``: the planned CAD parts a registered photo disagrees with.

Modules, in the order the data flows:

* ``ids`` -- :func:`object_ids`, :func:`behind_ids`: the instance every photo pixel sees, and
  what lies behind it (ray casts through :mod:`mrcheck.scene.raycast`);
* ``edges`` -- photo edges, CAD outlines and their oriented support;
* ``planned`` -- :func:`planned_view` -> :class:`PlannedView`: the planned scene through the
  camera (render, CAD edges, ids, scored and discriminative outlines);
* ``thresholds`` -- every number that decides what is a suspect;
* ``detector`` -- :func:`detect` -> :class:`Detection` (:class:`Suspect`, :class:`Region`,
  :class:`Marker`; ``Detection.to_dict()`` is the JSON part); the method in its docstring;
* ``heatmap`` -- :func:`heatmap`; ``report`` -- ``suspects.json``, ``suspects.md``, the console line;
* ``command`` -- :func:`discrepancies_command` -> :class:`DiscrepancyRun` (what the CLI calls).

The precision / recall harness on as-built variants judges this app from above it:
:mod:`mrcheck.eval.discrepancy_eval`.
"""

from mrcheck.apps.discrepancies.command import DiscrepancyRun, discrepancies_command
from mrcheck.apps.discrepancies.detector import (
    Detection,
    Marker,
    Region,
    Suspect,
    detect,
)
from mrcheck.apps.discrepancies.heatmap import heatmap
from mrcheck.apps.discrepancies.ids import behind_ids, object_ids
from mrcheck.apps.discrepancies.planned import PlannedView, planned_view

__all__ = [
    "discrepancies_command",
    "DiscrepancyRun",
    "detect",
    "Detection",
    "Suspect",
    "Region",
    "Marker",
    "heatmap",
    "object_ids",
    "behind_ids",
    "planned_view",
    "PlannedView",
]
