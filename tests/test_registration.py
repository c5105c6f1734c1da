"""Registration on real photos (OpenCV's ChArUco tutorial photo, a simulated AprilTag rotation
series), synthetic correspondences with outliers, and bad input through the command line."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera, load_shot
from mrcheck.core.camerafiles import read_photo as read_rgb_photo
from mrcheck.core.shot import Shot
from mrcheck.mr.register import summary_lines
from mrcheck.mr.registration import register_markers, register_points


def read_photo(path):
    return read_rgb_photo(path, grey=True)  # what registration reads: the photo in grey


DATA = Path(__file__).parent / "data"
CHARUCO = DATA / "calibration" / "opencv_charuco"
APRILTAG = DATA / "markers" / "apriltag"
BOARD_MAP = {
    "charuco_boards": [
        {
            "squares": [5, 7],
            "square": 0.04,
            "marker": 0.02,
            "dictionary": "DICT_6X6_250",
            "pose": {"R": np.eye(3).tolist(), "t": [0.0, 0.0, 0.0]},
        }
    ]
}
# the 70 deg photo is too oblique for OpenCV's AprilTag detector; every other angle is detected
ANGLES = [0, 10, 20, 30, 40, 50, 60, -10, -20, -30, -40, -50, -60, -70]


def charuco_camera() -> Camera:
    fs = cv2.FileStorage(str(CHARUCO / "tutorial_camera_charuco.yml"), cv2.FILE_STORAGE_READ)
    return Camera(
        fs.getNode("image_width").real(),
        fs.getNode("image_height").real(),
        fs.getNode("camera_matrix").mat(),
        dist=fs.getNode("distortion_coefficients").mat().ravel(),
    )


def apriltag_setup():
    """The rotation test's camera and a map with its tag (id 76) centred at the world origin."""
    text = (APRILTAG / "test_info.yaml").read_text().split("rotation_test:")[1].split("multiple_tags_test:")[0]
    value = lambda key: re.search(rf"{key}: (\S.*)", text).group(1)  # noqa: E731 (no PyYAML here)
    camera = Camera(int(value("width")), int(value("height")), np.reshape(json.loads(value("K")), (3, 3)))
    s = float(value("tag_size")) / 2.0
    marker_map = {
        "dictionary": "DICT_APRILTAG_36h11",
        "markers": [{"id": 76, "corners": [[-s, s, 0], [s, s, 0], [s, -s, 0], [-s, -s, 0]]}],
    }
    return camera, marker_map


@pytest.fixture
def files(tmp_path):
    """Paths for a CLI run: scene, intrinsics JSON (of the ChArUco camera), board map, output."""
    # the board lies on this slab (register loads the scene and checks the camera is near it)
    slab = trimesh.creation.box(extents=(0.3, 0.3, 0.01))
    slab.apply_translation((0.15, 0.15, -0.005))
    slab.export(tmp_path / "scene.obj")
    (tmp_path / "cam.json").write_text(json.dumps(charuco_camera().to_dict()))
    (tmp_path / "map.json").write_text(json.dumps(BOARD_MAP))
    return tmp_path


def run(files, *extra, photo=CHARUCO / "choriginal.jpg", intrinsics="cam.json"):
    return main(
        [
            "register",
            str(files / "scene.obj"),
            "--photo",
            str(photo),
            "--intrinsics",
            str(files / intrinsics),
            "-o",
            str(files / "SHOT.json"),
            *extra,
        ]
    )


def test_charuco_photo_registers_sub_pixel():
    shot = register_markers(read_photo(CHARUCO / "choriginal.jpg"), charuco_camera(), BOARD_MAP)
    assert shot.report["method"] == "markers"
    assert shot.report["rms"] < 0.4  # measured 0.22 px; the calibration's own RMS is 0.18 px
    assert shot.report["used"][0]["board"] == 0 and shot.report["used"][0]["corners"] == 24
    assert shot.report["rejected"] == [] and shot.report["unknown_ids"] == []
    assert 0.2 < np.linalg.norm(shot.report["camera_position"]) < 0.8  # a desk photo of a 20 x 28 cm board


