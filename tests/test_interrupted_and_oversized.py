"""Photos too large to decode refused from their header by every command that reads one
(``mrcheck --max-pixels``), unreadable inputs as one line, interrupted runs that do not block the
next, output folders that are new, empty or mrcheck's own, and shots of another size skipped or
warned about.

A stale partial is made by killing (SIGKILL) a process while it writes, or named with the id of a
process that has ended; a partial of a live process is left alone.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from mrcheck.core.images import MAX_PIXELS, check_pixels, encode_image, set_max_pixels

from .bad_files import check_one_error, command, run, write_workspace

ROOT_DIR = Path(__file__).resolve().parents[1]
WALL = ROOT_DIR / "tests" / "data" / "cad" / "ifc" / "wall-standard-case.ifc"


@pytest.fixture(autouse=True)
def default_limit():
    """``mrcheck --max-pixels`` sets the limit for the process: the next test starts from the default."""
    yield
    set_max_pixels(MAX_PIXELS)


@pytest.fixture
def ws(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path / "cache"))
    return write_workspace(tmp_path)


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header says ``width`` x ``height`` (RGB), with one row of data: decoded, it
    would take width * height * 3 bytes; its header alone says so."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = lambda kind, data: (  # noqa: E731
        struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    )
    row = zlib.compress(b"\0" * (1 + 3 * width))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", row) + chunk(b"IEND", b"")


def dead_pid() -> int:
    """The id of a process that has ended (not reused this soon: Linux hands out ids in turn)."""
    child = subprocess.Popen(["true"])
    child.wait()
    return child.pid


# -- 1. photo bombs, everywhere a photo is read ------------------------------------------------------
BOMB = "20000x20000 px (400.0 MP), over the limit of 64 MP (--max-pixels)"
PHOTO_COMMANDS = ["register", "overlay", "discrepancies", "deviation", "calibrate", "export"]


@pytest.mark.parametrize("name", PHOTO_COMMANDS)
def test_a_photo_bomb_is_refused_from_its_header(ws, capfd, name):
    """A 20000 x 20000 px PNG (1.2 GB decoded): refused at the default 64 MP, naming the file."""
    bomb = png_header(20000, 20000)
    if name == "calibrate":
        Path("bomb.png").write_bytes(bomb)
        args = ["calibrate", "bomb.png", *ws["views"][:1], "--board", "chessboard:9x6:0.025", "-o", "out/cam.json"]
    else:
        Path(ws["photo"]).write_bytes(bomb)
        args = command(name, ws)
    began = time.perf_counter()
    code, out, err = run(args, capfd)
    seconds = time.perf_counter() - began
    printed = out + err  # export lists its failed shots on stdout
    assert BOMB in printed and code == 1, printed
    line = next(line for line in printed.splitlines() if BOMB in line)
    assert ("bomb.png" if name == "calibrate" else ws["photo"]) in line, line
    assert seconds < 5, seconds


@pytest.mark.parametrize("name", ["overlay", "register"])
def test_max_pixels_sets_the_limit_of_every_command(ws, capfd, name):
    code, out, err = run(["--max-pixels", "3000", *command(name, ws)], capfd)
    check_one_error(code, err, ws["photo"], "photo is 64x48 px (0.0 MP), over the limit of 0.003 MP (--max-pixels)")
    code, out, err = run(["--max-pixels", "lots", *command(name, ws)], capfd)
    assert code == 1 and "'lots' is not a pixel count" in err


def test_image_sizes_of_every_format_from_pillows_header_readers():
    """Every format OpenCV writes here agrees with its decoded size; the review's limit test of
    the unread formats holds for HDR (only decoding would tell its size)."""
    image = np.zeros((37, 61, 3), np.uint8)
    for suffix in (".png", ".jpg", ".tif", ".bmp", ".webp", ".ppm", ".jp2", ".ras"):
        assert check_pixels(encode_image(suffix, image), 10_000) == (61, 37), suffix
    with pytest.raises(Exception, match=r"image is 30000x30000 px \(900.0 MP\), over the limit"):
        check_pixels(b"P6\n30000 30000\n255\n", 100)
    with pytest.raises(Exception, match=r"a HDR image: only PNG, JPEG, TIFF, BMP, GIF, WebP, AVIF"):
        check_pixels(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 30000 +X 30000\n", 100)


# -- tracks: a video's frames and stream ------------------------------------------------------------
def _video(path: Path, width: int, height: int, frames: int = 2) -> None:
    from mrcheck.eval.walks import write_video

    write_video(path, (np.full((height, width), 60 + 40 * k, np.uint8) for k in range(frames)))


def _track_args(folder: Path, video: Path, intrinsics: Path, out: Path) -> list:
    return [
        "track",
        video,
        "--scene",
        folder / "scene" / "scene.toml",
        "--intrinsics",
        intrinsics,
        "--initial",
        folder / "rough.json",
        "-o",
        out,
    ]


@pytest.fixture
def crate(tmp_path):
    """The crate scene, its camera at 480x360 and that camera's intrinsics at 240x180."""
    from mrcheck.core.camerafiles import write_camera
    from mrcheck.eval.edgescenes import crate_camera, write_crate_scene

    write_crate_scene(tmp_path / "scene")
    camera = crate_camera(480, 360)
    write_camera(tmp_path / "cam.json", camera, pose=False)
    write_camera(tmp_path / "small.json", camera.resized(240, 180), pose=False)
    write_camera(tmp_path / "rough.json", camera)
    return tmp_path


