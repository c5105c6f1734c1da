"""A small project folder for the bad-input tests of every command (test_outputs_not_inputs,
test_numeric_inputs): a unit box scene with a viewpoint, a camera, intrinsics, a photo and its
registered shot, correspondences, a marker map, a scan, a job and a folder of shots; and the
checks of the one-line error contract."""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.output import write_image

W, H = 64, 48
VIEW = "eye = [3, 2, 1.5]\ntarget = [0, 0, 0]\nwidth = 64\nheight = 48"
PHOTO = object()  # as a file's content: a grey photo of the shot's size


class Link:
    """As a file's content: a symlink to ``target`` (relative to the link's folder)."""

    def __init__(self, target):
        self.target = target


def camera() -> Camera:
    """The camera of the box's viewpoint "v" and of every shot."""
    return Camera.from_look_at((3, 2, 1.5), (0, 0, 0), (0, 0, 1), 60, W, H)


def manifest(mesh: str = "box.stl", part: str = "", view: str = "") -> str:
    """A manifest of one part ``mesh`` (``part``: more lines of its table) and the viewpoint "v"."""
    return (
        f'format = 1\n[[parts]]\nname = "box"\nmesh = "{mesh}"\nunits = "m"\n{part}\n'
        f'[[viewpoints]]\nname = "v"\n{VIEW}\n{view}\n'
    )


def shot(photo: str = "photo.png", **changes) -> dict:
    """A registered shot of the box whose photo is ``photo`` (relative to the shot's folder)."""
    return {**camera().to_dict(), "photo": photo, "rms": 0.1, **changes}


def intrinsics(**changes) -> dict:
    return {**{k: v for k, v in camera().to_dict().items() if k not in ("R", "t")}, **changes}


def correspondences() -> dict:
    """The box's eight corners and their pixels in the photo's camera."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    return {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(camera().project(corners), corners)]}


def marker_map() -> dict:
    return {
        "dictionary": "DICT_6X6_250",
        "markers": [
            {"id": 1, "corners": [[-0.2, -0.51, 0.2], [0.2, -0.51, 0.2], [0.2, -0.51, -0.2], [-0.2, -0.51, -0.2]]}
        ],
    }


def job(shots: str = '[[shots]]\nname = "s"\nshot = "shot.json"\n', extra: str = "") -> str:
    return f'scene = "scene.toml"\nmodes = ["phong"]\nwidth = 64\nsamples = 4\n{extra}\n{shots}'


def make_project() -> None:
    """The project's files in the current folder; ``linkdir`` links to the folder itself,
    ``linkout`` to ``out``, ``alias.json`` to corr.json."""
    trimesh.creation.box().export("box.stl")
    write_files(
        {
            "scene.toml": manifest(),
            "cam.json": camera().to_dict(),
            "photo.png": PHOTO,
            "shot.json": shot(),
            "intr.json": intrinsics(),
            "corr.json": correspondences(),
            "markers.json": marker_map(),
            "job.toml": job(),
            "shots/s.json": shot("../photo.png"),
            "linkdir": Link("."),
            "linkout": Link("out"),
            "alias.json": Link("corr.json"),
        }
    )
    np.savetxt("scan.xyz", trimesh.sample.sample_surface(trimesh.creation.box(), 300, seed=0)[0])


@pytest.fixture
def project(tmp_path, monkeypatch):
    """A fresh project folder (:func:`make_project`) as the working folder."""
    monkeypatch.chdir(tmp_path)
    make_project()
    return tmp_path


def write_files(files: dict) -> None:
    """name -> str, dict/list (as JSON, NaN and Infinity as Python writes them), PHOTO, Link or
    a callable(path)."""
    for name, content in files.items():
        path = Path(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, Link):
            path.unlink(missing_ok=True)
            path.symlink_to(content.target)
        elif content is PHOTO:
            write_image(path, np.full((H, W, 3), 128, np.uint8))
        elif callable(content):
            content(path)
        elif isinstance(content, str):
            path.write_text(content)
        else:
            path.write_text(json.dumps(content))


def snapshot() -> dict:
    """Every entry of the current folder: a symlink's target, a file's bytes (links not followed)."""
    out = {}
    for root, dirs, names in os.walk("."):
        for name in dirs + names:
            path = Path(root, name)
            if path.is_symlink():
                out[str(path)] = ("link", os.readlink(path))
            elif path.is_file():
                out[str(path)] = path.read_bytes()
    return out


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def with_port(args: list) -> list:
    """A review's command line on a free port (a refusal that came only after listening, as
    before the checks, must not fail on a port in use)."""
    return [*args, "--port", str(free_port())] if args[0] == "review" else args


def check_error(rc: int, err: str, out: str, *fragments: str) -> None:
    """Exit 1, nothing on stdout, no traceback, exactly one line ``error: ...`` (after any
    ``warning:`` lines) holding every fragment."""
    assert rc == 1, f"exit {rc}, stderr {err!r}"
    assert out == "", out
    assert "Traceback" not in err
    lines = err.splitlines()
    assert err.endswith("\n") and lines and lines[-1].startswith("error: "), f"no error line last: {err!r}"
    assert all(line.startswith("warning: ") for line in lines[:-1]), f"not one error line: {err!r}"
    for fragment in fragments:
        assert fragment in err, f"{fragment!r} not in {err!r}"


def run_refused(capsys, args: list, files: dict, *fragments: str) -> str:
    """Write ``files`` into the project, run ``mrcheck ARGS`` and check that it is refused
    (:func:`check_error` with ``fragments``) with nothing written: every file and link of the
    folder as before, no output, no temporary file, no database. Returns stderr."""
    write_files(files)
    before = snapshot()
    rc = main(with_port(args))
    captured = capsys.readouterr()
    check_error(rc, captured.err, captured.out, *fragments)
    assert snapshot() == before
    return captured.err