FAR = [1.0e6, -2.0e6, 3.0e5]  # a factory's survey coordinates: a million metres from the origin
# board-to-world poses: face-up on the floor (README), and seeded random rotations, near and far
FACE_UP = np.diag([1.0, -1.0, -1.0])
BOARD_POSES = [("face_up", FACE_UP, [0.0, 0.0, 0.0]), ("face_up_far", FACE_UP, FAR)] + [
    (f"random{k}{'_far' if k % 2 else ''}", R, FAR if k % 2 else [0.0, 0.0, 0.0])
    for k, R in enumerate(Rotation.random(10, random_state=20240611).as_matrix())
]


def _board_map(R, t):
    board = dict(BOARD_MAP["charuco_boards"][0], pose={"R": np.asarray(R).tolist(), "t": list(t)})
    return {"charuco_boards": [board]}


@pytest.fixture(scope="module")
def board_frame_shot():
    return register_markers(read_photo(CHARUCO / "choriginal.jpg"), charuco_camera(), BOARD_MAP)


@pytest.mark.parametrize("name, R, t", BOARD_POSES, ids=[p[0] for p in BOARD_POSES])
def test_charuco_registration_does_not_depend_on_the_board_pose(board_frame_shot, name, R, t):
    """The same photo of the same board: the camera relative to the board must not change with
    where the board sits in the world (EPnP RANSAC on the world coordinates failed for about half
    of the orientations, and far from the origin, where OpenCV's RANSAC rounds them to float32)."""
    shot = register_markers(read_photo(CHARUCO / "choriginal.jpg"), charuco_camera(), _board_map(R, t))
    assert shot.report["rms"] < 0.4
    assert shot.report["used"][0]["corners"] == 24 and shot.report["rejected"] == []
    # X_board -> X_world = R X_board + t, so the board-frame camera (R0, t0) becomes R0 R^T, centre R c0 + t
    base, found = board_frame_shot.camera, shot.camera
    assert np.linalg.norm(found.center - (R @ base.center + t)) < 1e-3
    assert np.linalg.norm(np.asarray(shot.report["camera_position"]) - (R @ base.center + t)) < 1e-3
    angle = np.degrees(np.linalg.norm(cv2.Rodrigues(found.R @ (base.R @ R.T).T)[0]))
    assert angle < 0.1
    assert shot.report["rms"] == pytest.approx(board_frame_shot.report["rms"], abs=0.01)
    assert shot.report["expected_overlay_error_px"] == pytest.approx(
        board_frame_shot.report["expected_overlay_error_px"], abs=0.02
    )


def test_cli_writes_a_shot_that_is_a_camera(files, capsys):
    assert run(files, "--markers", str(files / "map.json")) == 0
    shot = json.loads((files / "SHOT.json").read_text())
    camera = load_camera(files / "SHOT.json")  # what `mrcheck render --camera SHOT.json` reads
    assert (camera.width, camera.height) == (640, 480)
    # the photo relative to the shot's folder, which load_shot resolves
    assert not Path(shot["photo"]).is_absolute()
    assert load_shot(files / "SHOT.json")[1].resolve() == (CHARUCO / "choriginal.jpg").resolve()
    assert {"rms", "method", "used", "rejected", "warnings"} <= set(shot)
    out = capsys.readouterr().out
    assert "from markers" in out and "rms" in out and "wrote" in out