def test_a_video_of_frames_over_the_limit_is_refused(crate, capfd):
    _video(crate / "walk.mp4", 480, 360)
    args = _track_args(crate, crate / "walk.mp4", crate / "cam.json", crate / "out.mp4")
    code, out, err = run(["--max-pixels", "100000", *args], capfd)
    check_one_error(code, err, "walk.mp4", "video frame is 480x360 px (0.2 MP), over the limit of 0.1 MP")
    assert not (crate / "out.mp4").exists()


def test_a_video_without_a_video_stream_is_one_line(crate, capfd):
    import av

    with av.open(str(crate / "sound.mp4"), "w") as container:
        stream = container.add_stream("aac", rate=8000)
        frame = av.AudioFrame.from_ndarray(np.zeros((1, 1024), np.float32), format="fltp", layout="mono")
        frame.sample_rate = 8000
        for packet in [*stream.encode(frame), *stream.encode()]:
            container.mux(packet)
    code, out, err = run(_track_args(crate, crate / "sound.mp4", crate / "cam.json", crate / "out.mp4"), capfd)
    check_one_error(code, err, "sound.mp4", "has no video stream")


def test_track_warns_of_intrinsics_rescaled_and_removes_a_killed_runs_video(crate, capfd):
    """Intrinsics of 240x180 on a 480x360 video: K is rescaled, with a warning. A ``.track-*``
    video of a run that was killed, beside the output, is removed; a live run's is kept."""
    _video(crate / "walk.mp4", 480, 360)
    stale = crate / f".track-{dead_pid()}-x1y2.mp4"
    live = crate / f".track-{os.getppid()}-x1y2.mp4"  # the shell or pytest's parent: running
    stale.write_bytes(b"half a video")
    live.write_bytes(b"a video being written")
    code, out, err = run(_track_args(crate, crate / "walk.mp4", crate / "small.json", crate / "out.mp4"), capfd)
    assert code == 0, err
    assert "video is 480x360 but the intrinsics are for 240x180: K rescaled" in err, err
    assert err.startswith("warning: ") and "walk.mp4" in err.splitlines()[0], err
    assert not stale.exists() and live.exists()


# -- 2. unreadable OBJ in the companion-file check ----------------------------------------------------
@pytest.mark.parametrize("name", ["render", "deviation"])
def test_an_unreadable_obj_is_one_line(ws, capfd, name):
    """An OBJ that fails to read (an I/O error: /proc/self/mem reads as EIO for everyone, even root)."""
    os.symlink("/proc/self/mem", "box.obj")
    args = [str(a).replace(ws["mesh"], "box.obj") for a in command(name, ws)]
    code, out, err = run(args, capfd)
    check_one_error(code, err, "box.obj", "mesh file is empty")


