"""File names that are not valid UTF-8 (``Halle_S\\xfcd.png``, as a Latin-1 camera or a Windows
share names files; Linux allows any bytes in a name): every command that reads or writes files
works with them, prints them without a UnicodeEncodeError, and says them as ``\\xfc`` in messages.

OpenCV takes file names as UTF-8 and crashed the process on such a name (SIGSEGV, exit 139, no
message): ``overlay``, ``discrepancies``, ``review`` start-up, a ``.yml`` camera, a ``.yml``
calibration of such photos. Names reach JSON as Python's surrogate escapes (``\\udcfc``), which
Python reads back as the same name, and text files and messages as ``\\xfc``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.resources import sample_scene_path

from .bad_files import check_one_error, command, run, write_workspace

PREFIX = os.fsdecode(b"Halle_S\xfcd_")  # str with the surrogate escape of byte 0xFC
SHOWN = "Halle_S\\xfcd_"  # as messages and text files show it


def _allows_non_utf8_names(folder: Path) -> bool:
    try:
        (folder / PREFIX).touch()
    except (OSError, UnicodeEncodeError):
        return False
    (folder / PREFIX).unlink()
    return True


@pytest.fixture
def ws(tmp_path, monkeypatch):
    if not _allows_non_utf8_names(tmp_path):
        pytest.skip("this file system refuses names that are not valid UTF-8")
    monkeypatch.chdir(tmp_path)
    return write_workspace(tmp_path, PREFIX)


def _ok(args, capfd) -> tuple[str, str]:
    code, out, err = run(args, capfd)
    assert code == 0, err
    assert "error" not in err and "Traceback" not in err, err
    return out, err


def _read_json(path) -> dict:
    # the file is valid (ASCII) JSON; its non-UTF-8 names are \udcNN escapes
    data = Path(path).read_bytes()
    data.decode("ascii")
    return json.loads(data)


# -- every command works on such names ---------------------------------------------------------------
@pytest.mark.parametrize(
    "name", ["render", "render-manifest", "overlay", "reference", "compare", "scene-info", "scene-info-manifest"]
)
def test_renders_and_scene_commands(ws, capfd, name):
    out_dir = f"{PREFIX}out"
    out, _ = _ok(command(name, ws, out_dir), capfd)
    if name.startswith("scene-info"):
        assert "box" in out
        if name.endswith("manifest"):
            assert json.loads(out)["source"] == ws["manifest"]
    else:
        assert os.listdir(out_dir), "nothing written"


def test_register_writes_a_shot_that_names_the_photo(ws, capfd):
    out, _ = _ok(command("register", ws, f"{PREFIX}out"), capfd)
    shot = _read_json(f"{PREFIX}out/shot.json")
    assert shot["photo"] == f"../{ws['photo']}"  # relative to the shot: the same file, byte for byte
    assert (Path(f"{PREFIX}out") / shot["photo"]).is_file()


@pytest.mark.parametrize("suffix", [".json", ".yml"])
def test_calibrate_names_the_views(ws, capfd, suffix):
    args = command("calibrate", ws, f"{PREFIX}out")
    args[-1] = f"{PREFIX}out/{PREFIX}cam{suffix}"
    _ok(args, capfd)
    written = Path(args[-1])
    if suffix == ".json":
        assert set(_read_json(written)["per_view_errors"]) == set(ws["views"])
    else:  # OpenCV's YAML is UTF-8 text: the names as messages show them
        text = written.read_bytes().decode("utf-8")
        assert f"{SHOWN}view0.jpg" in text.replace("\\\\", "\\")
        from mrcheck.core.camerafiles import read_camera

        assert read_camera(written).width == 640


def test_a_yaml_camera_of_such_a_name_is_read(ws, capfd):
    from mrcheck.core.camerafiles import load_camera, write_camera

    cam = load_camera(ws["camera"])
    write_camera(f"{PREFIX}cam.yml", cam)
    _ok(["render", ws["mesh"], "--camera", f"{PREFIX}cam.yml", "-o", "out/r.png", "--mode", "phong"], capfd)


def test_discrepancies_texts_show_the_names(ws, capfd):
    _ok(command("discrepancies", ws, f"{PREFIX}out"), capfd)
    folder = Path(f"{PREFIX}out/discrepancies")
    assert _read_json(folder / "suspects.json")["shot"] == str(Path.cwd() / ws["shot"])
    assert f"{SHOWN}shot.json" in (folder / "suspects.md").read_bytes().decode("utf-8")
    assert (folder / "heatmap.png").is_file()


def test_deviation_texts_show_the_names(ws, capfd):
    _ok(command("deviation", ws, f"{PREFIX}out"), capfd)
    folder = Path(f"{PREFIX}out/deviation")
    assert _read_json(folder / "parts.json")["scan"] == ws["scan"]
    assert f"{SHOWN}scan.xyz" in (folder / "parts.md").read_bytes().decode("utf-8")
    assert {
        "deviation_top.png",
        "deviation_side.png",
        "deviation_render.png",
        "deviation_overlay.png",
        "deviations.npy",
    } <= set(os.listdir(folder))


def test_export_of_a_photo_with_such_a_name(ws, capfd):
    out, _ = _ok(command("export", ws, f"{PREFIX}out"), capfd)
    folder = Path(f"{PREFIX}out/export")
    manifest = _read_json(folder / "manifest.json")
    assert [s["status"] for s in manifest["shots"]] == ["done"]
    shot = _read_json(folder / "shots" / "a" / "SHOT.json")
    assert (folder / "shots" / "a" / shot["photo"]).resolve() == (Path.cwd() / ws["photo"]).resolve()
    (folder / "report.html").read_bytes().decode("utf-8")


def test_scene_asbuilt_of_a_manifest_with_such_a_name(tmp_path, capfd, monkeypatch):
    if not _allows_non_utf8_names(tmp_path):
        pytest.skip("this file system refuses names that are not valid UTF-8")
    import shutil

    cell = tmp_path / f"{PREFIX}cell"
    shutil.copytree(sample_scene_path().parent, cell)
    (cell / "scene.toml").rename(cell / f"{PREFIX}scene.toml")
    _ok(["scene", "asbuilt", cell / f"{PREFIX}scene.toml", "-o", tmp_path / f"{PREFIX}asbuilt"], capfd)
    text = (tmp_path / f"{PREFIX}asbuilt" / "scene.toml").read_bytes().decode("utf-8")
    assert f"{SHOWN}scene.toml" in text.splitlines()[0]
    tomllib.loads(text)
    report = _read_json(tmp_path / f"{PREFIX}asbuilt" / "discrepancies.json")
    assert report["planned"] == str(cell / f"{PREFIX}scene.toml")


def test_review_serves_shots_of_such_names(ws, tmp_path):
    from fastapi.testclient import TestClient

    from mrcheck.apps.review.app import create_app
    from mrcheck.apps.review.source import open_source

    source = open_source(ws["mesh"], ws["shots"])
    assert f"{SHOWN}shots" in source.label
    app = create_app(source, db_path=tmp_path / f"{PREFIX}review.sqlite", cache_dir=tmp_path / "cache", samples=4)
    with TestClient(app) as client:
        (name,) = source.shots
        assert client.get("/api/info").status_code == 200
        assert client.get(f"/api/shots/{name}/photo.png").status_code == 200
        marker = {"shot": name, "x": 10, "y": 10, "category": "missing", "severity": 2, "note": ""}
        assert client.post("/api/markers", json=marker).status_code == 201
        report = client.get("/api/export/report.html")
        assert report.status_code == 200 and SHOWN in report.text


# -- and says them in messages --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "name, role, content, problem",
    [
        ("overlay", "photo", b"just some text\n", "cannot read photo: a text file, not an image"),
        ("register", "photo", b"", "photo is empty"),
        ("render", "mesh", b"", "mesh file is empty"),
        ("deviation", "scan", b"\xff\xfe\x00binary", "not a text x y z point file"),
        ("discrepancies", "shot", b"{", "malformed shot JSON"),
        ("export", "job", b"scene = ", "malformed job TOML"),
    ],
)
def test_a_bad_file_of_such_a_name_is_named_as_xfc(ws, capfd, name, role, content, problem):
    Path(ws[role]).write_bytes(content)
    before = set(os.listdir("."))
    code, out, err = run(command(name, ws), capfd)
    check_one_error(code, err, SHOWN + Path(ws[role]).name.removeprefix(PREFIX), problem)
    assert set(os.listdir(".")) == before


# -- a real process: what the terminal and a pipe get -------------------------------------------------------
@pytest.mark.slow
def test_a_real_process_prints_such_names(ws, tmp_path):
    """stdout carries an output path as its bytes (a script can use it, as with ls and find);
    stderr shows it as \\xfc; with a strict UTF-8 stdout too (PYTHONIOENCODING=utf-8, as in a
    locale such as en_US.UTF-8), where print() raised UnicodeEncodeError after the work."""
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}
    output = f"{PREFIX}out/{PREFIX}render.png"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mrcheck.cli",
            "render",
            ws["mesh"],
            "--camera",
            ws["camera"],
            "--mode",
            "phong",
            "-o",
            output,
        ],
        capture_output=True,
        env=env,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == os.fsencode(output) + b"\n"
    Path(ws["camera"]).write_text("{")
    result = subprocess.run(
        [sys.executable, "-m", "mrcheck.cli", "render", ws["mesh"], "--camera", ws["camera"], "-o", output],
        capture_output=True,
        env=env,
        timeout=120,
    )
    assert result.returncode == 1
    assert (
        result.stderr.decode("utf-8") == f"error: {SHOWN}cam.json: malformed camera JSON: Expecting property name "
        "enclosed in double quotes at line 1\n"
    )


@pytest.mark.slow
def test_overlay_in_a_real_process_does_not_crash(ws):
    """The crash itself: cv2.imread on the photo's name was SIGSEGV (exit 139)."""
    result = subprocess.run(
        [sys.executable, "-m", "mrcheck.cli", *command("overlay", ws)], capture_output=True, timeout=120
    )
    assert result.returncode == 0, (result.returncode, result.stderr)
    image = np.frombuffer(Path("out/o.png").read_bytes(), np.uint8)
    assert image.size > 0
