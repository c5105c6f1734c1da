"""Clicked points on BOP LM-O's real photos (issue 40), measured by tests/lmo_clicks.py against the
ground truth: 8 clicks with 1.5 px noise per object, seeds 0-4, with and without one 10-30 px
mis-click. Skipped without the shared real data (``../shared/data/real``, see its README). The
limits leave a margin over the measured spread (docs/mixed-reality.md has the table)."""

from __future__ import annotations

import numpy as np
import pytest

from tests import lmo_clicks
from tests.lmo_clicks import HELD_OUT, LMO, TUNE_PHOTOS, run

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not (LMO / "camera.json").exists(), reason=f"no LM-O data at {LMO} (shared real data)"),
]


def _figures(outcomes):
    done = [o for o in outcomes if o.refused is None]
    rot = np.array([o.rot_deg for o in done])
    trans = np.array([o.trans_mm for o in done])
    return {
        "refused": len(outcomes) - len(done),
        "not_ambiguous": sum("ambiguous" not in o.refused for o in outcomes if o.refused),
        "honest_lost": sum(o.honest_rejected for o in done),
        "miss_kept": sum(o.case.miss and not o.miss_rejected for o in done),
        "median_px": float(np.median([o.median_px for o in done])),
        "within": float(np.mean((rot <= 5) & (trans <= 50))),
        "max_deg": float(rot.max()),
    }


def test_clicks_on_the_tuning_photos():
    """Measured: 160 cases, 11 refused as ambiguous, 3 of 1121 honest clicks lost, every mis-click
    rejected, median 1.09 px, 83 % within 5 deg / 5 cm, at worst 8.8 deg (the fixed 3 px
    threshold lost 126 of 1200 and reached 22 deg)."""
    f = _figures(run(TUNE_PHOTOS, range(5), with_refine=False))
    assert f["not_ambiguous"] == 0 and f["refused"] <= 20, f
    assert f["honest_lost"] <= 8 and f["miss_kept"] == 0, f
    assert f["median_px"] < 1.3 and f["within"] >= 0.75 and f["max_deg"] < 12, f


def test_clicks_on_the_held_out_photo():
    """Photo 819, never tuned on. Measured: 4 of 80 refused as ambiguous, 5 of 572 honest clicks
    lost, one mis-click on the ape (~60 px wide) absorbed (17 deg off), median 1.10 px, 93 %."""
    f = _figures(run([HELD_OUT], range(5), with_refine=False))
    assert f["not_ambiguous"] == 0 and f["refused"] <= 10, f
    assert f["honest_lost"] <= 10 and f["miss_kept"] <= 2, f
    assert f["median_px"] < 1.3 and f["within"] >= 0.8, f


def test_refine_on_seed_0_snaps_most_cases_and_stays_within_the_ground_truths_agreement():
    """``--points --refine`` on seed 0 (the three photos, each object on the whole desk, with and
    without a mis-click): never refused, the start's pose kept with the reason when not taken,
    the edges' pose taken in most cases, and the result within BOP's own agreement with the
    photo (the desk fitted from the ground truth moves 1.1-1.4 px, docs/real-data.md). Measured on
    seed 0: taken in 27 of 42, median 1.05 -> 0.99 px, at worst 1.28 px farther from the ground
    truth than the clicks' pose; seeds 0-4 (225 cases): taken 46-73 % per seed, the median
    change -0.10 to +0.21 px per seed, at worst +1.79 px. Whether such a change is worse or
    better than the clicks the ground truth cannot tell (docs/edge-registration.md)."""
    outcomes = [o for o in run([*TUNE_PHOTOS, HELD_OUT], [0], with_refine=True) if o.refused is None]
    refined = [(o, o.refine) for o in outcomes]
    assert refined and all(r is not None and not np.isnan(r.median_px) for _, r in refined)
    assert all(r.refused is None or r.refused.startswith("not applied: ") for _, r in refined)
    taken = sum(r.refused is None for _, r in refined)
    change = np.array([r.median_px - o.median_px for o, r in refined])
    assert taken >= 0.4 * len(refined), (taken, len(refined))
    assert abs(np.median([r.median_px for _, r in refined]) - np.median([o.median_px for o, _ in refined])) < 0.3
    assert change.max() < 2.0, change.max()
    assert lmo_clicks.CLICKS == 8
