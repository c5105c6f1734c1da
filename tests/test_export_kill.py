"""``kill -9`` of ``mrcheck export --workers 2``: its worker processes exit with it (none is left
writing shots into OUTDIR), and a rerun into the same OUTDIR resumes to a complete, clean export."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path

from .mr_helpers import make_camera

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

SHOTS = 30  # some seconds with two workers: the parent is killed after the first few records
EYE, TARGET = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])


def _job(folder: Path) -> Path:
    """SHOTS copies of one registered shot (a noise photo: nothing is registered, only rendered)."""
    camera = make_camera(160, 120, 125.0, eye=EYE, target=TARGET)
    cv2.imwrite(str(folder / "photo.png"), np.random.default_rng(0).integers(0, 255, (120, 160, 3), np.uint8))
    (folder / "shot.json").write_text(json.dumps(dict(camera.to_dict(), photo="photo.png")))
    shots = "".join(f'[[shots]]\nname = "s{i:02d}"\nshot = "shot.json"\n' for i in range(SHOTS))
    job = folder / "job.toml"
    job.write_text(
        f'scene = "{sample_scene_path()}"\nmodes = ["phong", "vector"]\nalphas = [0.5]\nwidth = 64\n'
        f"samples = 4\n{shots}"
    )
    return job


def _records(out: Path) -> int:
    return len(list(out.glob("shots/*/record.json")))


def _parents() -> dict:
    """{pid: parent pid} of every process still running (a zombie has finished: not counted)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                # "pid (comm) state ppid ...": comm may hold spaces and parentheses, the last ")" ends it
                state, ppid = (entry / "stat").read_text().rsplit(")", 1)[1].split()[:2]
            except (OSError, ValueError):
                continue  # gone meanwhile
            if state != "Z":
                parents[int(entry.name)] = int(ppid)
    return parents


def _descendants(pid: int) -> set:
    parents, found, frontier = _parents(), set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def _wait_for(condition, timeout: float, step: float = 0.05) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(step)
    return condition()


def test_kill_9_of_the_parent_ends_its_workers_and_a_rerun_resumes(tmp_path, capsys):
    job, out = _job(tmp_path), tmp_path / "out"
    log = (tmp_path / "export.log").open("wb")
    parent = subprocess.Popen(
        [sys.executable, "-m", "mrcheck.cli", "export", str(job), "-o", str(out), "--workers", "2"],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    workers = set()
    try:
        assert _wait_for(lambda: _records(out) >= 3 or parent.poll() is not None, 120), "no shot finished in 120 s"
        workers = _descendants(parent.pid)  # the two workers (and multiprocessing's resource tracker)
        assert parent.poll() is None and _records(out) < SHOTS, "the export finished before it could be killed"
        assert len(workers) >= 2, f"expected two worker processes, found {sorted(workers)}"
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        left = lambda: workers & set(_parents())  # noqa: E731
        assert _wait_for(lambda: not left(), 5), f"worker process(es) {sorted(left())} still running after kill -9"
        written = _records(out)
        time.sleep(2)
        assert _records(out) == written, "records are still being written after the export was killed"
    finally:
        log.close()
        for pid in workers & set(_parents()):  # what the test started: none left behind on a failure
            os.kill(pid, signal.SIGKILL)

    assert main(["export", str(job), "-o", str(out), "--workers", "2"]) == 0
    captured = capsys.readouterr().out
    assert f"export: {SHOTS} shots: {SHOTS - written} done, {written} skipped, 0 failed" in captured, captured
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted(s["name"] for s in manifest["shots"]) == [f"s{i:02d}" for i in range(SHOTS)]
    assert not list(out.glob("shots/*/.*.part")), "temp files of the killed run are left"
    for folder in sorted(out.glob("shots/*")):
        record = json.loads((folder / "record.json").read_text())
        assert record["status"] == "done" and record["name"] == folder.name
        for output in record["outputs"]:
            if not output["file"].endswith(".png"):
                json.loads((folder / output["file"]).read_text())  # SHOT.json
                continue
            image = cv2.imread(str(folder / output["file"]), cv2.IMREAD_UNCHANGED)
            assert image is not None, f"{folder / output['file']} does not decode"
            assert output["kind"] == "sheet" or image.shape[:2] == (48, 64), folder / output["file"]
