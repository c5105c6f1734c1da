"""The marker editor's BCF status and comments, and the import's result, in headless Chromium
(Playwright, Debian's /usr/bin/chromium): a status chosen and a comment added in the page are
stored, shown, and exported to BCF; the element's name shows where its id was; a refused
import's reason is shown whole, with the option that fixes it."""

from __future__ import annotations

import pytest

pytest.importorskip("fastapi")

from mrcheck.apps.bcf import read_bcf_bytes  # noqa: E402
from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402

from .mr_helpers import make_camera, sample_shot  # noqa: E402
from .test_review import needs_chromium, open_browser, served_app  # noqa: E402
from .test_review_bcf import EYE, TARGET  # noqa: E402


@pytest.fixture()
def shots(ctx, tmp_path):
    return sample_shot(ctx, tmp_path / "shots", make_camera(320, 240, 250.0, eye=EYE, target=TARGET))


@pytest.mark.slow
@needs_chromium
def test_status_and_comments_in_the_marker_editor(shots, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    from fastapi.testclient import TestClient

    app = create_app(
        open_source(sample_scene_path(), shots),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "cache",
        samples=2,
        author="ana",
        max_upload=64 << 10,
    )
    with TestClient(app) as client:
        marker = client.post(
            "/api/markers", json={"shot": "p1", "x": 160, "y": 150, "category": "moved", "severity": 2}
        ).json()
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path)
        page = browser.new_page()
        page.on("dialog", lambda d: d.accept())
        page.goto(url)
        page.wait_for_selector("body[data-ready='1']", timeout=60000)
        page.click(f"#marker-list li[data-id='{marker['id']}']")
        page.wait_for_selector("#editor:not([hidden])")
        assert page.input_value("#ed-status") == "Open"
        page.select_option("#ed-status", "Resolved")
        page.wait_for_function("document.querySelector('#status').textContent.includes('saved')", timeout=10000)
        page.fill("#ed-comment", "welded on site <b>today</b>")
        page.click("#ed-comment-add")
        page.wait_for_selector("#ed-comment-list li", timeout=10000)
        item = page.text_content("#ed-comment-list li")
        assert "ana" in item and "welded on site <b>today</b>" in item  # as text, not markup
        assert "[Resolved]" in page.text_content(f"#marker-list li[data-id='{marker['id']}']")
        # a refused import: the whole reason, with the option to change, beside the link
        big = tmp_path / "big.bcfzip"
        big.write_bytes(b"PK" + b"\0" * (100 << 10))
        page.set_input_files("#import-bcf", str(big))
        page.wait_for_selector("#bcf-result.error", timeout=10000)
        result = page.locator("#bcf-result")
        assert "(--max-upload)" in result.text_content()
        assert page.evaluate("(e) => e.scrollWidth <= e.clientWidth", result.element_handle())  # nothing cut off
        page.screenshot(path=str(tmp_path / "bcf_editor.png"))
        browser.close()
    with TestClient(app) as client:
        (stored,) = client.get("/api/markers").json()
        (topic,) = read_bcf_bytes(client.get("/api/bcf/markers.bcfzip").content)
    assert stored["status"] == "Resolved" and stored["comments"][0]["text"] == "welded on site <b>today</b>"
    assert topic.status == "Resolved" and topic.comments[0].author == "ana"