@pytest.mark.skipif(shutil.which("setpriv") is None and os.geteuid() == 0, reason="needs another user than root")
def test_an_obj_without_read_permission_is_one_line():
    import tempfile

    import trimesh

    from .bad_files import camera

    folder = Path(tempfile.mkdtemp())  # not under pytest's 0700 folder: another user runs in it
    try:
        os.chmod(folder, 0o777)
        trimesh.creation.box().export(folder / "box.obj")
        os.chmod(folder / "box.obj", 0)
        (folder / "cam.json").write_text(json.dumps(camera().to_dict()))
        os.chmod(folder / "cam.json", 0o644)
        # root reads any file: the command runs as nobody, who must reach the repository's code
        prefix = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"] if os.geteuid() == 0 else []
        closed = [p for p in (ROOT_DIR, *ROOT_DIR.parents) if not p.stat().st_mode & stat.S_IXOTH]
        if prefix and closed:
            pytest.skip(f"{closed[0]} is closed to other users (a mktemp -d clone): nobody cannot import mrcheck")
        args = ["render", "box.obj", "--camera", "cam.json", "-o", "r.png"]
        env = {**os.environ, "PYTHONPATH": str(ROOT_DIR)}
        done = subprocess.run(
            [*prefix, sys.executable, "-m", "mrcheck.cli", *args], capture_output=True, text=True, env=env, cwd=folder
        )
        assert done.returncode == 1, done.stderr
        assert done.stderr == "error: box.obj: cannot read scene file: permission denied\n", done.stderr
        assert not (folder / "r.png").exists()
    finally:
        shutil.rmtree(folder)


# -- 3. interrupted work ------------------------------------------------------------------------------
def _killed_while_writing(script: str, *args) -> None:
    """Run ``script`` in a new Python, wait for it to print "writing", then SIGKILL it."""
    env = {**os.environ, "PYTHONPATH": str(ROOT_DIR)}
    child = subprocess.Popen(
        [sys.executable, "-c", script, *map(str, args)], stdout=subprocess.PIPE, env=env, text=True
    )
    assert child.stdout.readline().strip() == "writing"
    child.send_signal(signal.SIGKILL)
    child.wait()


KILLED_IMPORT = """
import sys, time
from pathlib import Path
from mrcheck.scene.importers import writer

def fill(work, model, header):
    (work / "scene.toml").write_text("half")
    print("writing", flush=True)
    time.sleep(120)

writer._fill = fill
from mrcheck.scene.importers.cache import import_scene
import_scene(sys.argv[1], sys.argv[2])
"""


def test_a_killed_scene_import_does_not_block_the_retry(tmp_path, capfd):
    out = tmp_path / "wall"
    _killed_while_writing(KILLED_IMPORT, WALL, out)
    assert [p.name.startswith(".mrcheck-partial-") for p in out.iterdir()] == [True]  # what the kill left
    code, _, err = run(["scene", "import", WALL, "-o", out], capfd)
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["README.md", "meshes", "scene.toml"]


def test_a_live_imports_partial_is_left_alone(tmp_path):
    from mrcheck.core.partials import remove_stale_partials

    (tmp_path / f".mrcheck-partial-{os.getppid()}-abc").mkdir()
    (tmp_path / f".mrcheck-partial-{dead_pid()}-abc").mkdir()
    (tmp_path / ".mrcheck-partial-notmine").mkdir()  # no process id: another program's
    remove_stale_partials(tmp_path, ".mrcheck-partial-")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f".mrcheck-partial-{os.getppid()}-abc", ".mrcheck-partial-notmine"]
    )


KILLED_CACHE = """
import sys, time
from pathlib import Path
from mrcheck.scene.importers import cache

def write_scene(model, outdir, header):
    Path(outdir).mkdir()
    (Path(outdir) / "scene.toml").write_text("half")
    print("writing", flush=True)
    time.sleep(120)

cache.write_scene = write_scene
cache.cached_manifest(sys.argv[1])
"""


def test_a_killed_cached_import_leaves_nothing_after_the_next(tmp_path, monkeypatch):
    from mrcheck.scene.importers.cache import cache_root, cached_manifest

    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path / "cache"))
    _killed_while_writing(KILLED_CACHE, WALL)
    assert [p.name[:9] for p in cache_root().iterdir()] == [".partial-"]
    result = cached_manifest(WALL)
    assert [p.name for p in cache_root().iterdir()] == [result.manifest.parent.name]


