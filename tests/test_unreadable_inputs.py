"""Input files that cannot be read, for every command that reads files: a symlink loop, a folder
or a FIFO where a file belongs, an empty file, a file without read permission, and for photos a
text file or a truncated image with an image suffix.

Each is one line ``error: FILE: PROBLEM`` naming the file and the real problem (not "not found"
for a loop, not "not an image OpenCV decodes"), exit 1, no traceback, nothing a library prints
itself (OpenCV's ``[ WARN``, libpng's), nothing written; a FIFO is refused, not read forever. In
``export`` a shot whose photo or SHOT.json cannot be read fails alone, saying why, and the
others are done.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from .bad_files import (  # noqa: F401
    check_one_error,
    command,
    fifo,
    files_under,
    no_serving,
    run,
    time_limit,
    write_workspace,
)

PROBLEMS = {
    "loop": "symlink loop",
    "folder": "is a folder",
    "fifo": "not a regular file but a FIFO",
    "empty": "empty",
    "unreadable": "permission denied",
    "text": "a text file, not an image",
    "truncated": "truncated ",
}
ROOT = os.geteuid() == 0


def make_bad(path: Path, kind: str) -> None:
    """Replace the file ``path`` by an unreadable one of ``kind``."""
    data = path.read_bytes() if path.is_file() else b""
    path.unlink()
    if kind == "loop":
        os.symlink(path.name, path)  # a link to itself
    elif kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        fifo(path)
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "unreadable":
        path.write_bytes(data)
        path.chmod(0)
    elif kind == "text":
        path.write_text("Notes on the north wall, photo taken 9:30\n")
    elif kind == "truncated":
        path.write_bytes(data[: len(data) // 2])


# (command, role of the bad file): a scene argument (a mesh here, or a manifest) that is a folder
# is a scene folder, whose manifest is missing; review names a shot it skips in a warning
SCENE_ARGUMENT = {
    "render",
    "overlay",
    "register",
    "reference",
    "discrepancies",
    "deviation",
    "scene-info",
    "review-shots",
    "export",
}
CASES = [
    ("render", "mesh"),
    ("render", "camera"),
    ("render-manifest", "manifest"),
    ("render-manifest", "mesh"),
    ("overlay", "shot"),
    ("overlay", "photo"),
    ("overlay", "mesh"),
    ("register", "mesh"),
    ("register", "photo"),
    ("register", "intrinsics"),
    ("register", "points"),
    ("calibrate", "view"),
    ("reference", "mesh"),
    ("reference", "camera"),
    ("compare", "manifest"),
    ("compare", "mesh"),
    ("export", "job"),
    ("export", "mesh"),
    ("review-job", "job"),
    ("review-job", "shot"),
    ("review-shots", "mesh"),
    ("review-shots", "photo"),
    ("review-shots", "shots-file"),
    ("discrepancies", "shot"),
    ("discrepancies", "photo"),
    ("discrepancies", "mesh"),
    ("deviation", "scan"),
    ("deviation", "mesh"),
    ("deviation", "shot"),
    ("deviation", "photo"),
    ("scene-info", "mesh"),
    ("scene-info-manifest", "manifest"),
    ("scene-asbuilt", "manifest"),
]
IMAGES = {"photo", "view"}


def _params():
    for name, role in CASES:
        for kind in PROBLEMS:
            if kind in ("text", "truncated") and role not in IMAGES:
                continue
            marks = [pytest.mark.skipif(ROOT, reason="root reads any file")] if kind == "unreadable" else []
            yield pytest.param(name, role, kind, id=f"{name}-{role}-{kind}", marks=marks)


@pytest.fixture
def ws(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return write_workspace(tmp_path)


def _file(ws: dict, role: str) -> Path:
    if role == "view":
        return Path(ws["views"][0])
    if role == "shots-file":
        return Path(ws["shots"]) / "a.json"
    return Path(ws[role])


@pytest.mark.slow
@pytest.mark.usefixtures("no_serving", "time_limit")
@pytest.mark.parametrize("name, role, kind", list(_params()))
def test_an_unreadable_input_is_one_line_naming_it(ws, capfd, name, role, kind):
    bad = _file(ws, role)
    make_bad(bad, kind)
    args = command(name, ws)
    if name == "calibrate":
        args = ["calibrate", bad, *args[len(ws["views"]) + 1 :]]  # the bad photo alone
    before = files_under(Path("."))
    code, out, err = run(args, capfd)
    problem = PROBLEMS[kind]
    if kind == "folder" and (role == "manifest" or (role == "mesh" and name in SCENE_ARGUMENT)):
        problem = "no scene manifest"
    if kind == "folder" and name == "review-job" and role == "job":  # a folder to review is an export's
        problem = "not an export folder"
    if role in ("shots-file",) or (name == "review-job" and role == "shot"):
        # a shot that cannot be used is skipped with a warning naming it; no shot left is the error
        check_one_error(code, err, [], "no usable shots")
        warning = next(line for line in err.splitlines() if line.startswith("warning:"))
        assert bad.name in warning and problem in warning, warning
    else:
        check_one_error(code, err, bad.name, problem)
    assert out == ""
    assert files_under(Path(".")) == before, "an output was written"


# -- calibrate: photos that cannot be used are named, with why ----------------------------------------
def test_five_empty_photos_are_named(tmp_path, capfd):
    photos = [tmp_path / f"IMG_{i}.jpg" for i in range(5)]
    for photo in photos:
        photo.write_bytes(b"")
    code, out, err = run(["calibrate", *photos, "--board", "chessboard:9x6:0.025", "-o", tmp_path / "cam.json"], capfd)
    line = check_one_error(code, err, [p.name for p in photos], "5 images cannot be used (image is empty (0 bytes)")
    assert "board found in only 0 of 5 images" in line  # five photos, not one (their bytes are alike)
    assert not (tmp_path / "cam.json").exists()


def test_a_good_photo_set_with_bad_ones_calibrates_and_warns(ws, capfd):
    """Photos that cannot be read among enough good ones: skipped, each in a warning with why."""
    extra = {"empty.jpg": b"", "notes.jpg": b"just text\n", "cut.jpg": Path(ws["views"][0]).read_bytes()[:3000]}
    for name, data in extra.items():
        Path(name).write_bytes(data)
    os.symlink("loop.jpg", "loop.jpg")
    code, out, err = run(
        ["calibrate", *ws["views"], *extra, "loop.jpg", "--board", "chessboard:9x6:0.025", "-o", "cam.json"], capfd
    )
    assert code == 0, err
    warnings = {line.split(": ", 2)[1]: line.split(": ", 2)[2] for line in err.splitlines()}
    assert warnings == {
        "empty.jpg": "image is empty (0 bytes), skipped",
        "notes.jpg": "cannot read image: a text file, not an image, skipped",
        "cut.jpg": "cannot read image: truncated JPEG (the file ends before the image does: an "
        "interrupted copy or download?), skipped",
        "loop.jpg": "cannot read image: symlink loop (the link leads back to itself, directly or "
        "through other links), skipped",
    }
    assert json.loads(Path("cam.json").read_text())["skipped_views"] == [*extra, "loop.jpg"]


# -- export: only the shot fails -------------------------------------------------------------------------
@pytest.mark.usefixtures("time_limit")
@pytest.mark.parametrize(
    "role, kind",
    [
        (role, kind)
        for role in ("photo", "shot")
        for kind in PROBLEMS
        if kind != "unreadable" and (role == "photo" or kind not in ("text", "truncated"))
    ]
    + [pytest.param("photo", "unreadable", marks=pytest.mark.skipif(ROOT, reason="root reads any file"))],
)
def test_export_fails_only_the_shot_that_cannot_be_read(ws, capfd, role, kind):
    shutil.copyfile(ws["photo"], "bad.png")
    Path("bad.json").write_text(json.dumps({**json.loads(Path(ws["shot"]).read_text()), "photo": "bad.png"}))
    Path(ws["job"]).write_text(Path(ws["job"]).read_text() + '[[shots]]\nname = "b"\nshot = "bad.json"\n')
    bad = Path("bad.png" if role == "photo" else "bad.json")
    make_bad(bad, kind)
    code, out, err = run(command("export", ws), capfd)
    assert code == 1, err
    assert "Traceback" not in err and "error" not in err and "internal" not in out, (out, err)
    manifest = json.loads(Path("out/export/manifest.json").read_text())
    status = {s["name"]: (s["status"], s["error"]) for s in manifest["shots"]}
    assert status["a"] == ("done", None)
    assert status["b"][0] == "failed" and bad.name in status["b"][1] and PROBLEMS[kind] in status["b"][1], status
    assert f"failed b: {status['b'][1]}" in out
    assert os.listdir("out/export/shots/b") == ["record.json"]
    assert PROBLEMS[kind] in Path("out/export/report.html").read_text()


@pytest.mark.usefixtures("no_serving")
@pytest.mark.parametrize(
    "name, role",
    [
        ("render", "mesh"),
        ("overlay", "photo"),
        ("register", "points"),
        ("calibrate", "view"),
        ("deviation", "scan"),
        ("export", "job"),
        ("review-shots", "photo"),
        ("scene-info-manifest", "manifest"),
    ],
)
def test_permission_denied_is_said_by_every_reader(ws, capfd, monkeypatch, name, role):
    """What chmod 000 gives a user who is not root (the cases above are skipped for root, whom
    no permission stops): os.access says no for the one file, and every reader says so first."""
    bad = _file(ws, role).resolve()
    access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: Path(path).resolve() != bad and access(path, mode, **kw))
    args = command(name, ws)
    if name == "calibrate":
        args = ["calibrate", bad.name, *args[len(ws["views"]) + 1 :]]
    code, out, err = run(args, capfd)
    check_one_error(code, err, bad.name, "permission denied")
