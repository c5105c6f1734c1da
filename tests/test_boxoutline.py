"""The box photo's outline reference (:mod:`mrcheck.eval.boxoutline`) follows a weak rim, not
the strong print inside it (the CD segment of tests/data/pose/box: a rim 10-12 grey levels above
the table, a printed border 3-5 px inside)."""

from __future__ import annotations

import numpy as np

from mrcheck.eval.boxoutline import PROFILE_STEP, profile_crossing


def _profile(rim_levels: float) -> tuple:
    """A profile outward from the box (0.25 px steps): the box at 180, a dark printed border
    (60) from 6 to 3 px inside the outline, the rim at ``100 + rim_levels`` for the last 3 px,
    the table at 100 beyond the outline; the outline's index."""
    x = np.arange(-14.0, 14.0 + 1e-9, PROFILE_STEP)
    profile = np.where(x < -6, 180.0, np.where(x < -3, 60.0, np.where(x < 0, 100.0 + rim_levels, 100.0)))
    return profile, int(np.flatnonzero(x >= 0)[0])


def test_the_crossing_lies_on_a_weak_rim_not_on_the_print_inside():
    profile, outline = _profile(10.0)
    crossing = profile_crossing(profile)
    assert crossing is not None and abs(crossing - outline) * PROFILE_STEP <= 0.5


def test_a_step_within_the_tables_noise_is_not_taken_for_the_rim():
    profile, outline = _profile(3.0)  # below the table's measured 4 levels peak to peak
    crossing = profile_crossing(profile)
    assert crossing is not None and (outline - crossing) * PROFILE_STEP >= 2.5  # the print's edge instead
