"""``mrcheck export``: a 6-shot job on the sample cell (one broken), restart, force, workers, Dask.

The photos are synthetic: the sample cell plus four ArUco markers (parts added in memory, the
job's scene stays the plain sample manifest), rendered from known cameras with a little barrel
distortion; four are a glob sharing one camera, one is an already registered SHOT.json, and one
"photo" is a corrupt file.
"""

from __future__ import annotations

import hashlib
import html
import json
import os
import re
import shutil
import sys
import time

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.output import write_image
from mrcheck.core.resources import sample_scene_path
from mrcheck.mr.registration import register_photo
from mrcheck.scene.model import Scene, load_scene

from .mr_helpers import make_camera, marker_parts, render_photo

EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
OFFSETS = [(0.0, 0.0, 0.0), (0.3, -0.2, 0.1), (-0.3, 0.2, -0.1), (0.2, 0.3, 0.0), (-0.2, -0.3, 0.1)]
GOOD = ["cam-0", "cam-1", "cam-2", "cam-3", "given"]
BROKEN = "cam-4"
PER_SHOT = {
    "SHOT.json",
    "render_phong.png",
    "render_vector_i0.5.png",
    "render_vector_i1.png",
    "overlay_phong_a0.png",
    "overlay_phong_a0.5.png",
    "overlay_vector_i1_a0.png",
    "overlay_vector_i1_a0.5.png",
    "sheet.png",
}


def _markers():
    fwd = (TARGET - EYE) / np.linalg.norm(TARGET - EYE)
    side = np.cross(fwd, (0, 0, 1.0))
    side /= np.linalg.norm(side)
    markers = []
    for marker_id, (d, s, z) in zip(
        (7, 23, 42, 61), ((4.5, -1.6, 1.2), (5.5, 1.7, 1.0), (6.5, -0.7, 2.6), (6.0, 1.1, 2.4))
    ):
        centre = EYE + fwd * d + side * s
        centre[2] = z
        to_cam = EYE - centre
        to_cam[2] = 0.0
        n = to_cam / np.linalg.norm(to_cam)
        right = np.cross((0, 0, 1.0), n)
        markers.append((marker_id, centre, right, np.cross(right, n), 0.7))
    return marker_parts(markers)


@pytest.fixture(scope="module")
def job_dir(ctx, tmp_path_factory):
    root = tmp_path_factory.mktemp("export_job")
    sample = load_scene(sample_scene_path())
    parts, marker_map = _markers()
    scene = Scene("markers", sample.source, sample.parts + parts, sample.viewpoints)
    dist = (-0.05, 0.0, 0.0, 0.0, 0.0)
    intrinsics = make_camera(320, 240, 250.0, dist=dist)
    (root / "camera.json").write_text(json.dumps(intrinsics.to_dict()))
    (root / "markers.json").write_text(json.dumps(marker_map))
    (root / "photos").mkdir()
    (root / "given").mkdir()
    for i, offset in enumerate(OFFSETS):
        truth = make_camera(320, 240, 250.0, dist=dist, eye=EYE + offset, target=TARGET)
        photo = render_photo(ctx, scene, truth, supersample=4)
        path = root / ("given/given.png" if i == 4 else f"photos/cam-{i}.png")
        write_image(path, photo)
    (root / "photos" / f"{BROKEN}.png").write_bytes(b"\x89PNG\r\n\x1a\n but not really a PNG")
    shot = register_photo(root / "given" / "given.png", intrinsics, marker_map=marker_map)
    (root / "given" / "given.json").write_text(json.dumps(shot.to_dict()))
    (root / "job.toml").write_text(f'''
scene = "{sample_scene_path()}"
modes = ["phong", "vector"]
alphas = [0.0, 0.5]
intensities = [0.5, 1.0]
width = 240
samples = 8
max_registration_error_px = 2.0
intrinsics = "camera.json"

[[shots]]
photos = "photos/*.png"
markers = "markers.json"

[[shots]]
shot = "given/given.json"
''')
    return root