def test_a_shot_moves_with_its_photo(tmp_path, files):
    """A project folder (shots/ and photos/) copied elsewhere: its SHOT.json finds the copied
    photo, not the original (an absolute path would still point at the first folder, or nowhere
    on another machine)."""
    project = tmp_path / "project"
    (project / "photos").mkdir(parents=True)
    shutil.copy(CHARUCO / "choriginal.jpg", project / "photos" / "p.jpg")
    assert (
        main(
            [
                "register",
                str(files / "scene.obj"),
                "--photo",
                str(project / "photos" / "p.jpg"),
                "--intrinsics",
                str(files / "cam.json"),
                "--markers",
                str(files / "map.json"),
                "-o",
                str(project / "shots" / "SHOT.json"),
            ]
        )
        == 0
    )
    assert json.loads((project / "shots" / "SHOT.json").read_text())["photo"] == "../photos/p.jpg"
    moved = shutil.copytree(project, tmp_path / "elsewhere")
    shutil.rmtree(project)
    camera, photo = load_shot(moved / "shots" / "SHOT.json")
    assert photo.resolve() == (moved / "photos" / "p.jpg").resolve() and photo.is_file()


def test_apriltag_rotation_series_consistent():
    camera, marker_map = apriltag_setup()
    distances, first = {}, None
    for angle in ANGLES:
        shot = register_markers(read_photo(APRILTAG / f"test_image_rotation_{angle}.png"), camera, marker_map)
        R, t = np.array(shot.camera.R), np.array(shot.camera.t)  # t = the tag centre in the camera frame
        distances[angle] = np.linalg.norm(t)
        assert shot.report["rms"] < 1.5
        # the tag turns about its vertical axis: its normal leaves the line of sight by the angle
        # (a nearly frontal single tag is ambiguous by a few degrees, hence only from 20 deg)
        viewing = np.degrees(np.arccos(abs(R[:, 2] @ t) / np.linalg.norm(t)))
        if abs(angle) >= 20:
            assert viewing == pytest.approx(abs(angle), abs=2.5), angle
            rotation = cv2.Rodrigues(R @ first.T)[0].ravel()
            assert np.sign(rotation[1]) == -np.sign(angle)  # turns the other way for negative angles
        if angle == 0:
            first = R
            assert any("one plane facing the camera" in w for w in shot.report["warnings"])
        assert any("only one marker" in w for w in shot.report["warnings"])
    d = np.array(list(distances.values()))
    assert d.max() / d.min() < 1.05  # measured 0.2075 .. 0.2143 m


def test_resized_photo_same_aspect_rescales_k_and_warns():
    camera, marker_map = apriltag_setup()
    image = read_photo(APRILTAG / "test_image_rotation_30.png")
    full = register_markers(image, camera, marker_map)
    half = register_markers(cv2.resize(image, (528, 396), interpolation=cv2.INTER_AREA), camera, marker_map)
    assert (half.camera.width, half.camera.height) == (528, 396)
    assert any("K rescaled" in w for w in half.report["warnings"])
    assert np.linalg.norm(half.camera.t) == pytest.approx(np.linalg.norm(full.camera.t), rel=0.02)


def test_points_with_outliers_are_rejected_and_pose_recovered():
    truth = Camera.from_look_at([4.0, -6.0, 2.5], [0.5, 1.0, 0.8], [0, 0, 1], 60.0, 1920, 1080)
    truth = Camera(1920, 1080, truth.K, truth.R, truth.t, dist=[0.05, -0.02, 0.001, 0.0005, 0.0])
    rng = np.random.default_rng(1)
    world = rng.uniform([-2, -1, 0], [3, 4, 3], size=(14, 3))
    pixels = cv2.projectPoints(world, cv2.Rodrigues(truth.R)[0], truth.t, truth.K, truth.dist)[0].reshape(-1, 2)
    pixels[[3, 9]] += [[40.0, -25.0], [-60.0, 80.0]]  # two mis-clicks
    pairs = {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels, world)]}
    shot = register_points(Camera(1920, 1080, truth.K, dist=truth.dist), pairs)
    assert sorted(r["index"] for r in shot.report["rejected"]) == [3, 9]
    assert all(r["error_px"] > 20 for r in shot.report["rejected"]) and len(shot.report["used"]) == 12
    assert shot.report["rms"] < 1e-6
    found = shot.camera
    assert np.linalg.norm(found.center - truth.center) < 1e-3
    angle = np.degrees(np.linalg.norm(cv2.Rodrigues(found.R @ truth.R.T)[0]))
    assert angle < 0.01