def test_a_truncated_cached_glb_is_imported_again(tmp_path, monkeypatch):
    from mrcheck.core.errors import MrcheckWarning
    from mrcheck.scene.importers.cache import cached_manifest
    from mrcheck.scene.model import load_scene

    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path / "cache"))
    first = cached_manifest(WALL)
    glb = next((first.manifest.parent / "meshes").glob("*.glb"))
    glb.write_bytes(glb.read_bytes()[: glb.stat().st_size // 2])  # a full disk, a killed copy
    with pytest.warns(MrcheckWarning, match=r"the cached import is damaged \(meshes/.*\.glb is \d+ bytes"):
        again = cached_manifest(WALL)
    assert not again.cached and again.manifest == first.manifest
    assert len(load_scene(again.manifest).parts) == 1
    assert cached_manifest(WALL).cached  # whole again: a hit


# -- 4. output folders: new, empty or mrcheck's ------------------------------------------------------
@pytest.mark.parametrize("name", ["deviation", "discrepancies"])
def test_results_are_not_written_among_a_users_files(ws, capfd, name):
    Path("suspects.md").write_text("my own notes\n")
    before = {p.name: p.read_bytes() for p in Path(".").iterdir() if p.is_file()}
    args = command(name, ws)
    args[args.index("-o") + 1] = "."
    code, out, err = run(args, capfd)
    check_one_error(code, err, [], "output folder holds other files and was not made by mrcheck")
    assert {p.name: p.read_bytes() for p in Path(".").iterdir() if p.is_file()} == before
    # a new folder, then the same folder again (mrcheck's), then an empty one: written
    args[args.index("-o") + 1] = "results"
    for _ in range(2):
        code, out, err = run(args, capfd)
        assert code == 0 and Path("results/.mrcheck-output").is_file(), err
    Path("empty").mkdir()
    args[args.index("-o") + 1] = "empty"
    assert run(args, capfd)[0] == 0


# -- 5. shots of another size ------------------------------------------------------------------------
def test_review_skips_a_shot_whose_photo_has_another_size(ws, recwarn):
    """Two shots in --shots DIR, one photo replaced by a smaller one: a warning naming its
    SHOT.json, and the review goes on with the other."""
    from mrcheck.apps.review.source import open_source
    from mrcheck.core.output import write_image

    cam = json.loads(Path("shots/a.json").read_text())
    write_image("small.png", np.zeros((24, 32, 3), np.uint8))
    Path("shots/b.json").write_text(json.dumps({**cam, "photo": "../small.png"}))
    source = open_source(ws["mesh"], "shots")
    assert list(source.shots) == ["a"]
    messages = [str(w.message) for w in recwarn]
    assert any(
        "b.json: its photo small.png is 32x24 but the shot was registered at 64x48 (skipped" in m for m in messages
    ), messages
    Path("shots/a.json").write_text(json.dumps({**cam, "photo": "../small.png"}))
    with pytest.raises(Exception, match="no usable shots to review: the photos of all 2 have another size"):
        open_source(ws["mesh"], "shots")


def test_export_workers_keep_the_limit_of_the_command_line(ws, capfd):
    """Shots made in spawned worker processes refuse a photo over ``mrcheck --max-pixels`` too."""
    job = Path(ws["job"]).read_text()
    Path(ws["job"]).write_text(job + '[[shots]]\nname = "b"\nshot = "shot.json"\n')
    code, out, err = run(["--max-pixels", "3000", "export", ws["job"], "-o", "out/export", "--workers", "2"], capfd)
    assert code == 1 and out.count("over the limit of 0.003 MP (--max-pixels)") == 2, out + err


def test_a_webp_over_pillows_own_limit_is_refused_with_its_pixel_count():
    """Pillow's WebP reader refuses above 179 MP itself (its decoder would allocate the canvas):
    one line with the pixel count, not an internal error."""
    from mrcheck.core.errors import MrcheckError

    side = (16383 - 1).to_bytes(3, "little")  # the largest WebP: 16383 x 16383 px, VP8X's canvas
    header = b"VP8X" + struct.pack("<I", 10) + b"\0" * 4 + side + side
    data = b"RIFF" + struct.pack("<I", 4 + len(header)) + b"WEBP" + header
    with pytest.raises(MrcheckError, match=r"^photo is 268.4 MP, over the limit of 64 MP \(--max-pixels\)$"):
        check_pixels(data, MAX_PIXELS, what="photo")
