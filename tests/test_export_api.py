"""The export's and the review's API below the command line: progress through a callback, the
result returned (nothing printed), one place for the file names, and HTML reports whose every
user-given string is escaped (they are Jinja2 templates with autoescape)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mrcheck.apps.export.job import JobSettings, load_job
from mrcheck.apps.export.report import render_report
from mrcheck.apps.export.run import ShotProgress, run_export
from mrcheck.apps.export.tasks import plan_outputs
from mrcheck.apps.names import RECORD, SHOT_FILE, is_export_name
from mrcheck.core.camera import Camera
from mrcheck.core.output import write_image
from mrcheck.core.resources import sample_scene_path
from mrcheck.render.renderer import MODES


@pytest.fixture()
def job(tmp_path):
    """A one-shot job (a given SHOT.json, a flat photo) on the sample cell."""
    camera = Camera.from_look_at((-11.4, -6.2, 1.7), (-5.0, -4.2, 0.9), (0, 0, 1), 60.0, 64, 48)
    write_image(tmp_path / "photo.png", np.full((48, 64, 3), 128, np.uint8))
    (tmp_path / "shot.json").write_text(json.dumps({**camera.to_dict(), "photo": "photo.png", "rms": 0.1}))
    path = tmp_path / "job.toml"
    path.write_text(
        f'scene = "{sample_scene_path()}"\nmodes = ["phong"]\nwidth = 64\nsamples = 4\n'
        '[[shots]]\nname = "one"\nshot = "shot.json"\n'
    )
    return path


def test_progress_is_a_callback_and_nothing_is_printed(job, tmp_path, capsys):
    steps = []
    result = run_export(job, tmp_path / "out", progress=steps.append)
    assert capsys.readouterr() == ("", "")  # the command line prints; the export returns
    assert steps[0] == ShotProgress(0, 1)
    assert (steps[1].done, steps[1].total, steps[1].name, steps[1].status, steps[1].failed) == (1, 1, "one", "done", 0)
    assert len(steps) == 2 and steps[1].eta_s == 0.0
    assert not result.failed and result.manifest["summary"] == {"shots": 1, "done": 1, "skipped": 0, "failed": 0}
    assert result.summary()[0].startswith("export: 1 shots: 1 done, 0 skipped, 0 failed (")
    assert result.summary()[-1] == f"wrote {tmp_path / 'out' / 'manifest.json'} and {tmp_path / 'out' / 'report.html'}"
    steps.clear()
    run_export(job, tmp_path / "out", progress=steps.append)
    assert steps == [ShotProgress(1, 1)]  # the rerun: the shot is finished, skipped from the start


@pytest.mark.slow
def test_workers_with_a_scheduler_is_a_python_warning(job, tmp_path):
    with pytest.warns(UserWarning, match="--workers is ignored with --scheduler"), pytest.raises(Exception):
        run_export(job, tmp_path / "out", workers=2, scheduler="notanaddress")


def test_every_planned_output_has_one_of_the_export_s_own_names(job):
    """The export removes only files with its own names: every file it plans must be one (else a
    rerun would leave it behind), and the planner's own files are not."""
    settings = JobSettings(
        str(sample_scene_path()), list(MODES), [0.0, 0.25, 1.0], [0.5, 1.0, 1e-05, 2.0], 1.0, None, None, 4, False
    )
    names = [o["file"] for o in plan_outputs(settings)] + [SHOT_FILE, RECORD]
    ao_modes = len(MODES) - 1  # phong renders once, every AO mode at each of the 4 intensities
    assert len(set(names)) == len(names) == 1 + ao_modes * 4 + len(MODES) * 3 + 1 + 2 and all(
        map(is_export_name, names)
    )
    for other in ("notes.txt", "render_phong.jpg", "overlay_vector_a0.5.png", "photo.png", "sheet.png.bak"):
        assert not is_export_name(other), other
    assert load_job(job).shots[0].inputs.to_dict() == {"shot": str(job.parent / "shot.json")}


HOSTILE = "<script>alert('x')</script> & \"quoted\""


def test_the_export_report_escapes_what_the_job_and_the_shots_give(tmp_path):
    manifest = {
        "job": f"/jobs/{HOSTILE}.toml",
        "summary": {"shots": 1, "done": 0, "skipped": 0, "failed": 1},
        "timings_s": {"total": 1.0},
        "executor": "local, 1 worker(s)",
        "settings": {"scene": f"/scenes/{HOSTILE}.toml", "modes": ["phong"]},
        "shots": [
            {
                "name": "a",
                "status": "failed",
                "error": f"photo {HOSTILE} is broken",
                "registration_error_px": None,
                "registration": {"method": HOSTILE, "rejected": [HOSTILE], "warnings": [HOSTILE]},
                "outputs": [],
                "timings_s": {HOSTILE: 0.5},
            }
        ],
    }
    report = render_report(manifest, tmp_path)
    assert (
        "<script>" not in report
        and "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt; &amp; &quot;quoted&quot;" in report
    )
    # the job, the scene, the error (table and card), the method, the rejected, the warning, the timing
    assert report.count("&lt;script&gt;") == 8


def test_the_review_report_escapes_notes_parts_and_names(tmp_path):
    from mrcheck.apps.review.report import report_html

    class Renders:
        def image(self, shot, kind, mode="phong", intensity=1.0):
            return np.zeros((40, 60, 3), np.uint8)

    source = SimpleNamespace(
        label=HOSTILE, scene=Path(f"/scenes/{HOSTILE}"), shots={"a": SimpleNamespace(served_scale=lambda: (1.0, 1.0))}
    )
    marker = {
        "id": 1,
        "shot": "a",
        "x": 10.0,
        "y": 10.0,
        "category": "other",
        "severity": 2,
        "note": HOSTILE,
        "part": HOSTILE,
        "distance": 1.5,
        "mode": None,
        "created": 0.0,
        "updated": 0.0,
        "offset": None,
    }
    report = report_html(source, Renders(), [marker, {**marker, "id": 2, "shot": HOSTILE}])
    # the label, the scene; the part and the note of each marker, the shot of the second
    assert "<script>" not in report and report.count("&lt;script&gt;alert(&#x27;x&#x27;)") == 7
    assert "no crops: the review no longer has this shot" in report
