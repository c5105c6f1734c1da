"""Navigate in the review (issue 42), in headless Chromium (Playwright, Debian's chromium): from a
640x480 shot of the sample cell, orbit, walk and come back to the shot, measure a known distance
on the floor, with the frame rates the page itself measures."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("fastapi")

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .mr_helpers import make_camera, sample_shot  # noqa: E402
from .test_review import needs_chromium, open_browser, ready_page, served_app  # noqa: E402

EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
# two floor points in view of the shot, 1.5 m apart
FLOOR_A, FLOOR_B = np.array([-7.5, -5.5, 0.0]), np.array([-6.0, -5.5, 0.0])


@pytest.fixture()
def shot(ctx, tmp_path):
    cam = make_camera(640, 480, 500.0, eye=EYE, target=TARGET)
    return sample_shot(ctx, tmp_path / "shots", cam), cam


def _wait_view(page, quality: str, after: int) -> int:
    """Wait for a frame of ``quality`` newer than id ``after``; its id."""
    page.wait_for_function(
        "([q, after]) => { const v = (document.body.dataset.view || '0|').split('|');"
        " return v[1] === q && Number(v[0]) > after; }",
        arg=[quality, after],
        timeout=30000,
    )
    return int(page.evaluate("document.body.dataset.view").split("|")[0])


def _client_xy(page, pixel) -> tuple[float, float]:
    """Where photo pixel ``pixel`` (x, y) is on the screen."""
    box = page.evaluate("(() => { const r = document.querySelector('#pane-a .photo').getBoundingClientRect();"
                        " return [r.left, r.top, r.width]; })()")  # fmt: skip
    scale = box[2] / 640.0
    return box[0] + (pixel[0] + 0.5) * scale, box[1] + (pixel[1] + 0.5) * scale


@pytest.mark.slow
@needs_chromium
def test_orbit_walk_back_to_the_shot_and_measure(shot, tmp_path, record_property):
    """Measured (this machine, 2 runs): 8.4 frames/s while moving (the drag moves every 100 ms, so
    about 10 is the most it can ask for), the converged frame (8 AO frames) 335 ms after the last
    move; the distance 1.503 m. The asserts: the targets of issue 42 (4 frames/s, 2 s)."""
    sync_api = pytest.importorskip("playwright.sync_api")
    root, cam = shot
    app = create_app(open_source(sample_scene_path(), root), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path)
        page, errors = ready_page(browser, url)
        page.click("#navigate")
        seen = _wait_view(page, "rest", 0)
        assert float(page.evaluate("document.body.dataset.away")) == 0.0
        # orbit: a slow drag, 30 steps over about 3 s, as a planner turns the view
        x, y = _client_xy(page, (320, 300))
        page.mouse.move(x, y)
        page.mouse.down()
        for step in range(30):
            page.mouse.move(x + 6 * (step + 1), y + 1 * (step + 1))
            page.wait_for_timeout(100)
        page.mouse.up()
        fps = float(page.evaluate("document.body.dataset.moveFps"))
        seen = _wait_view(page, "rest", seen)
        rest_ms = float(page.evaluate("document.body.dataset.restMs"))
        away = float(page.evaluate("document.body.dataset.away"))
        record_property("move_fps", fps)
        record_property("rest_ms", rest_ms)
        print(f"orbit: {fps:.1f} frames/s while moving, converged frame {rest_ms:.0f} ms after the last move")
        assert fps >= 4.0 and rest_ms <= 2000.0
        assert away > 40.0  # the photo has faded out
        assert float(page.evaluate("getComputedStyle(document.querySelector('#pane-a .photo')).opacity")) == 0.0
        # walk forward, then back to the shot: the photo is back, exactly at its pose
        page.keyboard.press("w")
        seen = _wait_view(page, "rest", seen)
        page.keyboard.press("h")
        seen = _wait_view(page, "rest", seen)
        assert float(page.evaluate("document.body.dataset.away")) == 0.0
        # measure two floor points 1.5 m apart, clicked where the shot's camera sees them
        page.keyboard.press("m")
        for point in (FLOOR_A, FLOOR_B):
            page.mouse.click(*_client_xy(page, cam.project(point[None])[0]))
            page.wait_for_timeout(300)
        page.wait_for_function("document.body.dataset.measure !== undefined", timeout=10000)
        measured = float(page.evaluate("document.body.dataset.measure"))
        page.screenshot(path=str(tmp_path / "navigate.png"))
        browser.close()
    assert not errors, errors
    # a click lands within half a pixel of the point: at 6-8 m and f = 500 px, about 1 cm on the floor
    assert measured == pytest.approx(np.linalg.norm(FLOOR_B - FLOOR_A), abs=0.03)
