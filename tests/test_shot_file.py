"""The SHOT.json record (:mod:`mrcheck.core.shot`): its reader and writer round-trip, the files
mrcheck wrote before the record existed read and write back byte for byte, and no module but
``mrcheck/core/shot.py`` writes or parses a shot's JSON.

``tests/data/shot/markers.json`` and ``edges.json`` are ``mrcheck register --markers`` (the
ChArUco photo of tests/data/calibration) and ``--initial`` (the crate scene) outputs as the
code wrote them when each writer built its own dict.
"""

from __future__ import annotations

import ast
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.shot import Shot, read_shot, shot_text, write_shot

REPO = Path(__file__).resolve().parent.parent
SHOTS = Path(__file__).parent / "data" / "shot"
WRITER = "mrcheck/core/shot.py"


def _camera() -> Camera:
    K = [[812.5, 0.0, 320.25], [0.0, 810.0, 239.5], [0.0, 0.0, 1.0]]
    R = Camera.from_look_at([3.0, -4.0, 2.0], [0.0, 0.0, 1.0], [0, 0, 1], 50.0, 640, 480).R
    return Camera(640, 480, K, R, [0.1, -0.2, 3.0], dist=[0.05, -0.01, 0.001, 0.0002, 0.0])


def test_write_then_read_gives_the_same_shot(tmp_path):
    photo = tmp_path / "photos" / "p 1.jpg"
    report = {
        "method": "points",
        "rms": 0.1234,
        "used": [{"index": 0, "pixel": [1.5, 2.0], "world": [0.1, 0.2, 0.3], "error_px": 0.2}],
        "rejected": [],
        "camera_position": [3.0, -4.0, 2.0],
        "expected_overlay_error_px": 1.25,
        "warnings": ["only 4 correspondences"],
    }
    shot = Shot(_camera(), photo, report)
    (tmp_path / "shots").mkdir()
    path = write_shot(tmp_path / "shots" / "SHOT.json", shot)
    back = read_shot(path)
    # the photo as the file names it, resolved against the shot's folder (not normalised: shots/../photos)
    assert back.photo is not None and back.photo.resolve() == photo.resolve()
    assert back.to_dict(photo="p") == shot.to_dict(photo="p")
    for name in ("K", "R", "t", "dist"):
        assert np.array_equal(getattr(back.camera, name), getattr(shot.camera, name)), name
    assert list(back.report) == list(report)  # the order is the file's
    assert (back.method, back.rms, back.warnings) == ("points", 0.1234, ["only 4 correspondences"])
    data = json.loads(path.read_text())
    assert data["photo"] == "../photos/p 1.jpg"  # relative to the shot's folder
    assert list(data)[:7] == ["width", "height", "K", "dist", "R", "t", "photo"]
    assert shot_text(back, path) == path.read_text()


@pytest.mark.parametrize("name", ["markers.json", "edges.json"])
def test_a_shot_written_before_the_record_reads_and_writes_back_byte_for_byte(tmp_path, name):
    path = tmp_path / name
    shutil.copy(SHOTS / name, path)
    shot = read_shot(path)
    assert shot.method == json.loads(path.read_text())["method"]
    assert shot.photo == tmp_path / json.loads(path.read_text())["photo"]
    assert shot_text(shot, path) == (SHOTS / name).read_text()
    write_shot(tmp_path / "again.json", shot)
    assert (tmp_path / "again.json").read_bytes() == (SHOTS / name).read_bytes()


def test_with_report_keeps_the_order_and_appends_new_fields():
    shot = Shot(_camera(), Path("/p.jpg"), {"method": "points", "rms": 1.0, "warnings": []})
    changed = shot.with_report(rms=None, clicks=[])
    assert list(changed.report) == ["method", "rms", "warnings", "clicks"]
    assert changed.rms is None and shot.rms == 1.0  # a new record, the old one unchanged


def test_a_shot_without_a_photo_is_a_one_line_error(tmp_path):
    path = tmp_path / "SHOT.json"
    path.write_text(json.dumps(_camera().to_dict()))
    with pytest.raises(MrcheckError, match='shot JSON has no "photo" path'):
        read_shot(path)
    with pytest.raises(ValueError):  # an image registered in memory has no file to name
        shot_text(Shot(_camera()), path)


# -- one writer, one reader -----------------------------------------------------------------
WRITERS = {"json.dumps", "json.dump", "write_camera", "write_text"}


def _dotted(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value)
        return f"{base}.{node.attr}" if base else None
    return None


def _shot_io(tree: ast.AST) -> set[str]:
    """How a module writes or parses a shot's JSON itself: a JSON or camera write of an object
    with a ``"photo"`` key, the photo reference only a SHOT.json holds, ``read_json(.., "shot")``."""
    found = set()
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = _dotted(node.func) or ""
        args = [*node.args, *(k.value for k in node.keywords)]
        if name.split(".")[-1] == "photo_reference":
            found.add("photo_reference")
        if name in WRITERS and any(
            isinstance(sub, ast.Dict) and any(isinstance(k, ast.Constant) and k.value == "photo" for k in sub.keys)
            for arg in args
            for sub in ast.walk(arg)
        ):
            found.add(f"{name} of a shot")
        if name.split(".")[-1] == "read_json" and any(isinstance(a, ast.Constant) and a.value == "shot" for a in args):
            found.add("read_json of a shot")
    return found


def test_only_the_shot_module_writes_or_parses_a_shot():
    offenders = {}
    for path in sorted((REPO / "mrcheck").rglob("*.py")):
        where = path.relative_to(REPO).as_posix()
        found = _shot_io(ast.parse(path.read_text(encoding="utf-8"), where))
        if found and where != WRITER:
            offenders[where] = found
    assert offenders == {}


def test_the_shot_check_sees_what_it_looks_for():
    """Not vacuous: the ways the shot was written and read in four places before the record."""
    bad = ast.parse(
        "def a(shot, out):\n    write_text(out, json.dumps({**shot, 'photo': photo_reference(p, out)}, indent=2))\n"
        "def b(shot, out):\n    write_camera(out, camera, {**extra, 'photo': ref})\n"
        "def c(path):\n    return read_json(path, 'shot')\n"
    )
    assert _shot_io(bad) == {
        "photo_reference",
        "json.dumps of a shot",
        "write_text of a shot",
        "write_camera of a shot",
        "read_json of a shot",
    }
    fine = ast.parse("def d(out, data):\n    write_text(out, json.dumps({'scene': 1}))\n    read_json(out, 'camera')\n")
    assert _shot_io(fine) == set()
