"""The command line and its output contracts (other tools and tests rely on them)."""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path

SCENE = str(sample_scene_path())
SMALL = ["--width", "160", "--height", "120"]
REPO = Path(__file__).resolve().parents[1]


def test_render_all_writes_the_labelled_study_sheet(tmp_path, capsys):
    out = tmp_path / "study.png"
    assert main(["render", SCENE, "--view", "overview", "--mode", "all", *SMALL, "-o", str(out)]) == 0
    sheet = cv2.imread(str(out))
    assert sheet.shape[1] >= 3 * 160 and sheet.shape[0] > 120  # three panels under a label bar
    assert str(out) in capsys.readouterr().out


@pytest.mark.slow
def test_output_ao_npy_contract(tmp_path):
    out, ao_path = tmp_path / "v.png", tmp_path / "ao.npy"
    args = ["render", SCENE, "--view", "robot", "--mode", "vector", "--no-blur", *SMALL, "-o", str(out)]
    assert main([*args, "--output-ao", str(ao_path)]) == 0
    ao = np.load(ao_path)
    assert ao.dtype == np.float32 and ao.shape == (120, 160)
    assert 0.0 <= ao.min() < 0.9 and ao.max() == 1.0
    # the same render again is bit-identical: fixed default seed
    again = tmp_path / "again.npy"
    assert main([*args, "--output-ao", str(again)]) == 0
    assert np.array_equal(np.load(again), ao)


def test_output_ao_png_is_16_bit_and_all_mode_writes_one_per_ao_mode(tmp_path):
    out = tmp_path / "all.png"
    assert (
        main(
            [
                "render",
                SCENE,
                "--view",
                "robot",
                "--mode",
                "all",
                *SMALL,
                "-o",
                str(out),
                "--output-ao",
                str(tmp_path / "ao.png"),
            ]
        )
        == 0
    )
    for mode in ("vector", "ssao"):
        ao = cv2.imread(str(tmp_path / f"ao_{mode}.png"), cv2.IMREAD_UNCHANGED)
        assert ao.dtype == np.uint16 and ao.shape == (120, 160) and ao.max() == 65535


def test_background_is_unoccluded_and_camera_json_works(tmp_path):
    # a camera looking into the sky over the cell: mostly background
    from mrcheck.core.camera import Camera

    cam = Camera.from_look_at((0, -30, 2), (0, 0, 30), (0, 0, 1), 40, 64, 48)
    cam_path = tmp_path / "sky.json"
    cam_path.write_text(json.dumps(cam.to_dict() | {"photo": "x.jpg", "rms": 0.3}))
    ao_path = tmp_path / "ao.npy"
    assert (
        main(["render", SCENE, "--camera", str(cam_path), "-o", str(tmp_path / "s.png"), "--output-ao", str(ao_path)])
        == 0
    )
    assert np.all(np.load(ao_path) == 1.0)


def test_half_resolution_ao_is_close_to_full_resolution(ctx):
    from mrcheck.render.renderer import Renderer, RenderSettings
    from mrcheck.scene.model import load_scene

    renderer = Renderer(load_scene(SCENE), ctx=ctx)
    camera = renderer.scene.camera("robot", 320, 240)
    full = renderer.render(camera, ["vector"], RenderSettings(), want_ao=True)["vector"].ao
    half = renderer.render(camera, ["vector"], RenderSettings(ao_scale=0.5), want_ao=True)["vector"].ao
    assert np.abs(full - half).mean() < 0.03


@pytest.mark.slow
def test_demo_writes_every_view_and_mode(tmp_path, capsys, monkeypatch):
    from mrcheck.render.renderer import Renderer

    rendered = []
    real = Renderer.render

    def render(self, camera, modes, *args, **kwargs):
        rendered.append(tuple(modes))
        return real(self, camera, modes, *args, **kwargs)

    monkeypatch.setattr(Renderer, "render", render)
    assert main(["demo", "-o", str(tmp_path), *SMALL]) == 0
    # only the modes it writes (it rendered all six, crytek, hbao and alchemy for nothing)
    assert rendered and set(rendered) == {("phong", "vector", "ssao")}
    printed = capsys.readouterr().out.split()
    names = {Path(p).name for p in printed}
    for view in ("overview", "robot", "conveyor", "cell_aisle", "cell_robot_cell", "cell_overview"):
        for kind in ("phong", "vector", "ssao", "study"):
            assert f"{view}_{kind}.png" in names
    assert all(Path(p).exists() for p in printed)


def test_help_explains_every_option(capsys):
    assert main(["render", "--help"]) == 0
    text = capsys.readouterr().out
    for option in (
        "--view",
        "--camera",
        "--mode",
        "--samples",
        "--radius-px",
        "--radius",
        "--falloff",
        "--intensity",
        "--blur",
        "--ao-scale",
        "--output-ao",
        "--seed",
        "--units",
    ):
        assert option in text