PLANES = [(k, offset) for k in range(8) for offset in ([0.0, 0.0, 0.0], FAR)]


@pytest.mark.parametrize("k, offset", PLANES, ids=[f"plane{k}{'_far' if o[0] else ''}" for k, o in PLANES])
def test_coplanar_points_off_the_xy_plane_register(k, offset):
    """Clicked points on one plane (a wall, a ramp) of any orientation, anywhere in the world:
    the two mis-clicks are rejected and the pose is exact."""
    plane = Rotation.random(8, random_state=7).as_matrix()[k]  # columns: two in-plane axes, the normal
    rng = np.random.default_rng(k)
    centre = np.array([3.0, 4.0, 2.0]) + offset
    world = centre + rng.uniform([-2.0, -1.5], [2.0, 1.5], size=(12, 2)) @ plane[:, :2].T
    truth = Camera.from_look_at(centre + 6.0 * plane[:, 2] + rng.normal(size=3), centre, [0, 0, 1], 60.0, 1920, 1080)
    truth = Camera(1920, 1080, truth.K, truth.R, truth.t, dist=[0.05, -0.02, 0.001, 0.0005, 0.0])
    pixels = cv2.projectPoints(world, cv2.Rodrigues(truth.R)[0], truth.t, truth.K, truth.dist)[0].reshape(-1, 2)
    pixels[[2, 7]] += [[35.0, -20.0], [-50.0, 60.0]]  # two mis-clicks
    pairs = {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels, world)]}
    shot = register_points(Camera(1920, 1080, truth.K, dist=truth.dist), pairs)
    assert sorted(r["index"] for r in shot.report["rejected"]) == [2, 7] and len(shot.report["used"]) == 10
    assert shot.report["rms"] < 1e-4
    found = shot.camera
    assert np.linalg.norm(found.center - truth.center) < 1e-3
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(found.R @ truth.R.T)[0])) < 0.01
    assert np.isfinite(shot.report["expected_overlay_error_px"])


def _points_file(files, world, pixels=None):
    pixels = pixels if pixels is not None else [[100.0 + 50 * i, 100.0 + 10 * i * i] for i in range(len(world))]
    (files / "corr.json").write_text(json.dumps({"points": [{"pixel": p, "world": w} for p, w in zip(pixels, world)]}))
    return str(files / "corr.json")


def _corrupt(files):
    (files / "bad.jpg").write_bytes(b"\xff\xd8\xff\xe0 not really a jpeg")
    return {"photo": files / "bad.jpg"}


def _blank(files):
    cv2.imwrite(str(files / "blank.png"), np.full((480, 640), 128, np.uint8))
    return {"photo": files / "blank.png"}


def _other_aspect(files):
    cv2.imwrite(str(files / "wide.png"), cv2.resize(cv2.imread(str(CHARUCO / "choriginal.jpg")), (640, 360)))
    return {"photo": files / "wide.png"}


def _unknown_ids(files):
    camera, marker_map = apriltag_setup()
    marker_map["markers"][0]["id"] = 5
    (files / "tags.json").write_text(json.dumps(marker_map))
    (files / "tagcam.json").write_text(json.dumps(camera.to_dict()))
    return {
        "photo": APRILTAG / "test_image_rotation_30.png",
        "intrinsics": "tagcam.json",
        "extra": ["--markers", str(files / "tags.json")],
    }


def _small_board(files):
    """The board photo at half size: the detector finds 4 of its 24 corners (the pose cannot be
    checked); the error says so instead of only blaming the survey and the intrinsics."""
    cv2.imwrite(
        str(files / "small.png"),
        cv2.resize(cv2.imread(str(CHARUCO / "choriginal.jpg")), (320, 240), interpolation=cv2.INTER_AREA),
    )
    return {"photo": files / "small.png", "extra": ["--markers", str(files / "map.json"), "--max-error", "20"]}


