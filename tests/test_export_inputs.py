"""``mrcheck export`` input validation: an output folder that cannot be made, a scene that does not
load and a bad or unreachable Dask scheduler are one line ``error: ...``, exit 1, nothing written.

Every case fails before any shot runs, so nothing is rendered here."""

from __future__ import annotations

import json
import socket

import numpy as np
import pytest

from mrcheck.apps.export import execute
from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.output import write_image
from mrcheck.core.resources import sample_scene_path


@pytest.fixture()
def job(tmp_path):
    """A valid one-shot job (a given SHOT.json) on the sample cell; ``scene`` is overridable."""
    camera = Camera.from_look_at((-11.4, -6.2, 1.7), (-5.0, -4.2, 0.9), (0, 0, 1), 60.0, 64, 48)
    write_image(tmp_path / "photo.png", np.full((48, 64, 3), 128, np.uint8))
    (tmp_path / "shot.json").write_text(json.dumps({**camera.to_dict(), "photo": "photo.png", "rms": 0.1}))

    def write(scene=str(sample_scene_path())):
        path = tmp_path / "job.toml"
        path.write_text(
            f'scene = "{scene}"\nmodes = ["phong"]\nwidth = 64\nsamples = 4\n[[shots]]\nshot = "shot.json"\n'
        )
        return path

    return write


def _export(capsys, *args):
    code = main(["export", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.err


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("where", ["/proc/x", "{tmp}/job.toml/out"])
def test_output_folder_that_cannot_be_made_is_one_line(where, job, tmp_path, capsys):
    path = job()
    out = where.replace("{tmp}", str(tmp_path))
    code, err = _export(capsys, path, "-o", out)
    assert code == 1
    assert err.startswith(f"error: {out}: cannot create or write to the output folder") and err.count("\n") == 1, err
    assert path.read_text().startswith("scene")  # the job file (a file, not a folder) is untouched


BAD_SCENES = {  # problem: (scene file, its content; None: the job's photo)
    "png": ("photo.png", None),
    "garbage_mesh": ("scene.glb", b"\x00\x01 not a mesh" * 10),
    "malformed_manifest": ("scene.toml", b"name = \n[[parts]"),
    "missing_mesh": ("scene.toml", b'[[parts]]\nmesh = "nowhere.glb"\n'),
}


@pytest.mark.parametrize("problem", sorted(BAD_SCENES))
def test_scene_that_does_not_load_is_a_bad_job(problem, job, tmp_path, capsys):
    name, content = BAD_SCENES[problem]
    if content is not None:
        (tmp_path / name).write_bytes(content)
    path = job(name)
    out = tmp_path / "out"
    code, err = _export(capsys, path, "-o", out)
    assert code == 1
    assert err.startswith(f"error: {path}: scene: ") and err.count("\n") == 1, err
    assert not out.exists()


@pytest.mark.parametrize("address", ["notanaddress", "unreachable"])
def test_bad_scheduler_leaves_no_outdir(address, job, tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr(execute, "SCHEDULER_TIMEOUT", "1s")
    if address == "unreachable":
        address = f"tcp://127.0.0.1:{_free_port()}"
    out = tmp_path / "out"
    code, err = _export(capsys, job(), "-o", out, "--scheduler", address)
    assert code == 1
    assert err.startswith(f"error: cannot connect to the Dask scheduler at {address}") and err.count("\n") == 1, err
    assert not out.exists()


def test_a_refused_scheduler_port_is_reported_at_once(job, tmp_path, capsys):
    """Dask retries a refused connection for its whole timeout (30 s); a closed port answers a
    plain TCP connect at once."""
    pytest.importorskip("distributed")
    import time

    address = f"tcp://127.0.0.1:{_free_port()}"
    start = time.perf_counter()
    code, err = _export(capsys, job(), "-o", tmp_path / "out", "--scheduler", address)
    assert code == 1 and "Connection refused" in err and err.count("\n") == 1, err
    assert time.perf_counter() - start < 10.0
    assert not (tmp_path / "out").exists()


def test_workers_with_a_scheduler_is_a_warning(job, tmp_path, capsys):
    code, err = _export(capsys, job(), "-o", tmp_path / "out", "--scheduler", "notanaddress", "--workers", "2")
    assert code == 1
    assert err.startswith("warning: --workers is ignored with --scheduler") and err.count("\n") == 2, err


def test_bad_scheduler_keeps_an_existing_outdir(job, tmp_path, capsys):
    pytest.importorskip("distributed")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    code, err = _export(capsys, job(), "-o", out, "--scheduler", "notanaddress")
    assert code == 1 and err.count("\n") == 1
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_a_job_file_with_a_byte_order_mark_is_read(job, tmp_path, capsys):
    """Windows Notepad saves UTF-8 with a BOM; tomllib calls that an invalid statement."""
    path = job()
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    code, err = _export(capsys, path, "-o", tmp_path / "out")
    assert code == 0, err


@pytest.mark.slow
def test_antialias_comes_from_the_job_and_the_command_line_overrides_it(job, tmp_path, capsys):
    """`antialias = false` in the job, or `--no-antialias`, renders without anti-aliasing; the
    setting is part of the manifest's settings and of the shots' fingerprints, so a switch redoes
    a shot instead of keeping the other setting's images; a value that is no bool is one line."""
    path = job()
    out = tmp_path / "out"

    def run(*options):
        code, err = _export(capsys, path, "-o", out, *options)
        assert code == 0, err
        manifest = json.loads((out / "manifest.json").read_text())
        return manifest["settings"]["antialias"], (
            out / manifest["shots"][0]["folder"] / "render_phong.png"
        ).read_bytes()

    on, smooth = run()
    off, plain = run("--no-antialias")
    assert (on, off) == (True, False) and smooth != plain  # redone, not skipped
    path.write_text(path.read_text().replace("samples = 4\n", "samples = 4\nantialias = false\n"))
    assert run() == (False, plain)
    assert run("--antialias") == (True, smooth)
    path.write_text(path.read_text().replace("antialias = false", 'antialias = "yes"'))
    code, err = _export(capsys, path, "-o", tmp_path / "out2")
    assert code == 1 and "antialias must be true or false" in err and err.count("\n") == 1
    assert not (tmp_path / "out2").exists()
