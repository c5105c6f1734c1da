"""The detector's parameters: every number that decides what is a suspect, in one place.

The thresholds were chosen on the evaluation's development seeds 0-9 only (640x480); the sweep
and what it showed are in :mod:`mrcheck.apps.discrepancies.detector`'s docstring.
"""

from __future__ import annotations

from mrcheck.core.camera import Camera

SCORE_THRESHOLD = 0.55    # swept on the evaluation's development seeds 0-9 (recall against false suspects)
MIN_EDGE_PIXELS = 20      # fewer visible edge pixels is too little evidence either way
MIN_REGION_PIXELS = 25    # unexplained photo edge pixels a region needs to be reported
SHIFT_RADIUS = 4.0        # the displaced copies searched reach this many tolerances
MAX_TOLERANCE_SHARE = 0.05   # --tolerance-px at most this share of the photo's shorter side
# second rule (seeds 0-9): the outline the planned scene *without* the part would not show
# scores >= DISCRIMINATIVE_THRESHOLD while the whole outline scores >= DISCRIMINATIVE_FLOOR
DISCRIMINATIVE_THRESHOLD = 0.85
DISCRIMINATIVE_FLOOR = 0.2     # the middle of 0-0.4, where moves found on seeds 0-9 stay the same
# issue 22 (seeds 0-9 and the unchanged scenes): a part whose expected outline (the pixels the
# planned render itself shows as an edge) is found where planned for more than this share is no
# suspect, whatever a shifted copy finds (in a fence's or a shelf's clutter one always fits)
MAX_SUPPORT = 0.5
# "texture, not structure": photo structure wholly inside CAD faces above floor level is no
# added object (objects stand on the floor); floor level = this high above the lowest seen surface
GROUND_HEIGHT = 0.05   # m
GROUND_SHARE = 0.1     # ... or this share of the scene's height, when less (a 7.5 cm box)
FLOOR_BAND = 0.25      # the lowest upward face is a floor only in the bottom quarter of the scene


def default_tolerance(camera: Camera) -> float:
    """2 px at 1000 px on the longer side or less, growing with resolution."""
    return 2.0 * max(1.0, max(camera.width, camera.height) / 1000.0)


def shift_radius(tol: float) -> int:
    """How far (px) the shifted copies of an outline reach for a tolerance ``tol``."""
    return max(2, int(round(SHIFT_RADIUS * tol)))


__all__ = ["SCORE_THRESHOLD", "MIN_EDGE_PIXELS", "MIN_REGION_PIXELS", "SHIFT_RADIUS", "MAX_TOLERANCE_SHARE",
           "DISCRIMINATIVE_THRESHOLD", "DISCRIMINATIVE_FLOOR",
           "MAX_SUPPORT", "GROUND_HEIGHT", "GROUND_SHARE", "FLOOR_BAND", "default_tolerance", "shift_radius"]
