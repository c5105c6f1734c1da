"""The progress of the deep loops (a scene's parts, levels of detail) goes to the display the
caller installed (the command line: a bar), never to a bar of the library's own (levels of
detail: tests/test_culling_lod.py)."""

from __future__ import annotations

from mrcheck.core.progress import no_progress, showing_progress, shown_progress
from mrcheck.core.resources import sample_scene_path
from mrcheck.scene.model import load_scene

SAMPLE = sample_scene_path()


def _recorder(seen: list):
    def progress(items, desc, unit):
        seen.append((desc, unit))
        yield from items

    return progress


def test_the_default_display_shows_nothing_and_a_set_one_is_undone_after_its_block():
    seen = []
    assert shown_progress() is no_progress
    with showing_progress(_recorder(seen)):
        assert shown_progress() is not no_progress
    assert shown_progress() is no_progress


def test_loading_a_scene_reports_its_parts_only_when_asked():
    seen = []
    with showing_progress(_recorder(seen)):
        quiet = load_scene(SAMPLE)
        assert seen == []
        loaded = load_scene(SAMPLE, progress=True)
    assert seen == [("loading scene", "part")]
    assert [p.name for p in loaded.parts] == [p.name for p in quiet.parts]
