"""The workspace of the file-name and unreadable-input tests: one small good input of every kind
(mesh, manifest, camera, intrinsics, photo, shot, correspondences, scan, job, shots folder,
calibration photos), the command line of every command that reads files, and the checks of
the bad-input contract on what a run printed and wrote."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.camera import Camera

W, H = 64, 48
CHESS = sorted((Path(__file__).parent / "data" / "calibration" / "opencv_chessboard").glob("left0[1-6].jpg"))
BOARD = "chessboard:9x6:0.025"
# what a C library prints on its own: none of it may reach the terminal
LIBRARY_NOISE = ("[ WARN", "[ERROR", "[ INFO", "libpng", "Corrupt JPEG", "Premature end", "TIFF", "Open3D", "RPly")


def camera() -> Camera:
    return Camera.from_look_at((3, 2, 1.5), (0, 0, 0), (0, 0, 1), 60, W, H)


def photo() -> np.ndarray:
    """A 64x48 photo with some structure (a grey ramp and a dark square)."""
    image = np.tile(np.linspace(60, 200, W, dtype=np.uint8), (H, 1))
    image[14:34, 22:42] = 30
    return np.dstack([image] * 3)


def correspondences(cam: Camera) -> dict:
    """Pixel <-> world pairs of the unit box's corners as ``cam`` sees them."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    rvec, _ = cv2.Rodrigues(cam.R)
    pixels, _ = cv2.projectPoints(corners, rvec, cam.t, cam.K, cam.dist)
    return {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels.reshape(-1, 2), corners)]}


def manifest(mesh: str = "box.stl") -> str:
    return (
        f'format = 1\n[[parts]]\nname = "box"\nmesh = "{mesh}"\nunits = "m"\n'
        f'[[viewpoints]]\nname = "v"\neye = [3, 2, 1.5]\ntarget = [0, 0, 0]\nwidth = {W}\nheight = {H}\n'
    )


def scan_text() -> str:
    """Points on the unit box's faces."""
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.5, 0.5, (60, 3))
    axis = np.arange(60) % 3
    points[np.arange(60), axis] = np.where(np.arange(60) % 2, 0.5, -0.5)
    return "".join(f"{x:.4f} {y:.4f} {z:.4f}\n" for x, y, z in points)


def write_workspace(folder: Path, prefix: str = "") -> dict:
    """Every good input, named ``prefix`` + its plain name (``prefix`` may hold surrogate escapes:
    a name that is not valid UTF-8). Returns {role: file name}."""
    cam = camera()
    names = {
        role: prefix + plain
        for role, plain in (
            ("mesh", "box.stl"),
            ("manifest", "scene.toml"),
            ("camera", "cam.json"),
            ("intrinsics", "intr.json"),
            ("photo", "photo.png"),
            ("shot", "shot.json"),
            ("points", "corr.json"),
            ("scan", "scan.xyz"),
            ("job", "job.toml"),
            ("shots", "shots"),
        )
    }
    file = lambda role: folder / names[role]  # noqa: E731
    trimesh.creation.box().export(file("mesh"))
    file("manifest").write_text(manifest())  # TOML is UTF-8: it names the plain box.stl
    if prefix:
        trimesh.creation.box().export(folder / "box.stl")
    file("camera").write_text(json.dumps(cam.to_dict()))
    file("intrinsics").write_text(json.dumps(cam.to_dict(pose=False)))
    file("photo").write_bytes(cv2.imencode(".png", photo())[1].tobytes())
    # json.dumps writes a name's undecodable bytes as \udcNN escapes, as mrcheck register does
    file("shot").write_text(json.dumps({**cam.to_dict(), "photo": names["photo"]}))
    file("points").write_text(json.dumps(correspondences(cam)))
    file("scan").write_text(scan_text())
    file("shots").mkdir()
    (file("shots") / f"{prefix}a.json").write_text(json.dumps({**cam.to_dict(), "photo": f"../{names['photo']}"}))
    # the job names plain files (TOML is UTF-8); its shot's SHOT.json names the photo
    if prefix:
        (folder / "shot.json").write_text(json.dumps({**cam.to_dict(), "photo": names["photo"]}))
    file("job").write_text(
        f'scene = "box.stl"\nmodes = ["phong"]\nalphas = [0.5]\nwidth = {W}\nsamples = 4\n'
        '[[shots]]\nname = "a"\nshot = "shot.json"\n'
    )
    for i, source in enumerate(CHESS):
        shutil.copyfile(source, folder / f"{prefix}view{i}.jpg")
    names["views"] = [f"{prefix}view{i}.jpg" for i in range(len(CHESS))]
    return names


