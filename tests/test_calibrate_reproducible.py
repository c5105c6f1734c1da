"""``mrcheck calibrate`` is bit-reproducible: the same photos give the same bytes, in separate
processes, with OpenCV's thread pool at any size and with the photos given in any order."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

DATA = Path(__file__).parent / "data" / "calibration"
BOARDS = {
    "chessboard": (sorted((DATA / "opencv_chessboard").glob("left[0-9]*.jpg")), "chessboard:9x6:0.025", 5),
    "charuco": (sorted((DATA / "opencv_charuco").glob("img_*.jpg")), "charuco:5x7:0.04:0.02:DICT_6X6_250", 3),
}


def calibrate(tmp_path, name, photos, spec, min_views) -> bytes:
    """The camera JSON of ``mrcheck calibrate`` run in a process of its own."""
    out = tmp_path / f"{name}.json"
    # four OpenCV threads whatever the machine has: the race among them is what made runs differ
    env = dict(os.environ, OPENCV_FOR_THREADS_NUM="4")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mrcheck.cli",
            "calibrate",
            *map(str, photos),
            "--board",
            spec,
            "--min-views",
            str(min_views),
            "-o",
            str(out),
        ],
        env=env,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    return out.read_bytes()


@pytest.mark.parametrize("board", sorted(BOARDS))
def test_two_runs_write_the_same_bytes(tmp_path, board):
    photos, spec, min_views = BOARDS[board]
    first = calibrate(tmp_path, "first", photos, spec, min_views)
    second = calibrate(tmp_path, "second", photos, spec, min_views)
    assert first == second, "two runs on the same photos wrote different camera files"


def test_the_order_of_the_photos_does_not_change_the_camera(tmp_path):
    photos, spec, min_views = BOARDS["chessboard"]
    given = json.loads(calibrate(tmp_path, "given", photos, spec, min_views))
    reversed_ = json.loads(calibrate(tmp_path, "reversed", photos[::-1], spec, min_views))
    # the per-view errors follow the order given (a dict compares without it); every number is exact
    assert list(reversed_["per_view_errors"]) == [str(p) for p in photos[::-1]]
    assert given == reversed_
