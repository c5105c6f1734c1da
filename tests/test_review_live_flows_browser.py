"""The live check's other paths in a real browser (issue 42): headless Chromium with a fake camera
fed videos of Open3D photos of the sample cell with known cameras.

* The camera is covered for half a second in the middle of a walk: the track is lost, then
  tracked again within the accuracy of the walk; a frozen frame becomes a shot, a marker on it
  measures its offset from the CAD and the BCF export holds it as a topic.
* The shot's pose is wrong: Live starts from the markers in view (``--marker-map``), and from
  clicks on a frozen frame through "Add photo", whose saved shot Live starts from again.
"""

from __future__ import annotations

import io
import json
import time
import zipfile

import numpy as np
import pytest

pytest.importorskip("fastapi")

from mrcheck.apps.review.app import create_app  # noqa: E402
from mrcheck.apps.review.source import open_source  # noqa: E402
from mrcheck.core.camera import Camera  # noqa: E402
from mrcheck.core.output import write_image  # noqa: E402
from mrcheck.core.resources import sample_scene_path  # noqa: E402
from mrcheck.eval.edgephotos import reprojection_error, scene_points, synthetic_photo  # noqa: E402
from mrcheck.eval.walks import walk_camera  # noqa: E402
from mrcheck.mr.markers import parse_marker_map  # noqa: E402
from mrcheck.scene.model import load_scene  # noqa: E402

from .addphoto_helpers import project  # noqa: E402
from .addphoto_helpers import scene_points as clickable_points  # noqa: E402
from .mr_helpers import paste_marker, standing_marker  # noqa: E402
from .test_review import needs_chromium, open_browser, ready_page, served_app  # noqa: E402
from .test_review_live_browser import write_y4m  # noqa: E402

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

RATE, STEPS = 30, 90  # 30 frames/s; the walk: 90 frames of 0.27 cm (a planner's slow 8 cm/s)
COVERED = slice(40, 55)  # half a second of a covered lens
LIMIT_PX = 1.5  # as the live walk's (tests/test_review_live_browser.py)


def _fake_camera(tmp_path, photos) -> list[str]:
    write_y4m(tmp_path / "video.y4m", photos, rate=RATE)
    return [
        "--use-fake-device-for-media-stream",
        "--use-fake-ui-for-media-stream",
        f"--use-file-for-fake-video-capture={tmp_path / 'video.y4m'}",
    ]


def _shots(tmp_path, photo, camera) -> object:
    root = tmp_path / "shots"
    root.mkdir()
    write_image(root / "p1.png", photo)
    (root / "p1.json").write_text(json.dumps({**camera.to_dict(), "photo": "p1.png"}))
    return root


def _nearest_px(page, truths, points) -> float:
    """The page's latest pose against the nearest true camera (which video frame the fake camera
    showed the page cannot tell)."""
    pose = json.loads(page.evaluate("document.body.dataset.livePose"))
    found = Camera(320, 240, truths[0].K, np.array(pose["R"]), np.array(pose["t"]))
    return min(float(np.median(reprojection_error(t, found, points))) for t in truths)


def _tracked(page, truths, points, samples: int = 6) -> list[float]:
    """Poses sampled every 0.4 s, the lost ones left out, each against the nearest truth."""
    errors = []
    for _ in range(10 * samples):  # at most 4 s a sample
        if len(errors) == samples:
            break
        page.wait_for_timeout(400)
        if not json.loads(page.evaluate("document.body.dataset.livePose"))["lost"]:
            errors.append(_nearest_px(page, truths, points))
    assert len(errors) == samples, f"only {len(errors)} tracked poses in {4 * samples} s"
    return errors


def _freeze(page) -> str:
    """Freeze a tracked frame into a new shot; its name. The fake camera loops its file, covered
    stretch included: a frame frozen there is lost and not saved (the page says so and stops), so
    Live is started again and a tracked frame frozen, at most three times, as a planner would."""
    tracked = "(() => { const p = document.body.dataset.livePose; return p && !JSON.parse(p).lost; })()"
    for _ in range(3):
        page.wait_for_function(tracked, timeout=60000)
        page.click("#freeze")
        page.wait_for_function(
            "document.body.dataset.frozen || document.querySelector('#status').textContent.includes('not saved')",
            timeout=60000,
        )
        if page.evaluate("document.body.dataset.frozen"):
            return page.evaluate("document.body.dataset.frozen")
        page.click("#live")
    raise AssertionError("three frozen frames in a row were not tracked")


