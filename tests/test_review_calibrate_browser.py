""" "Calibrate this camera" in a real browser (issue 42): headless Chromium with a fake camera
(``--use-fake-device-for-media-stream --use-file-for-fake-video-capture=FILE.y4m``) playing a
chessboard held at 20 poses in front of a known camera (tests/chessboard_photos.py); the page
sends frames, the server keeps the views, Solve calibrates, saves the camera and Live uses it
(its CAD layer comes at the calibrated size)."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("fastapi")

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.livecamera import calibrated_path  # noqa: E402
from mrcheck.core.camerafiles import read_camera  # noqa: E402

from .chessboard_photos import BOARD, TRUE, board_poses, chessboard_photo  # noqa: E402
from .test_review import box_review, needs_chromium, open_browser, ready_page, served_app  # noqa: E402
from .test_review_live_browser import write_y4m  # noqa: E402

POSES, HOLD, RATE = 20, 5, 10  # each pose held 0.5 s (a hand holding the board still), a 10 s loop
VIEWS = 12  # views kept before Solve
TOLERANCE_PX = 2.0


@pytest.mark.slow
@needs_chromium
def test_the_page_calibrates_the_fake_camera(tmp_path):
    """Measured spread of the solve on these frames (I420 and JPEG round trip, as the browser does):
    over 60 random 12-view subsets of the 20 poses fx, fy, cx, cy came within 0.54, 0.53, 0.56,
    0.66 px of the truth (std 0.17-0.24 px); 8-view subsets 1.2 px, 5-view 2.0 px at most. The page
    solves at 12 views or more: TOLERANCE_PX, 2 px (0.4 % of f), is 3x the 12-view worst case.
    Measured in the browser (3 runs, CI machine at load 3-6): 12 views kept in 10.3-10.5 s, fx, fy,
    cx, cy within 0.30 px of the truth (fx -0.23 to -0.24, fy -0.29 to -0.30), RMS 0.05 px."""
    sync_api = pytest.importorskip("playwright.sync_api")
    frames = [chessboard_photo(r, t, seed=k) for k, (r, t) in enumerate(board_poses(POSES))]
    write_y4m(tmp_path / "board.y4m", [f for f in frames for _ in range(HOLD)], rate=RATE)
    fake = ["--use-fake-device-for-media-stream", "--use-fake-ui-for-media-stream",
            f"--use-file-for-fake-video-capture={tmp_path / 'board.y4m'}"]  # fmt: skip
    source = box_review(tmp_path / "box", (0.0, 0.0, 0.0))
    app = create_app(source, db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c", samples=2, board=BOARD)
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path, fake)
        page, problems = ready_page(browser, url)
        page.click("#calibrate")
        page.wait_for_function(f"document.querySelector('#cb-board').value === {json.dumps(BOARD)}")
        assert page.is_disabled("#cb-solve")
        page.select_option("#cb-size", "640x480")
        page.click("#cb-start")
        page.wait_for_function(f"Number(document.body.dataset.calibViews || 0) >= {VIEWS}", timeout=60000)
        assert not page.is_disabled("#cb-solve")
        page.click("#cb-solve")
        page.wait_for_selector("body[data-calibrated]", timeout=30000)
        got = json.loads(page.evaluate("document.body.dataset.calibrated"))
        shown = page.inner_text("#cb-result")
        live = page.evaluate("fetch('api/live/camera').then((r) => r.json())")
        page.click("#cb-close")
        # Live now sends its frames at the calibrated size, and the server tracks at it
        page.click("#live")
        page.wait_for_function("Number(document.body.dataset.liveFrames || 0) >= 1", timeout=60000)
        layer = page.evaluate(
            "[document.querySelector('.live-layer').naturalWidth, document.querySelector('.live-layer').naturalHeight]"
        )
        page.click("#live")
        browser.close()
    off = {k: round(got[k] - getattr(TRUE, k), 2) for k in ("fx", "fy", "cx", "cy")}
    print(f"browser calibration: {got['views']} views, RMS {got['rms_px']} px, off the truth by {off} px")
    assert not problems, problems
    assert (got["width"], got["height"]) == (640, 480) and got["views"] >= VIEWS
    assert all(abs(d) < TOLERANCE_PX for d in off.values()), off
    assert got["rms_px"] < 0.5 and "fx" in shown and "+/-" in shown
    assert live == {"width": 640, "height": 480, "source": "calibrated"} and layer == [640, 480]
    assert read_camera(calibrated_path(tmp_path / "r.sqlite")).fx == pytest.approx(got["fx"], abs=1e-3)