@pytest.mark.slow
def test_wheel_carries_shaders_and_sample_scene_and_renders_installed(tmp_path):
    # A non-editable install must find its shaders and the sample scene inside the package.
    wheel_dir, site = tmp_path / "wheel", tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheel_dir), str(REPO)],
        check=True,
        capture_output=True,
    )
    wheel = next(wheel_dir.glob("mrcheck-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert "mrcheck/_data/shaders/ao_vector.glsl" in names
    assert "factory_scenes/sample_cell/scene.toml" in names
    assert "factory_scenes/sample_cell/robots/kuka_iiwa/LICENSE.txt" in names
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
        check=True,
        capture_output=True,
    )
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import mrcheck.core.resources as r, mrcheck.cli as c;"
        "assert r.shader_dir().is_relative_to(sys.argv[1]), r.shader_dir();"
        "sys.exit(c.main(['demo', '-o', sys.argv[2], '--width', '64', '--height', '48']))"
    )
    run = subprocess.run(
        [sys.executable, "-c", code, str(site), str(tmp_path / "demo")], cwd=tmp_path, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "demo" / "robot_study.png").exists()


def test_two_renderers_interleaved_give_the_same_images(ctx):
    # moderngl draws on whatever context is current; creating a second context makes that one
    # current. Each Renderer must make its own current, or the first one draws into the second.
    from mrcheck.render.renderer import Renderer, RenderSettings
    from mrcheck.scene.model import load_scene

    scene = load_scene(SCENE)
    first = Renderer(scene, ctx=ctx)
    camera = scene.camera("robot", 96, 72)
    alone = first.render(camera, ["vector"], RenderSettings(), want_ao=True)["vector"]
    second = Renderer(scene)  # its own, new context
    other = second.render(scene.camera("overview", 64, 48), ["ssao"])
    again = first.render(camera, ["vector"], RenderSettings(), want_ao=True)["vector"]
    second.release()
    assert np.array_equal(again.ao, alone.ao) and np.array_equal(again.image, alone.image)
    assert other["ssao"].image.shape == (48, 64, 3)


def test_outputs_get_the_usual_file_permissions(tmp_path):
    import os

    out = tmp_path / "p.png"
    assert main(["render", SCENE, "--view", "robot", "--mode", "phong", *SMALL, "-o", str(out)]) == 0
    mask = os.umask(0)
    os.umask(mask)
    assert (out.stat().st_mode & 0o777) == (0o666 & ~mask)


def test_one_side_of_a_view_keeps_its_aspect_ratio(tmp_path):
    """--width alone scales the view's height too, as it does a camera file's (a 160x768 image
    was the surprise before)."""
    from mrcheck.scene.model import load_scene

    scene = load_scene(SCENE)
    vp = scene.viewpoints["robot"]
    w, h = vp.get("width", 1024), vp.get("height", 768)
    assert (scene.camera("robot", 160).width, scene.camera("robot", 160).height) == (160, round(h * 160 / w))
    assert scene.camera("robot", None, 90).width == round(w * 90 / h)
    assert (scene.camera("robot", 100, 50).width, scene.camera("robot", 100, 50).height) == (100, 50)
    out = tmp_path / "w.png"
    assert main(["render", SCENE, "--view", "robot", "--width", "160", "-o", str(out)]) == 0
    assert cv2.imread(str(out)).shape[:2] == (round(h * 160 / w), 160)


@pytest.mark.parametrize(
    "args",
    [
        ["bench", "--quick", "--json", "/proc/bench.json"],  # before minutes of benchmarking
        ["demo", "-o", "/proc/demo"],
    ],
)
def test_unwritable_outputs_fail_before_the_work(capsys, args):
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "folder /proc is not writable" in err


def test_a_bug_is_one_line_and_its_traceback_is_one_variable_away(tmp_path, capsys, monkeypatch):
    """Whatever escapes every check is a bug: one line naming it (exit 1), not a traceback;
    MRCHECK_DEBUG=1 lets the exception through for the developer."""
    import mrcheck.render.views

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(mrcheck.render.views, "render_command", broken)
    args = ["render", SCENE, "--view", "robot", "-o", str(tmp_path / "x.png")]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: internal error")
    assert "ZeroDivisionError: float division by zero" in err and "MRCHECK_DEBUG=1" in err
    monkeypatch.setenv("MRCHECK_DEBUG", "1")
    with pytest.raises(ZeroDivisionError):
        main(args)