def _client_xy(page, pixel, width: int = 320) -> tuple[float, float]:
    """Where photo pixel ``pixel`` of the selected shot is on the screen."""
    box = page.evaluate("(() => { const r = document.querySelector('#pane-a .photo').getBoundingClientRect();"
                        " return [r.left, r.top, r.width]; })()")  # fmt: skip
    scale = box[2] / width
    return box[0] + (pixel[0] + 0.5) * scale, box[1] + (pixel[1] + 0.5) * scale


@needs_chromium
def test_lost_and_recovered_then_frozen_marked_and_in_bcf(tmp_path):
    """Lost while covered, then tracked again: the first poses after it settle (measured, 3 runs
    on an idle machine: 0.08-3.0 px 0.4 s after, 0.18-1.1 px at 0.8 s, then 0.06-0.21 px; one
    run inside a loaded CI suite: 2.4-6.9 px for 2.0 s, then 0.07-0.19 px), so of ten poses
    sampled 0.4 s apart the last four (from about 4.8 s on: with its nearest-truth search a
    sample takes 0.8 s) are held to the walk's limit (1.5 px). The ten take longer than the 6 s
    the walk takes forth and back, so it walks a second time uncovered; a run that sampled into
    the next covered stretch read 1.73 px there."""
    sync_api = pytest.importorskip("playwright.sync_api")
    scene = load_scene(sample_scene_path())
    camera = scene.camera("conveyor", 320, 240)
    truths = [walk_camera(camera, "side", 6 * k / STEPS) for k in range(STEPS + 1)]
    unique = [synthetic_photo(scene, c, 0, clutter=0, leave_out=False, colour=True)[0] for c in truths]
    covered = np.random.default_rng(0).normal(40, 6, (COVERED.stop - COVERED.start, 240, 320, 3))
    walk = [*unique[: COVERED.start], *np.clip(covered, 0, 255).astype(np.uint8), *unique[COVERED.stop :]]
    back = unique[-2:0:-1]
    # and back, then once more uncovered: the fake camera loops the file (12 s), and the poses
    # sampled after the recovery must not reach its next covered stretch
    photos = [*walk, *back, *unique, *back]
    root = _shots(tmp_path, unique[0], camera)
    app = create_app(open_source(sample_scene_path(), root), db_path=tmp_path / "r.sqlite", cache_dir=tmp_path / "c")
    points = scene_points(scene, truths[0])
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path, _fake_camera(tmp_path, photos))
        page, problems = ready_page(browser, url)
        page.click("#live")
        page.wait_for_function("Number(document.body.dataset.liveRecovered || 0) >= 1", timeout=90000)
        lost = int(page.evaluate("document.body.dataset.liveLost"))
        began = time.perf_counter()
        errors = _tracked(page, truths, points, 10)
        sampled = time.perf_counter() - began
        page.screenshot(path=str(tmp_path / "recovered.png"))

        frozen = _freeze(page)
        page.wait_for_function(f"document.body.dataset.loaded === '{frozen}|phong|1'", timeout=60000)
        page.mouse.click(*_client_xy(page, (200, 150)))  # a marker where the photo shows something
        page.wait_for_selector("#editor:not([hidden])", timeout=30000)
        page.click("#ed-measure")
        page.mouse.click(*_client_xy(page, (160, 150)))  # the CAD point that should be there
        page.wait_for_function("document.body.dataset.offset", timeout=30000)
        offset = float(page.evaluate("document.body.dataset.offset"))
        bcf = page.request.get(url + "api/bcf/markers.bcfzip").body()
        browser.close()
    with zipfile.ZipFile(io.BytesIO(bcf)) as z:
        markups = [z.read(n).decode() for n in z.namelist() if n.endswith("markup.bcf")]
        snapshots = [n for n in z.namelist() if n.endswith(".png") or n.endswith(".jpg")]
    print(
        f"lost {lost} frame(s), then tracked ({sampled:.1f} s): px to the nearest truth {np.round(errors, 2)}; offset {offset} m"
    )
    assert not problems, problems
    assert lost >= 1 and max(errors[6:]) < LIMIT_PX, (lost, errors)
    # 40 px across the view at about 4-6 m: decimetres (the API test checks the value itself)
    assert 0.05 < offset < 2.0, offset
    assert len(markups) == 1 and f"offset {offset:.3f} m" in markups[0] and snapshots, (markups, snapshots)


