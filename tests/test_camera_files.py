"""Camera files from the user: JSON, shot JSON and OpenCV YAML load wherever a camera is, and a
bad one (empty, truncated, a distortion vector OpenCV cannot take, no pose for a render) is one
line ``error: FILE: problem`` and exit 1, never a traceback from OpenCV."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera, read_camera, write_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import sample_scene_path

SCENE = str(sample_scene_path())
CONVEYOR = Path(__file__).resolve().parents[1] / "calibration" / "sample_cell_conveyor.json"  # posed, in SCENE
TINY = ["--width", "64", "--height", "48"]


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(result, path, words):
    code, _, err = result
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1, err
    assert lines[0].startswith(f"error: {path}: ") and words in lines[0], err


def intrinsics_yaml(path, dist=(-0.1, 0.01, 0.0, 0.0, 0.0)):
    """An OpenCV calibration YAML (no pose) written by OpenCV itself, any dist length."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", np.array([[500.0, 0, 319.5], [0, 500.0, 239.5], [0, 0, 1]]))
    fs.write("distortion_coefficients", np.array(dist, np.float64).reshape(-1, 1))
    fs.release()
    return path


@pytest.fixture
def register_inputs(tmp_path):
    """A photo and five correspondences: enough for register to reach the pose solve."""
    photo, points = tmp_path / "p.png", tmp_path / "C.json"
    cv2.imwrite(str(photo), np.zeros((480, 640), np.uint8))
    points.write_text(
        json.dumps(
            {"points": [{"pixel": [100 + 50 * i, 100 + 80 * (i % 2)], "world": [i, i % 2, 0]} for i in range(5)]}
        )
    )
    return ["--photo", photo, "--points", points, "-o", tmp_path / "S.json"]


# -- 1. empty and truncated OpenCV YAML ------------------------------------------------------
def test_empty_yaml_intrinsics_is_one_line_error(tmp_path, capsys, register_inputs):
    empty = tmp_path / "empty.yml"
    empty.write_text("")
    result = run(capsys, "register", SCENE, "--intrinsics", empty, *register_inputs)
    assert_one_line_error(result, empty, "cannot read OpenCV YAML camera")