def _corner_order(files):
    """A map whose marker corners go TL, TR, BL, BR (not OpenCV's TL, TR, BR, BL)."""
    info = _unknown_ids(files)
    marker_map = apriltag_setup()[1]
    corners = marker_map["markers"][0]["corners"]
    corners[2], corners[3] = corners[3], corners[2]
    (files / "tags.json").write_text(json.dumps(marker_map))
    return info


BAD = {
    "three_pairs": (
        lambda f: {"extra": ["--points", _points_file(f, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])]},
        "at least 4",
    ),
    "collinear": (
        lambda f: {"extra": ["--points", _points_file(f, [[i, 2 * i, 0.5 * i] for i in range(6)])]},
        "corr.json: the world points are collinear",
    ),
    "pixel_outside": (
        lambda f: {
            "extra": [
                "--points",
                _points_file(f, [[i % 3, i // 3, 0] for i in range(6)], [[10, 10]] * 5 + [[-5000, 10]]),
            ]
        },
        "corr.json: point #5: pixel (-5000, 10) lies outside the 640x480 photo",
    ),
    "boolean_coordinate": (
        lambda f: {"extra": ["--points", _points_file(f, [[True, 0, 0]] + [[i, i * i, 0] for i in range(5)])]},
        "corr.json: point #0 needs",
    ),
    "corrupt_photo": (_corrupt, "cannot read photo: truncated JPEG"),
    "small_board_photo": (_small_board, "(detected: board 0: 4 corners)"),
    "corner_order": (
        _corner_order,
        "(detected: marker 76; a map's marker corners go top-left, top-right, bottom-right",
    ),
    "no_markers": (_blank, "no marker of the map"),
    "unknown_ids_only": (_unknown_ids, "not in the map: [76]"),
    "other_aspect": (_other_aspect, "another aspect ratio"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_one_line_error_and_no_shot(files, capsys, case):
    make, message = BAD[case]
    spec = make(files)
    extra = spec.pop("extra", ["--markers", str(files / "map.json")])
    assert run(files, *extra, **spec) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and message in err, err
    if "photo" in spec:  # the message names the photo it is about
        assert Path(spec["photo"]).name in err, err
    assert not (files / "SHOT.json").exists()


def test_a_scene_argument_that_is_no_scene_is_one_line(files, capsys):
    """The shot only names its scene; a photo given by mistake is caught here, not in every
    later command that renders the shot."""
    photo = CHARUCO / "choriginal.jpg"
    assert (
        main(
            [
                "register",
                str(photo),
                "--photo",
                str(photo),
                "--intrinsics",
                str(files / "cam.json"),
                "-o",
                str(files / "SHOT.json"),
                "--markers",
                str(files / "map.json"),
            ]
        )
        == 1
    )
    err = capsys.readouterr().err
    assert err.startswith(f"error: {photo}: not a scene") and err.count("\n") == 1
    assert not (files / "SHOT.json").exists()


def test_the_summary_counts_many_points_instead_of_listing_them(capsys):
    """54 chessboard corners as clicks: "used 52 of 54", the rejected ones listed."""
    entry = lambda i, error=0.2: {"index": i, "pixel": [0, 0], "world": [0, 0, 0], "error_px": error}  # noqa: E731
    report = {
        "method": "points",
        "rms": 0.3,
        "used": [entry(i) for i in range(54) if i not in (7, 40)],
        "rejected": [entry(7, 9.0), entry(40, 12.5)],
        "camera_position": [0, 0, 0],
        "expected_overlay_error_px": 0.5,
        "warnings": [],
    }
    shot = Shot(Camera(640, 480, np.diag([500.0, 500.0, 1.0])), Path("p.jpg"), report)
    assert "used 52 of 54; rejected 7 (9.0 px), 40 (12.5 px)" in "\n".join(summary_lines(shot, "SHOT.json"))
