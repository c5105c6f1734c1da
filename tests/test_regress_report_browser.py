"""The HTML report of ``mrcheck regress check`` in headless Chromium (Playwright, Debian's
/usr/bin/chromium): it opens from the file system, says how many views changed, names the moved
conveyor, and every image of it loads (baseline, now, difference)."""

from __future__ import annotations

import shutil

import pytest

pytest.importorskip("fastapi")  # tests.test_review's helpers import the review app

from mrcheck.apps.regress.run import check, record  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .test_review import needs_chromium, open_browser  # noqa: E402


@pytest.mark.slow
@needs_chromium
def test_the_report_opens_in_chromium_and_shows_the_change(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    record(sample_scene_path(), tmp_path / "baseline", ["conveyor,overview"], size=(320, 240))
    moved = tmp_path / "moved"
    shutil.copytree(sample_scene_path().parent, moved)
    manifest = moved / "scene.toml"
    manifest.write_text(manifest.read_text().replace("translate = [-5.8, -2.5, 0.0]", "translate = [-5.5, -2.5, 0.0]"))
    result = check(manifest, tmp_path / "baseline", tmp_path / "report")
    assert not result.passed
    with sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path)
        try:
            page = browser.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(result.report.resolve().as_uri())
            page.wait_for_load_state("load")
            changed = len(result.changed)
            assert page.text_content("#verdict").strip() == f"{changed} of 2 view(s) changed"
            assert "conveyor" in page.text_content("#view-conveyor table.elements")
            widths = page.eval_on_selector_all("img", "imgs => imgs.map(i => i.complete ? i.naturalWidth : -1)")
            assert len(widths) == 2 * 2 * 3 and set(widths) == {320}, widths
            assert errors == []
        finally:
            browser.close()