@needs_chromium
def test_live_starts_from_markers_and_from_clicks(tmp_path):
    """A still camera whose shot's pose is 0.6 m off. From the markers (one 0.5 m marker 3 m
    away): measured 0.05-0.2 px. From clicks: 8 pairs clicked where the points project, solved
    and saved in "Add photo", and Live tracking from that shot: measured 0.05-0.2 px. Limit
    1.5 px, as the walk's."""
    sync_api = pytest.importorskip("playwright.sync_api")
    scene = load_scene(sample_scene_path())
    truth = scene.camera("conveyor", 320, 240)
    marker_map = standing_marker(truth, (60, 190), 3.0, 0.5)
    photo = paste_marker(
        synthetic_photo(scene, truth, 0, clutter=0, leave_out=False, colour=True)[0], truth, marker_map
    )
    root = _shots(tmp_path, photo, walk_camera(truth, "side", 15))
    app = create_app(
        open_source(sample_scene_path(), root),
        db_path=tmp_path / "r.sqlite",
        cache_dir=tmp_path / "c",
        marker_map=parse_marker_map(marker_map),
    )
    points = scene_points(scene, truth)
    view = scene.camera("conveyor", 800)  # "Add photo" shows a CAD view at most 800 wide
    world = clickable_points(scene, view, 8, truth=truth)
    with served_app(app) as url, sync_api.sync_playwright() as pw:
        browser = open_browser(pw, tmp_path, _fake_camera(tmp_path, [photo] * 10))
        page, problems = ready_page(browser, url)
        page.select_option("#live-start", "markers")
        page.click("#live")
        page.wait_for_function("Number(document.body.dataset.liveFrames || 0) >= 3", timeout=90000)
        from_markers = _tracked(page, [truth], points, 3)

        page.click("#live-clicks")
        page.wait_for_selector("body[data-ap-open='1']", timeout=60000)
        page.wait_for_function("document.querySelector('#ap-photo-img').naturalWidth > 0", timeout=30000)
        page.select_option("#ap-view", "view:conveyor")
        page.wait_for_function("document.querySelector('#ap-cad-img').naturalWidth > 0", timeout=60000)
        for i, (p, c) in enumerate(zip(project(truth, world), project(view, world))):
            _click_pane(page, "#ap-left", "photo", p)
            _click_pane(page, "#ap-right", "cad", c)
            page.wait_for_selector(f"body[data-ap-pairs='{i + 1}']", timeout=30000)
        page.click("#ap-solve")
        page.wait_for_selector("body[data-ap-solved]", timeout=120000)
        page.click("#ap-save")
        page.wait_for_selector("body[data-ap-saved]", timeout=30000)
        page.wait_for_function("Number(document.body.dataset.liveFrames || 0) >= 3", timeout=90000)
        from_clicks = _tracked(page, [truth], points, 3)
        page.screenshot(path=str(tmp_path / "from_clicks.png"))
        browser.close()
    print(f"from markers: {np.round(from_markers, 2)} px; from clicks: {np.round(from_clicks, 2)} px")
    assert not problems, problems
    assert max(from_markers) < LIMIT_PX and max(from_clicks) < LIMIT_PX, (from_markers, from_clicks)


def _click_pane(page, pane: str, side: str, pixel) -> None:
    """Click image pixel ``pixel`` in an "Add photo" pane, as a planner would."""
    box = page.locator(pane).bounding_box()
    t = page.evaluate(f"AP.panes.{side}.t")
    page.mouse.click(box["x"] + t["x"] + (pixel[0] + 0.5) * t["s"], box["y"] + t["y"] + (pixel[1] + 0.5) * t["s"])