# -- command lines ---------------------------------------------------------------------------------
def command(name: str, n: dict, out: str = "out") -> list:
    """The command line of ``name`` on the workspace files ``n`` (:func:`write_workspace`),
    writing under ``out``."""
    return {
        "render": ["render", n["mesh"], "--camera", n["camera"], "-o", f"{out}/r.png", "--output-ao", f"{out}/ao.npy"],
        "render-manifest": ["render", n["manifest"], "--view", "v", "--mode", "phong", "-o", f"{out}/r.png"],
        "overlay": ["overlay", n["shot"], "--scene", n["mesh"], "--mode", "phong", "-o", f"{out}/o.png"],
        "register": [
            "register",
            n["mesh"],
            "--photo",
            n["photo"],
            "--intrinsics",
            n["intrinsics"],
            "--points",
            n["points"],
            "-o",
            f"{out}/shot.json",
        ],
        "calibrate": ["calibrate", *n["views"], "--board", BOARD, "-o", f"{out}/cam.json"],
        "reference": [
            "reference",
            n["mesh"],
            "--camera",
            n["camera"],
            "--width",
            "16",
            "--height",
            "12",
            "--rays",
            "4",
            "-o",
            f"{out}/ref.npy",
        ],
        "compare": [
            "compare",
            n["manifest"],
            "--view",
            "v",
            "--width",
            "32",
            "--height",
            "24",
            "--rays",
            "4",
            "--samples",
            "4",
            "-o",
            f"{out}/compare",
        ],
        "export": ["export", n["job"], "-o", f"{out}/export"],
        "discrepancies": ["discrepancies", n["shot"], "--scene", n["mesh"], "-o", f"{out}/discrepancies"],
        "deviation": ["deviation", n["scan"], "--scene", n["mesh"], "--shot", n["shot"], "-o", f"{out}/deviation"],
        "scene-info": ["scene", "info", n["mesh"]],
        "scene-info-manifest": ["scene", "info", n["manifest"], "--json"],
        "scene-asbuilt": ["scene", "asbuilt", n["manifest"], "-o", f"{out}/asbuilt"],
        "review-job": ["review", n["job"]],
        "review-shots": ["review", n["mesh"], "--shots", n["shots"]],
    }[name]


class WouldServe(Exception):
    """Raised instead of binding the review's port: start-up succeeded (a test must not block)."""


@pytest.fixture
def no_serving(monkeypatch):
    """``mrcheck review`` stops where it would start serving: a case that should fail before
    does not block the test run, and one that should start up says so."""
    import mrcheck.apps.review.server

    def listen(host, port):
        raise WouldServe()

    monkeypatch.setattr(mrcheck.apps.review.server, "listen", listen)


class Blocked(BaseException):
    """Raised by :func:`time_limit`: a BaseException, so that no ``except OSError`` (TimeoutError
    is one) or the CLI's report of internal errors turns a blocked read into a clean error line
    and the test passes after a minute's wait."""


@pytest.fixture
def time_limit():
    """A reader blocked on a FIFO (no writer) fails the test after 60 s instead of hanging it."""

    def expired(signum, frame):
        raise Blocked("blocked for 60 s (reading a FIFO?)")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def run(args: list, capfd) -> tuple[int, str, str]:
    """``mrcheck ARGS`` in this process; (exit status, stdout, stderr) as the file descriptors
    saw them (what C libraries print included)."""
    code = main([str(a) for a in args])
    captured = capfd.readouterr()
    return code, captured.out, captured.err


def files_under(folder: Path) -> set:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir() or p.is_symlink()}


def check_one_error(code: int, err: str, names, problem: str) -> str:
    """Exit 1, one ``error:`` line naming every one of ``names`` and ``problem``, no traceback,
    no library noise. Returns the error line."""
    assert code == 1, f"exit {code}, stderr {err!r}"
    assert "Traceback" not in err, err
    noise = [word for word in LIBRARY_NOISE if word in err]
    assert not noise, f"library output {noise} on stderr: {err!r}"
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, f"not one error line: {err!r}"
    assert "internal error" not in errors[0], errors[0]
    for name in [names] if isinstance(names, str) else names:
        assert name in errors[0], f"{name!r} not named in {errors[0]!r}"
    assert problem in errors[0], f"{problem!r} not in {errors[0]!r}"
    return errors[0]


def fifo(path: Path) -> None:
    os.mkfifo(path)