def _export(capsys, job, out, *extra):
    start = time.perf_counter()
    code = main(["export", str(job), "-o", str(out), *map(str, extra)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err, time.perf_counter() - start


def _pngs(out) -> dict:
    return {
        p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(out.glob("shots/*/*.png"))
    }


@pytest.fixture(scope="module")
def first_run(job_dir):
    out = job_dir / "out1"
    start = time.perf_counter()
    code = main(["export", str(job_dir / "job.toml"), "-o", str(out)])
    return out, code, time.perf_counter() - start


@pytest.mark.slow
def test_six_shots_five_done_one_failed(first_run, capsys):
    out, code, seconds = first_run
    print(f"first run (1 worker, 6 shots): {seconds:.1f} s")
    assert code == 1
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["summary"] == {"shots": 6, "done": 5, "skipped": 0, "failed": 1}
    shots = {s["name"]: s for s in manifest["shots"]}
    assert set(shots) == set(GOOD) | {BROKEN}
    broken = shots[BROKEN]
    assert broken["status"] == "failed" and "cam-4.png" in broken["error"] and "truncated PNG" in broken["error"]
    # a failed shot's folder holds only its record, which says so (and is never "finished")
    assert [p.name for p in (out / "shots" / BROKEN).iterdir()] == ["record.json"]
    assert json.loads((out / "shots" / BROKEN / "record.json").read_text())["status"] == "failed"
    for name in GOOD:
        entry = shots[name]
        assert entry["status"] == "done", entry
        assert 0.0 <= entry["registration_error_px"] < 2.0
        assert entry["registration"]["method"] == "markers" and len(entry["registration"]["used"]) >= 3
        assert entry["timings_s"]["total"] > 0 and "render" in entry["timings_s"]
        files = {o["file"] for o in entry["outputs"]}
        assert files == PER_SHOT
        for o in entry["outputs"]:
            assert (out / o["path"]).is_file()
            if o["kind"] == "overlay":
                assert o["alpha"] in (0.0, 0.5) and o["mode"] in ("phong", "vector")
                assert o["intensity"] == (None if o["mode"] == "phong" else 1.0)
            if o["kind"] == "render" and o["mode"] == "vector":
                assert o["intensity"] in (0.5, 1.0)
        assert (out / "shots" / name / "record.json").is_file()
        registered = json.loads((out / "shots" / name / "SHOT.json").read_text())
        assert registered["width"] == 320
        # the photo relative to the shot's folder: OUTDIR and the photos can move together
        assert registered["photo"] == f"../../../{'given/given' if name == 'given' else 'photos/' + name}.png"
    sheet = cv2.imread(str(out / "shots" / "cam-0" / "sheet.png"))
    assert sheet.shape[1] > 3 * 240 and sheet.shape[0] > 2 * 180  # 240x180 panels: `width` scaled the shot
    overlay = cv2.imread(str(out / "shots" / "cam-0" / "overlay_vector_i1_a0.5.png"))
    assert overlay.shape == (180, 240, 3)
    # the render at alpha 0 is the overlay at alpha 0; the AO intensities differ
    assert np.array_equal(
        cv2.imread(str(out / "shots/cam-0/render_vector_i1.png")),
        cv2.imread(str(out / "shots/cam-0/overlay_vector_i1_a0.png")),
    )
    assert not np.array_equal(
        cv2.imread(str(out / "shots/cam-0/render_vector_i1.png")),
        cv2.imread(str(out / "shots/cam-0/render_vector_i0.5.png")),
    )

    report = (out / "report.html").read_text()
    order = sorted(GOOD, key=lambda n: shots[n]["registration_error_px"]) + [BROKEN]
    positions = [report.index(f'href="#shot-{name}"') for name in order]
    assert positions == sorted(positions)  # the table lists shots by registration error, failures last
    assert report.count("data:image/jpeg;base64,") == 5
    # the settings as the job file writes them (TOML), not Python's True / None
    params = re.search(r'<p class="timings">(scene = .*?)</p>', report).group(1)
    assert re.search(r"edges = (true|false)", params) and not re.search(r"\b(True|False|None)\b", params), params
    for href in re.findall(r'href="([^"#][^"]*)"', report):
        assert not href.startswith(("/", "http")) and ".." not in href and (out / href).is_file()
    assert not list(out.rglob("*.part"))


@pytest.mark.slow
def test_rerun_skips_and_force_redoes_byte_identically(first_run, job_dir, capsys):
    out, _, first_seconds = first_run
    job = job_dir / "job.toml"
    before = _pngs(out)
    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("shots/*/*")}
    code, stdout, _, seconds = _export(capsys, job, out)
    print(f"rerun: {seconds:.2f} s (first run {first_seconds:.1f} s)")
    assert code == 1  # the broken shot is retried and fails again
    assert "5 skipped" in stdout and "1 failed" in stdout and "failed cam-4" in stdout
    assert json.loads((out / "manifest.json").read_text())["summary"] == {
        "shots": 6,
        "done": 0,
        "skipped": 5,
        "failed": 1,
    }
    # nothing of the skipped shots was touched (the retried failure rewrote its record only)
    assert {p: t for p, t in mtimes.items() if p.parent.name != "cam-4"} == {
        p: p.stat().st_mtime_ns for p in out.glob("shots/*/*") if p.parent.name != "cam-4"
    }
    assert seconds < 3.0

    # a shot whose output vanished is redone, the others still skipped
    (out / "shots" / "cam-2" / "sheet.png").unlink()
    code, stdout, _, _ = _export(capsys, job, out)
    assert "1 done, 4 skipped, 1 failed" in stdout
    assert _pngs(out) == before

    code, stdout, _, _ = _export(capsys, job, out, "--force")
    assert code == 1 and "5 done, 0 skipped, 1 failed" in stdout
    assert _pngs(out) == before
    assert all(p.stat().st_mtime_ns != mtimes[p] for p in out.glob("shots/cam-0/*.png"))


@pytest.mark.slow
def test_two_workers_give_the_same_bytes(first_run, job_dir, capsys):
    out = job_dir / "out_workers2"
    code, stdout, _, seconds = _export(capsys, job_dir / "job.toml", out, "--workers", 2)
    print(f"2 workers: {seconds:.1f} s")
    assert code == 1 and "5 done" in stdout
    assert _pngs(out) == _pngs(first_run[0]) and len(_pngs(out)) == 5 * 8


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_bytes(first_run, job_dir, capsys):
    distributed = pytest.importorskip("distributed")
    out = job_dir / "out_dask"
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        code, stdout, _, seconds = _export(capsys, job_dir / "job.toml", out, "--scheduler", cluster.scheduler_address)
    print(f"dask, 2 workers: {seconds:.1f} s")
    assert code == 1 and "5 done" in stdout
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["summary"]["failed"] == 1 and manifest["executor"].startswith("dask")
    assert _pngs(out) == _pngs(first_run[0])


BAD_JOBS = {
    "malformed": 'scene = "x\n[[shots]',
    "missing_scene": 'scene = "nowhere/scene.toml"\n[[shots]]\nshot = "s.json"\n',
    "no_scene": '[[shots]]\nshot = "s.json"\n',
    "no_shots": 'scene = "{scene}"\n',
    "unknown_mode": 'scene = "{scene}"\nmodes = ["phong", "raytrace"]\n[[shots]]\nshot = "s.json"\n',
    "alpha_high": 'scene = "{scene}"\nalphas = [0.5, 1.5]\n[[shots]]\nshot = "s.json"\n',
    "alpha_negative": 'scene = "{scene}"\nalphas = [-0.1]\n[[shots]]\nshot = "s.json"\n',
    "unknown_key": 'scene = "{scene}"\nalpha = [0.5]\n[[shots]]\nshot = "s.json"\n',
    "empty_glob": 'scene = "{scene}"\n[[shots]]\nphotos = "none/*.jpg"\nintrinsics = "c.json"\nmarkers = "m.json"\n',
    "missing_intrinsics": 'scene = "{scene}"\n[[shots]]\nphoto = "p.jpg"\nintrinsics = "c.json"\nmarkers = "m.json"\n',
    "duplicate_name": 'scene = "{scene}"\n[[shots]]\nshot = "a/s.json"\n[[shots]]\nshot = "b/s.json"\n',
}


@pytest.mark.parametrize("problem", sorted(BAD_JOBS))
def test_bad_job_is_one_line_and_writes_nothing(problem, tmp_path, capsys):
    job = tmp_path / "job.toml"
    job.write_text(BAD_JOBS[problem].replace("{scene}", str(sample_scene_path())))
    out = tmp_path / "out"
    code, stdout, err, _ = _export(capsys, job, out)
    assert code == 1
    assert err.startswith(f"error: {job}: ") and err.count("\n") == 1, err
    assert not out.exists()
    if problem == "missing_intrinsics":  # a shot is named as the planner counts and knows it
        assert "[[shots]] #1 (photo = 'p.jpg')" in err, err


# -- reruns after edits, progress in a log, outputs a shrunk job no longer produces --------------------
@pytest.fixture()
def small_job(job_dir, tmp_path):
    """Two tiny shots (cam-0 by markers, a given SHOT.json) on a copy of the sample scene, every
    input a file of its own, so that a test can edit any of them."""
    shutil.copytree(sample_scene_path().parent, tmp_path / "scene")
    for name in ("photos/cam-0.png", "camera.json", "markers.json", "given/given.png"):
        shutil.copy(job_dir / name, tmp_path)
    given = json.loads((job_dir / "given" / "given.json").read_text())
    (tmp_path / "given.json").write_text(json.dumps(dict(given, photo="given.png")))

    def write(alphas="[0.0, 0.5]", shots='[[shots]]\nshot = "given.json"\n'):
        job = tmp_path / "job.toml"
        job.write_text(
            f'scene = "scene/scene.toml"\nmodes = ["phong"]\nalphas = {alphas}\nwidth = 64\nsamples = 4\n'
            f'[[shots]]\nphoto = "cam-0.png"\nintrinsics = "camera.json"\nmarkers = "markers.json"\n{shots}'
        )
        return job

    return write


def _touch(path):
    st = path.stat()  # a second later than now: an mtime the filesystem cannot round back to the old one
    os.utime(path, ns=(st.st_atime_ns, max(st.st_mtime_ns, time.time_ns()) + 1_000_000_000))


@pytest.mark.slow
def test_rerun_redoes_shots_whose_input_files_changed(small_job, capsys):
    job = small_job()
    out = job.parent / "out"
    assert "2 done" in _export(capsys, job, out)[1]
    assert "0 done, 2 skipped" in _export(capsys, job, out)[1]
    sheet = (out / "shots/cam-0/sheet.png").read_bytes()
    manifest = job.parent / "scene" / "scene.toml"
    text = manifest.read_text()
    assert "translate = [-5.8, -2.5, 0.0]" in text  # the conveyor, in front of cam-0
    manifest.write_text(text.replace("translate = [-5.8, -2.5, 0.0]", "translate = [-5.0, -2.5, 0.0]"))
    _touch(manifest)
    assert "2 done, 0 skipped" in _export(capsys, job, out)[1]
    assert (out / "shots/cam-0/sheet.png").read_bytes() != sheet  # the part moved in the new outputs too
    for changed, redone in [
        ("scene/meshes/pallet.glb", "2 done, 0 skipped"),
        ("cam-0.png", "1 done, 1 skipped"),
        ("camera.json", "1 done, 1 skipped"),
        ("markers.json", "1 done, 1 skipped"),
        ("given.json", "1 done, 1 skipped"),
        ("given.png", "1 done, 1 skipped"),
    ]:
        _touch(job.parent / changed)
        assert redone in _export(capsys, job, out)[1], changed
    assert "0 done, 2 skipped" in _export(capsys, job, out)[1]


class _ClosedReader:
    """stderr whose reader went away (``2>&1 | head -1``): every write fails with EPIPE."""

    def write(self, text):
        raise BrokenPipeError(32, "Broken pipe")

    flush = write

    def isatty(self):
        return False


@pytest.mark.slow
def test_a_closed_progress_reader_does_not_stop_the_export(small_job, monkeypatch):
    """The progress lines fail; the shots, the manifest and the report are still written (the
    export died after the first progress line, with neither)."""
    job = small_job()
    monkeypatch.setattr(sys, "stderr", _ClosedReader())
    assert main(["export", str(job), "-o", str(job.parent / "out")]) == 0
    manifest = json.loads((job.parent / "out" / "manifest.json").read_text())
    assert manifest["summary"]["done"] == 2 and (job.parent / "out" / "report.html").is_file()


@pytest.mark.slow
def test_the_manifest_counts_the_processes_that_ran_and_upscaling_is_a_warning(small_job, capsys):
    """--workers 8 for one shot runs it here: the manifest says 1 worker, not 8. A width above
    the photo's (320 px) upscales it: a warning in the manifest, the report and the summary."""
    job = small_job(shots="")
    job.write_text(job.read_text().replace("width = 64", "width = 400"))
    code, stdout, _, _ = _export(capsys, job, job.parent / "out", "--workers", 8)
    assert code == 0
    manifest = json.loads((job.parent / "out" / "manifest.json").read_text())
    assert manifest["executor"] == "local, 1 worker(s)"
    warning = "the job's width 400 is larger than the photo (320 px): the photo is upscaled"
    assert warning in manifest["shots"][0]["registration"]["warnings"]
    assert html.escape(warning) in (job.parent / "out" / "report.html").read_text()
    assert "1 shot(s) with registration warnings (cam-0): see report.html" in stdout


@pytest.mark.slow
def test_progress_in_a_log_is_lines_not_a_bar(small_job, capsys):
    job = small_job()
    code, _, err, _ = _export(capsys, job, job.parent / "out")  # captured stderr is not a terminal
    assert code == 0 and "\r" not in err
    lines = [line for line in err.splitlines() if line.startswith("export: ")]
    assert len(lines) == 2 and lines[1].startswith("export: 2/2 shots, ") and lines[1].endswith(", ETA 0 s")
    assert all(re.fullmatch(r"export: [12]/2 shots, (cam-0|given) done, ETA \d+ s", line) for line in lines), lines


@pytest.mark.slow
def test_a_failed_shot_keeps_no_earlier_outputs_and_goes_when_dropped(small_job, capsys):
    """A shot done once, then failing (its photo replaced by a blank one): the earlier images no
    longer match its inputs and go, a failed record.json stays; dropped from the job, its
    folder goes too (before, no record.json was left to recognise it by)."""
    job = small_job()
    out = job.parent / "out"
    assert _export(capsys, job, out)[0] == 0
    cv2.imwrite(str(job.parent / "cam-0.png"), np.full((240, 320, 3), 128, np.uint8))  # no markers any more
    code, stdout, _, _ = _export(capsys, job, out)
    assert code == 1 and "1 failed" in stdout
    folder = out / "shots" / "cam-0"
    assert [p.name for p in folder.iterdir()] == ["record.json"]
    assert json.loads((folder / "record.json").read_text())["status"] == "failed"
    assert _export(capsys, job, out)[0] == 1  # a failed record is never finished
    job = small_job(shots="")  # cam-0 stays, given goes ...
    job.write_text(job.read_text().replace('photo = "cam-0.png"', 'photo = "given.png"'))  # ... cam-0 too
    job.write_text(job.read_text().replace("[[shots]]\nphoto", '[[shots]]\nname = "other"\nphoto'))
    _export(capsys, job, out)
    assert not folder.exists() and not (out / "shots" / "given").exists()


@pytest.mark.slow
def test_outputs_the_job_no_longer_produces_are_removed(small_job, capsys):
    job = small_job()
    out = job.parent / "out"
    _export(capsys, job, out)
    (out / "shots" / "cam-0" / "notes.txt").write_text("mine")
    (out / "shots" / "mine").mkdir()  # no record.json: not a shot folder of the export
    (out / "shots" / "mine" / "sheet.png").write_bytes(b"mine")
    # alpha 0 dropped; the given shot dropped, but its exported SHOT.json is an input of the new job
    job = small_job("[0.5]", f'[[shots]]\nname = "again"\nshot = "{out}/shots/given/SHOT.json"\n')
    code, stdout, _, _ = _export(capsys, job, out)
    assert code == 0 and "2 done" in stdout and "removed 6 file(s) of earlier runs" in stdout
    assert "including the outputs of 1 shot(s) no longer in the job" in stdout  # given
    removed = json.loads((out / "manifest.json").read_text())["removed"]
    assert sorted(removed) == ["shots/cam-0/overlay_phong_a0.png"] + [
        f"shots/given/{name}"
        for name in ("overlay_phong_a0.5.png", "overlay_phong_a0.png", "record.json", "render_phong.png", "sheet.png")
    ]
    assert sorted(p.name for p in (out / "shots" / "cam-0").iterdir()) == [
        "SHOT.json",
        "notes.txt",
        "overlay_phong_a0.5.png",
        "record.json",
        "render_phong.png",
        "sheet.png",
    ]
    assert [p.name for p in (out / "shots" / "given").iterdir()] == ["SHOT.json"]
    assert (out / "shots" / "mine" / "sheet.png").read_bytes() == b"mine"
    assert (out / "shots" / "again" / "record.json").is_file()
    # an untouched rerun removes nothing more
    code, stdout, _, _ = _export(capsys, job, out)
    assert "0 done, 2 skipped" in stdout and "removed" not in stdout
    assert json.loads((out / "manifest.json").read_text())["removed"] == []
