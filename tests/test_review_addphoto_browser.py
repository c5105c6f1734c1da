"""The review's "Add photo" end to end in headless Chromium (Playwright, Debian's /usr/bin/chromium):
upload a photo of the sample cell, pick its intrinsics in the folder, click 8 points on it and the
same points on the CAD view, solve (ray cast, pose, edge snap), save; the saved shot's pose is
within 1 px (median, on the clicked scene points) and 2 cm of the camera that took the photo."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("fastapi")

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.camerafiles import load_shot  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .addphoto_helpers import VIEW, make_folder, median_error_px, project, scene_points, truth_camera  # noqa: E402
from .test_review import needs_chromium, open_browser, served_app  # noqa: E402

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

TOLERANCE_PX, TOLERANCE_M = 1.0, 0.02  # 1 px: the edge registration's accuracy target (issue 20)


def _click(page, pane: str, side: str, pixel) -> None:
    """Click the image pixel ``pixel`` (native pixels) in the pane ``pane`` as a planner would."""
    box = page.locator(pane).bounding_box()
    t = page.evaluate(f"AP.panes.{side}.t")
    page.mouse.click(box["x"] + t["x"] + (pixel[0] + 0.5) * t["s"], box["y"] + t["y"] + (pixel[1] + 0.5) * t["s"])


@needs_chromium
def test_add_a_photo_by_clicking_in_the_browser(ctx, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    shots = make_folder(ctx, tmp_path / "shots")
    scene = load_scene(sample_scene_path())
    world = scene_points(scene, scene.camera("robot", 800))
    photo_px, cad_px = project(truth_camera(), world), project(scene.camera("robot", 800), world)
    app = create_app(
        open_source(sample_scene_path(), shots), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "cache", samples=2
    )
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path)
        page = browser.new_page()
        page.goto(url)
        page.wait_for_selector("body[data-ready='1']", timeout=60000)
        page.click("#add-photo")
        page.wait_for_selector("body[data-ap-open='1']", timeout=60000)
        page.select_option("#ap-intrinsics", "folder:cam.json")
        page.set_input_files("#ap-photo-file", str(shots / "photo.png"))  # uploaded, though it is in the folder
        page.wait_for_function("document.querySelector('#ap-photo-img').naturalWidth > 0", timeout=30000)
        page.select_option("#ap-view", VIEW)
        page.wait_for_function("document.querySelector('#ap-cad-img').naturalWidth > 0", timeout=60000)
        for i, (p, c) in enumerate(zip(photo_px, cad_px)):
            _click(page, "#ap-left", "photo", p)
            _click(page, "#ap-right", "cad", c)
            page.wait_for_selector(f"body[data-ap-pairs='{i + 1}']", timeout=30000)
            if i == 2:  # 3 pairs: the page says what is missing, nothing is solved
                page.click("#ap-solve")
                page.wait_for_selector("#ap-msg.error", timeout=30000)
                assert "3 pair(s) of clicks: at least 4 are needed" in page.text_content("#ap-msg")
        page.click("#ap-solve")
        page.wait_for_selector("body[data-ap-solved]", timeout=120000)
        message = page.text_content("#ap-msg")
        assert "snapped onto the photo's edges" in message, message
        assert page.locator("#ap-residuals li").count() == len(world)
        page.wait_for_function("document.querySelector('#ap-overlay-img').naturalWidth > 0", timeout=30000)
        page.screenshot(path=str(tmp_path / "addphoto_solved.png"))
        page.click("#ap-save")
        page.wait_for_selector("body[data-ap-saved='photo-2']", timeout=30000)
        page.wait_for_selector("body[data-loaded='photo-2|phong|1']", timeout=60000)
        assert page.locator("#shot-list li[data-name='photo-2']").count() == 1
        page.screenshot(path=str(tmp_path / "addphoto_saved.png"))
        browser.close()
    camera, photo = load_shot(shots / "photo-2.json")
    assert photo == shots / "photo-2.png" and json.loads((shots / "photo-2.json").read_text())["method"] == "edges"
    error_px, error_m = median_error_px(camera, world), float(np.linalg.norm(camera.center - truth_camera().center))
    print(f"saved shot vs truth: median {error_px:.3f} px on the clicked points, camera centre {error_m * 1000:.1f} mm")
    assert error_px < TOLERANCE_PX and error_m < TOLERANCE_M