@pytest.mark.parametrize(
    "mode, options, warned",
    [
        ("ssao", ["--radius-px", "5"], ["--radius-px"]),
        ("vector", ["--radius", "0.5", "--min-world-radius", "0.1"], ["--radius "]),
        ("phong", ["--samples", "8", "--no-blur"], ["--samples", "--blur/--no-blur"]),
        ("all", ["--radius-px", "5", "--radius", "0.5"], []),  # D2 reads the one, D3 the other
        ("vector", ["--samples", "8"], []),
    ],
)
def test_an_option_no_chosen_mode_reads_is_a_warning(tmp_path, capsys, mode, options, warned):
    out = tmp_path / "r.png"
    assert main(["render", SCENE, "--view", "robot", "--mode", mode, *SMALL, *options, "-o", str(out)]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert len(warnings) == len(warned), warnings
    for line, option in zip(warnings, warned):
        assert line.startswith(f"warning: {option}") and f"no effect in mode {mode}" in line
    assert out.exists()


def test_a_screen_radius_larger_than_the_image_is_refused(tmp_path, capsys):
    out = tmp_path / "r.png"
    assert main(["render", SCENE, "--view", "robot", *SMALL, "--radius-px", "121", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "radius of 121 px is larger than the image (120 px high)" in err[0]
    assert not out.exists()
    assert main(["render", SCENE, "--view", "robot", *SMALL, "--radius-px", "120", "-o", str(out)]) == 0


def _camera_looking_up(tmp_path) -> Path:
    """The conveyor camera turned to look straight up from 20 m above the cell: nothing in view."""
    data = json.loads((REPO / "calibration" / "sample_cell_conveyor.json").read_text())
    data["R"], data["t"] = np.eye(3).tolist(), [0.0, 0.0, -20.0]
    path = tmp_path / "up.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("command, out", [("render", "r.png"), ("reference", "r.npy")])
def test_a_camera_that_sees_no_part_is_a_warning(tmp_path, capsys, command, out):
    """A background-only image (a wrong pose, a camera kilometres away after a unit mix-up) was
    written with exit 0 and nothing said, where overlay and discrepancies warn."""
    up = _camera_looking_up(tmp_path)
    extra = ["--rays", "4"] if command == "reference" else ["--mode", "phong"]
    assert main([command, SCENE, "--camera", str(up), "--width", "64", *extra, "-o", str(tmp_path / out)]) == 0
    err = capsys.readouterr().err
    assert f"warning: {up}: no CAD part is in view of this camera (a wrong pose, or units?)" in err.splitlines()
    assert (tmp_path / out).exists()
    # a camera that sees the cell says nothing of the kind
    assert main([command, SCENE, "--view", "robot", "--width", "64", *extra, "-o", str(tmp_path / out)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_render_warns_about_parts_without_declared_units(tmp_path, capsys):
    """As `scene info` does: a part in mm read as metres is 1000x too big, and the render alone
    gave no hint of it."""
    text = Path(SCENE).read_text()
    first = text.index("units")
    line_end = text.index("\n", first)
    (tmp_path / "scene.toml").write_text(text[:first] + "# " + text[first:line_end] + text[line_end:])
    for path in sample_scene_path().parent.iterdir():
        if path.name != "scene.toml":
            (tmp_path / path.name).symlink_to(path)
    assert (
        main(
            [
                "render",
                str(tmp_path / "scene.toml"),
                "--view",
                "robot",
                "--mode",
                "phong",
                "--width",
                "64",
                "-o",
                str(tmp_path / "r.png"),
            ]
        )
        == 0
    )
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "1 part(s) without declared units" in warnings[0], warnings


def test_blur_size_has_a_stated_maximum_checked_before_the_work(tmp_path, capsys, monkeypatch):
    """--blur-size 100001 failed after the scene load with the GL linker's complaint about
    uniform components: the kernel's weights are a uniform array."""
    from mrcheck.render.blur import MAX_BLUR_SIZE

    out = tmp_path / "r.png"
    args = ["render", SCENE, "--view", "robot", "--width", "64", "-o", str(out)]
    assert main([*args, "--blur-size", str(MAX_BLUR_SIZE)]) == 0
    capsys.readouterr()

    def no_load(*a, **k):
        raise AssertionError("the scene was loaded before --blur-size was checked")

    monkeypatch.setattr("mrcheck.render.views.load_scene", no_load)
    out.unlink()
    for size in (MAX_BLUR_SIZE + 2, 100001):
        assert main([*args, "--blur-size", str(size)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"must be odd, 3 to {MAX_BLUR_SIZE}, got {size}" in err[0], err
    assert not out.exists()
    assert main(["render", "--help"]) == 0
    assert f"odd, 3 to {MAX_BLUR_SIZE}" in " ".join(capsys.readouterr().out.split())  # the help states it


@pytest.mark.parametrize("width", [40, 100, 160])
def test_sheet_labels_fit_their_panels_at_small_widths(width):
    """At --width 100 the labels ran off their panels ("D2 vector SS", "D3 standard")."""
    from mrcheck.core.output import labelled_sheet
    from mrcheck.render.renderer import STUDY_LABELS

    h = width * 3 // 4
    images = [np.zeros((h, width, 3), np.uint8) for _ in range(3)]
    sheet = labelled_sheet(images, [STUDY_LABELS[m] for m in ("phong", "vector", "ssao")])
    bar = sheet.shape[0] - h
    gap = (sheet.shape[1] - 3 * width) // 2
    for i in range(3):
        panel = sheet[:bar, i * (width + gap) : i * (width + gap) + width]
        text = np.nonzero((panel > 32).any(axis=(0, 2)))[0]
        assert text.size and text.max() < width - 2, f"panel {i}: label reaches column {text.max()} of {width}"
        rows = np.nonzero((panel > 32).any(axis=(1, 2)))[0]
        assert rows.min() > 0 and rows.max() < bar - 1  # nor cut at the top or bottom of its bar