@pytest.mark.parametrize("cut", ["data: [", "dt: d"])  # a parse error; a matrix without its type
def test_truncated_yaml_intrinsics_is_one_line_error(tmp_path, capsys, register_inputs, cut):
    text = intrinsics_yaml(tmp_path / "whole.yml").read_text()
    truncated = tmp_path / "cam.yml"
    truncated.write_text(text[: text.index(cut) + len(cut) // 2])
    result = run(capsys, "register", SCENE, "--intrinsics", truncated, *register_inputs)
    assert_one_line_error(result, truncated, "cannot read OpenCV YAML camera")


@pytest.mark.slow
def test_yaml_cut_anywhere_loads_or_is_mrcheck_error(tmp_path):
    posed = load_camera(CONVEYOR).with_pose(cv2.Rodrigues(np.array([0.1, -0.2, 0.3]))[0], [1.0, 2.0, 3.0])
    text = write_camera(tmp_path / "whole.yml", posed, {"rms": 0.3}).read_bytes()
    path = tmp_path / "cut.yml"
    for n in range(len(text)):
        path.write_bytes(text[:n])
        try:
            read_camera(path)
        except MrcheckError as exc:
            assert str(exc).startswith(f"{path}: ")


def test_yaml_text_is_not_a_number(tmp_path):
    # OpenCV reads a string as DBL_MAX (a huge "focal length") or asserts in FileNode.mat()
    text = intrinsics_yaml(tmp_path / "whole.yml").read_text()
    letters = "camera_matrix: [a, b, c, d, e, f, g, h, i]\nx: !!opencv-matrix"
    for old, new, words in (
        ("image_width: 640", 'image_width: "640"', "width"),
        ("camera_matrix: !!opencv-matrix", letters, "K contains NaN"),
    ):
        path = tmp_path / "bad.yml"
        path.write_text(text.replace(old, new))
        with pytest.raises(MrcheckError, match=words):
            read_camera(path)


# -- 2. distortion vectors OpenCV cannot take ----------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 6, 7, 9, 13, 15, 20])
def test_dist_of_a_length_opencv_rejects_is_an_error(n):
    with pytest.raises(MrcheckError, match=f"dist must .* got {n}"):
        Camera(640, 480, np.diag([500.0, 500.0, 1.0]), dist=np.zeros(n))


@pytest.mark.parametrize("n", [0, 4, 5, 8, 12, 14])
def test_dist_lengths_opencv_takes_are_accepted(n):
    camera = Camera(640, 480, [[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]], dist=np.full(n, 1e-3))
    # the calls the overlay and the registration make with it
    cv2.undistortPoints(np.array([[[100.0, 200.0]]]), camera.K, camera.dist)
    cv2.projectPoints(np.array([[0.0, 0.0, 5.0]]), np.zeros(3), np.zeros(3), camera.K, camera.dist)


def test_shot_json_with_three_dist_is_one_line_error(tmp_path, capsys):
    shot = tmp_path / "SHOT.json"
    shot.write_text(json.dumps(load_camera(CONVEYOR).to_dict() | {"dist": [0.1, 0, 0], "photo": "p.png"}))
    with pytest.raises(MrcheckError, match="dist"):
        load_camera(shot)
    result = run(capsys, "overlay", shot, "--scene", SCENE, "-o", tmp_path / "o.png")
    assert_one_line_error(result, shot, "dist must")
    result = run(capsys, "render", SCENE, "--camera", shot, *TINY, "-o", tmp_path / "r.png")
    assert_one_line_error(result, shot, "dist must")


def test_yaml_with_twenty_dist_is_one_line_error(tmp_path, capsys, register_inputs):
    path = intrinsics_yaml(tmp_path / "cam.yml", dist=np.zeros(20))
    result = run(capsys, "register", SCENE, "--intrinsics", path, *register_inputs)
    assert_one_line_error(result, path, "dist must have 4, 5, 8, 12 or 14 coefficients")


# -- 3. OpenCV YAML wherever a camera is -----------------------------------------------------------
def test_yaml_camera_loads_as_the_json_one(tmp_path):
    camera = load_camera(CONVEYOR)
    for name in ("cam.yml", "cam.YAML"):
        back = load_camera(write_camera(tmp_path / name, camera))
        assert np.allclose(back.K, camera.K) and np.allclose(back.R, camera.R) and np.allclose(back.t, camera.t)
        assert (back.width, back.height) == (camera.width, camera.height)


def test_yaml_intrinsics_have_no_pose_for_a_render(tmp_path):
    path = intrinsics_yaml(tmp_path / "cam.yml")
    with pytest.raises(MrcheckError, match="no pose"):
        load_camera(path)
    # the registration takes intrinsics only
    for camera in (read_camera(path), load_camera(path, need_pose=False)):
        assert camera.fx == 500.0 and camera.dist.size == 5 and np.array_equal(camera.R, np.eye(3))


@pytest.mark.slow
def test_render_and_reference_take_a_yaml_camera(tmp_path, capsys):
    yml = write_camera(tmp_path / "cam.yml", load_camera(CONVEYOR))
    images = {}
    for camera in (CONVEYOR, yml):
        out = tmp_path / f"{camera.suffix[1:]}.png"
        code, _, err = run(capsys, "render", SCENE, "--camera", camera, "--mode", "phong", *TINY, "-o", out)
        assert code == 0, err
        images[camera.suffix] = cv2.imread(str(out))
    assert np.array_equal(images[".json"], images[".yml"]) and images[".yml"].shape == (48, 64, 3)
    code, _, err = run(
        capsys,
        "reference",
        SCENE,
        "--camera",
        yml,
        "--width",
        "32",
        "--height",
        "24",
        "--rays",
        "4",
        "-o",
        tmp_path / "ref.npy",
    )
    assert code == 0, err
    assert np.load(tmp_path / "ref.npy").shape == (24, 32)


def test_render_from_yaml_intrinsics_says_no_pose(tmp_path, capsys):
    path = intrinsics_yaml(tmp_path / "cam.yml")
    result = run(capsys, "render", SCENE, "--camera", path, *TINY, "-o", tmp_path / "r.png")
    assert_one_line_error(result, path, "no pose (R and t)")
    assert not (tmp_path / "r.png").exists()


@pytest.mark.parametrize("command", ["render", "reference"])
def test_render_from_json_intrinsics_says_no_pose(tmp_path, capsys, command):
    """A camera JSON without R and t (what `mrcheck calibrate -o cam.json` writes) stood the camera
    at the world origin looking along +z; a render now refuses it as it refuses the YAML."""
    path = tmp_path / "cam.json"
    write_camera(path, load_camera(CONVEYOR), pose=False)
    out = tmp_path / ("r.png" if command == "render" else "r.npy")
    result = run(capsys, command, SCENE, "--camera", path, *TINY, "-o", out)
    assert_one_line_error(result, path, "camera JSON has intrinsics but no pose (R and t)")
    assert not out.exists()


@pytest.mark.parametrize("command", ["render", "reference"])
def test_a_bad_camera_file_fails_before_the_scene_loads(tmp_path, capsys, monkeypatch, command):
    """The camera file is read first: a typo in it costs no scene load (seconds on a big hall)."""
    import mrcheck.scene.model

    def no_load(*args, **kwargs):
        raise AssertionError("the scene was loaded before the camera file was checked")

    monkeypatch.setattr(mrcheck.scene.model, "load_scene", no_load)
    monkeypatch.setattr("mrcheck.render.views.load_scene", no_load)
    path = tmp_path / "cam.json"
    path.write_text('{"width": 64,')
    out = tmp_path / ("r.png" if command == "render" else "r.npy")
    assert_one_line_error(
        run(capsys, command, SCENE, "--camera", path, *TINY, "-o", out), path, "malformed camera JSON"
    )


# -- 4. a K the pinhole renderer cannot draw -------------------------------------------------
@pytest.mark.parametrize(
    "row, col, value, words",
    [
        (0, 1, 100.0, "skew K[0][1] = 100"),
        (1, 0, 5.0, "K[1][0] = 5"),
        (2, 0, 0.001, "bottom row"),
        (2, 2, 2.0, "bottom row"),
    ],
)
def test_a_k_with_skew_or_another_bottom_row_is_refused(tmp_path, capsys, row, col, value, words):
    """Only fx, fy, cx, cy are drawn: a skewed or unnormalised K rendered as if it were the plain
    pinhole, an image that does not match the camera, with exit 0."""
    data = json.loads(CONVEYOR.read_text())
    data["K"][row][col] = value
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(data))
    for command, out in (("render", "r.png"), ("reference", "r.npy")):
        result = run(capsys, command, SCENE, "--camera", path, *TINY, "-o", tmp_path / out)
        assert_one_line_error(result, path, words)
        assert not (tmp_path / out).exists()


def test_a_k_with_rounding_noise_in_its_zeros_is_accepted():
    K = np.array([[500.0, 1e-12, 319.5], [-1e-12, 500.0, 239.5], [1e-15, 0.0, 1.0 + 1e-15]])
    assert Camera(640, 480, K).fx == 500.0


# -- 5. --width and --height of another aspect ratio than the camera's -------------------------
@pytest.mark.parametrize("command", ["render", "reference"])
def test_width_and_height_of_another_aspect_ratio_are_refused_for_a_camera(tmp_path, capsys, command):
    """fx and fy were scaled apart: a squashed image (a round bollard drawn as an ellipse), exit 0."""
    out = tmp_path / ("r.png" if command == "render" else "r.npy")
    result = run(capsys, command, SCENE, "--camera", CONVEYOR, "--width", "64", "--height", "30", "-o", out)
    assert_one_line_error(result, CONVEYOR, "give only --width or --height")
    assert "1024x768" in result[2] and "64x48" in result[2]
    assert not out.exists()


@pytest.mark.slow
def test_width_and_height_within_a_pixel_of_the_aspect_ratio_are_accepted(tmp_path, capsys):
    # 65x48 and 64x49 are 64x48 up to the rounding of one side (what --width alone rounds too)
    for size in (("65", "48"), ("64", "49")):
        out = tmp_path / "r.png"
        code, _, err = run(
            capsys,
            "render",
            SCENE,
            "--camera",
            CONVEYOR,
            "--mode",
            "phong",
            "--width",
            size[0],
            "--height",
            size[1],
            "-o",
            out,
        )
        assert code == 0, err
        assert cv2.imread(str(out)).shape[:2] == (int(size[1]), int(size[0]))
