"""The photo overlay: lens distortion, the synthetic marker round trip, blending and bad input.

Synthetic "photos" are mrcheck renders distorted with the overlay's own photo -> ideal map, so
the lens model is checked independently against ``cv2.projectPoints`` (test 1) and against
ArUco detection and a pose solve (test 2).
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.resources import sample_scene_path
from mrcheck.mr.lens import distortion_map, padded_camera
from mrcheck.mr.overlay import overlay_images
from mrcheck.mr.shot import cad_edges, render_for_photo
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene

from .conftest import box, scene_of
from .mr_helpers import DICTIONARY, make_camera, marker_parts, render_photo

MAGENTA = (255, 0, 255)


def _project(camera: Camera, points) -> np.ndarray:
    rvec, _ = cv2.Rodrigues(camera.R)
    uv, _ = cv2.projectPoints(np.asarray(points, np.float64), rvec, camera.t, camera.K, camera.dist)
    return uv.reshape(-1, 2)


# -- 1. distortion -----------------------------------------------------------------------------
@pytest.mark.slow
def test_cad_edges_follow_the_distorted_lens_into_the_corners(ctx):
    # a long plate 5 m ahead whose top edge (y = 2.2 m, OpenCV y down) crosses the whole image
    # near its bottom corners, where k1 = -0.3 bends it by many pixels
    scene = scene_of(box((20.0, 7.8, 0.2), (0.0, 6.1, 5.0)))
    camera = make_camera(320, 240, 200.0, dist=(-0.3, 0.1, 0.0, 0.0, 0.0))
    photo = render_photo(ctx, scene, camera)
    renderer = Renderer(scene, ctx=ctx)
    renders, edges, offset, maps = render_for_photo(renderer, camera, ["phong"], RenderSettings(), True)
    assert offset != (0, 0)  # barrel distortion: the photo's corners see beyond the pinhole frame

    black = np.zeros_like(photo)
    drawn = overlay_images(black, renders, camera, 1.0, edges, MAGENTA, offset, maps)["phong"]
    edge_px = np.argwhere(drawn[..., 0] >= 128)[:, ::-1].astype(np.float64)  # (u, v)
    assert len(edge_px)

    x = np.linspace(-12.0, 12.0, 20001)
    line = np.column_stack((x, np.full_like(x, 2.2), np.full_like(x, 4.9)))  # the front face's top edge
    uv = _project(camera, line)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= 319) & (uv[:, 1] >= 0) & (uv[:, 1] <= 239)
    corner = inside & ((uv[:, 0] < 60) | (uv[:, 0] > 259))
    assert corner.sum() > 100

    def nearest(points, cloud):
        return np.min(np.linalg.norm(points[:, None, :] - cloud[None, :, :], axis=2), axis=1)

    curve = uv[corner][::20]
    assert nearest(curve, edge_px).max() <= 1.0  # every projected point has a CAD edge pixel within 1 px
    near_corner = edge_px[((edge_px[:, 0] < 55) | (edge_px[:, 0] > 264)) & (edge_px[:, 1] > 150)]
    assert len(near_corner) > 20
    # and every edge pixel there lies on the front or the back top edge (we look down on the top face);
    # an edge between two pixel centres marks both, so a pixel centre may be up to ~1.1 px off
    back = _project(camera, line + [0.0, 0.0, 0.2])
    near = lambda p: p[np.all((p > -3) & (p < [323, 243]), axis=1)]  # noqa: E731
    assert nearest(near_corner, np.concatenate([near(uv), near(back)])).max() <= 1.25

    # the test is sensitive: the ideal (undistorted) edge misses the distorted one by far more
    ideal = camera.project(line[::200])
    ideal = ideal[(ideal[:, 0] >= 0) & (ideal[:, 0] < 40)]
    assert nearest(ideal, edge_px).min() > 5.0

    # and the photo itself has its brightness steps (background | top face | front face) on the
    # same curves: the synthetic photo and the CAD edges agree
    grey = photo.astype(np.float64).mean(axis=2)
    for u, v in curve[:: max(1, len(curve) // 10)]:
        steps = np.flatnonzero(np.abs(np.diff(grey[:, int(round(u))])) > 4) + 0.5  # between rows j, j+1
        assert np.abs(steps - v).min() <= 1.0


def test_distortion_map_inverts_the_lens():
    camera = make_camera(320, 240, 200.0, dist=(-0.3, 0.1, 0.001, -0.002, 0.0))
    map_x, map_y = distortion_map(camera)
    ideal = np.column_stack((map_x.ravel(), map_y.ravel()))[::97]
    photo_px = np.argwhere(np.ones((240, 320), bool))[::97][:, ::-1]
    rays = np.column_stack(((ideal - camera.K[:2, 2]) / camera.fx, np.ones(len(ideal))))
    back, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), camera.K, camera.dist)
    assert np.abs(back.reshape(-1, 2) - photo_px).max() < 0.01
    assert distortion_map(make_camera(32, 24, 20.0)) is None
    assert padded_camera(make_camera(32, 24, 20.0))[1] == (0, 0)


def test_edges_flat_faces_are_quiet_at_grazing_angles():
    # a floor plane seen at a grazing angle: depth is far from linear, inverse depth is affine
    h, w, f = 120, 160, 100.0
    v = np.arange(h)[:, None] - 20.0
    depth = np.where(v > 0, 1.6 * f / np.maximum(v, 1e-9), 0.0) * np.ones((1, w))
    edges = cad_edges(depth.astype(np.float32), f)
    assert not edges[21:].any()  # the floor itself: no edges, right up to the horizon
    assert edges[20].all()  # where it meets the background (row 20, v = 0): a silhouette
    assert not edges[:20].any()


# -- 2. the synthetic marker round trip -----------------------------------------------------------
@pytest.fixture(scope="module")
def marker_shot(ctx):
    """The sample cell with four markers 4-6 m from a distorted 640x480 camera, and its photo."""
    sample = load_scene(sample_scene_path())
    eye, target = np.array([-11.4, -6.2, 1.7]), np.array([-5.0, -4.2, 0.9])
    truth = make_camera(640, 480, 500.0, dist=(-0.1, 0.0, 0.0, 0.0, 0.0), eye=eye, target=target, principal=(1.3, -1.3))
    fwd = (target - eye) / np.linalg.norm(target - eye)
    side = np.cross(fwd, (0, 0, 1.0))
    side /= np.linalg.norm(side)

    def facing(centre, yaw_deg, tilt_deg=0.0):
        # a plate facing the camera, turned by yaw about the vertical and tilted back
        to_cam = eye - centre
        to_cam[2] = 0.0
        n = to_cam / np.linalg.norm(to_cam)
        a = np.radians(yaw_deg)
        n = np.array([n[0] * np.cos(a) - n[1] * np.sin(a), n[0] * np.sin(a) + n[1] * np.cos(a), 0.0])
        right = np.cross((0, 0, 1.0), n)
        down = np.cross(right, n)
        tb = np.radians(tilt_deg)
        down = down * np.cos(tb) + n * np.sin(tb)
        return right, down

    def at(d, s, z):
        p = eye + fwd * d + side * s
        p[2] = z
        return p

    markers = []
    for marker_id, (d, s, z, yaw, tilt, size) in zip(
        (7, 23, 42), ((4.5, -1.3, 1.5, 25, 0, 0.5), (5.5, 1.2, 1.1, -20, 10, 0.6), (6.5, -0.2, 2.3, 0, -15, 0.5))
    ):
        markers.append((marker_id, at(d, s, z), *facing(at(d, s, z), yaw, tilt), size))
    # one lying on the floor, read from the camera (top edge away from it)
    floor_centre = at(4.2, 0.4, 0.012)
    away = fwd * [1, 1, 0]
    away /= np.linalg.norm(away)
    markers.append((61, floor_centre, np.cross(away, (0, 0, 1.0)), -away, 0.5))

    parts, marker_map = marker_parts(markers)
    scene = Scene("markers", sample.source, sample.parts + parts, sample.viewpoints)
    photo = render_photo(ctx, scene, truth, supersample=4)  # 4x: antialiased edges, cleaner corners
    return scene, truth, photo, marker_map


def _pose_error(truth: Camera, found: Camera):
    dR = found.R @ truth.R.T
    angle = np.degrees(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    return float(np.linalg.norm(found.center - truth.center)), float(angle)


def _overlay_error(truth: Camera, found: Camera, scene: Scene) -> float:
    """Largest pixel distance between scene points projected by the two cameras, inside the photo."""
    lo, hi = scene.bounds()
    rng = np.random.default_rng(0)
    points = lo + rng.random((4000, 3)) * (hi - lo)
    z = points @ truth.R[2] + truth.t[2]
    uv_true = _project(truth, points)
    inside = lambda uv: np.all((uv >= 0) & (uv <= [truth.width - 1, truth.height - 1]), axis=1)  # noqa: E731
    # seen by the lens (the distortion polynomial folds points far outside back into the frame),
    # and not right in front of the lens, where no photo of a hall has anything to overlay
    keep = (z > 2.0) & inside(uv_true) & inside(truth.project(points))
    return float(np.linalg.norm(_project(found, points[keep]) - uv_true[keep], axis=1).max())


def _solve_reference(photo, camera, marker_map) -> Camera:
    """The pose from the photo with plain OpenCV (ArUco + subpixel corners + iterative PnP)."""
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY)), params)
    corners, ids, _ = detector.detectMarkers(cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY))
    world = {m["id"]: m["corners"] for m in marker_map["markers"]}
    assert ids is not None and sorted(ids.ravel()) == sorted(world)  # every marker seen
    obj = np.concatenate([world[i] for i in ids.ravel()]).astype(np.float64)
    img = np.concatenate([c.reshape(4, 2) for c in corners]).astype(np.float64)
    ok, rvec, tvec = cv2.solvePnP(obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_SQPNP)
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, camera.K, camera.dist, rvec, tvec)
    return camera.with_pose(cv2.Rodrigues(rvec)[0], tvec.ravel())


def _assert_round_trip(scene, truth, found):
    position, angle = _pose_error(truth, found)
    overlay = _overlay_error(truth, found, scene)
    print(f"round trip: position {position * 1000:.2f} mm, rotation {angle:.4f} deg, overlay {overlay:.3f} px")
    assert position < 0.01 and angle < 0.1 and overlay < 1.0


@pytest.mark.slow
def test_marker_round_trip_with_plain_opencv(marker_shot):
    # the synthetic photo is right: its markers, through the lens model, give the true pose back
    scene, truth, photo, marker_map = marker_shot
    _assert_round_trip(scene, truth, _solve_reference(photo, truth.with_pose(np.eye(3), np.zeros(3)), marker_map))


@pytest.mark.slow
def test_marker_round_trip_with_register_markers(marker_shot):
    registration = pytest.importorskip("mrcheck.mr.registration")
    scene, truth, photo, marker_map = marker_shot
    intrinsics = truth.with_pose(np.eye(3), np.zeros(3))  # registration must not see the true pose
    shot = registration.register_markers(
        np.ascontiguousarray(photo[..., ::-1]), intrinsics, marker_map
    )  # BGR, as imread
    assert (shot.camera.width, shot.camera.height) == (truth.width, truth.height)
    _assert_round_trip(scene, truth, shot.camera)


# -- 3. blending and the command line -------------------------------------------------------------
def test_blend_is_exact_at_the_ends_and_the_mean_between():
    rng = np.random.default_rng(1)
    photo, render = (rng.integers(0, 256, (24, 32, 3), dtype=np.uint8) for _ in range(2))
    camera = make_camera(32, 24, 30.0)
    assert np.array_equal(overlay_images(photo, {"a": render}, camera, 0.0)["a"], render)
    assert np.array_equal(overlay_images(photo, {"a": render}, camera, 1.0)["a"], photo)
    half = overlay_images(photo, {"a": render}, camera, 0.5)["a"].astype(np.float64)
    assert np.abs(half - (photo.astype(np.float64) + render) / 2).max() <= 0.5


@pytest.fixture()
def shot_files(tmp_path):
    """A 160x120 shot of the sample cell without distortion and a random photo of its size."""
    camera = load_scene(sample_scene_path()).camera("overview", 160, 120)
    photo = np.random.default_rng(2).integers(0, 256, (120, 160, 3), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "photo.png"), photo)
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "photo.png"}))
    return shot, photo[..., ::-1]


def _run(capsys, *args):
    code = main(["overlay", *map(str, args)])
    return code, capsys.readouterr().err


@pytest.mark.slow
def test_alpha_zero_is_the_render_and_one_the_photo(shot_files, tmp_path, capsys):
    shot, photo = shot_files
    out0, out1, ref = tmp_path / "a0.png", tmp_path / "a1.png", tmp_path / "render.png"
    assert _run(capsys, shot, "--scene", sample_scene_path(), "--mode", "phong", "--alpha", 0, "-o", out0)[0] == 0
    assert _run(capsys, shot, "--scene", sample_scene_path(), "--mode", "phong", "--alpha", 1, "-o", out1)[0] == 0
    assert main(["render", str(sample_scene_path()), "--camera", str(shot), "--mode", "phong", "-o", str(ref)]) == 0
    assert np.array_equal(cv2.imread(str(out0)), cv2.imread(str(ref)))
    assert np.array_equal(cv2.imread(str(out1))[..., ::-1], photo)
    # in between, alpha is the photo's weight (README): 0.25 is a quarter photo, three quarters CAD
    out = tmp_path / "a025.png"
    assert _run(capsys, shot, "--scene", sample_scene_path(), "--mode", "phong", "--alpha", 0.25, "-o", out)[0] == 0
    expected = 0.25 * photo.astype(np.float64) + 0.75 * cv2.imread(str(ref))[..., ::-1]
    assert np.abs(cv2.imread(str(out))[..., ::-1] - expected).max() <= 0.5 + 1e-9


@pytest.mark.slow
def test_mode_all_writes_the_two_row_sheet(shot_files, tmp_path, capsys):
    shot, _ = shot_files
    out = tmp_path / "all.png"
    assert (
        _run(capsys, shot, "--scene", sample_scene_path(), "--mode", "all", "--edges", "--samples", 4, "-o", out)[0]
        == 0
    )
    sheet = cv2.imread(str(out))
    # three panels side by side, two rows, each panel under its label bar
    assert sheet.shape[1] > 3 * 160 and sheet.shape[0] > 2 * 120 + 2 * 24
    top, bottom = sheet[: sheet.shape[0] // 2], sheet[sheet.shape[0] // 2 :]
    assert not np.array_equal(top, bottom)


@pytest.mark.parametrize(
    "problem", ["missing", "corrupt", "size", "alpha_high", "alpha_low", "alpha_nan", "color", "no_photo_key"]
)
def test_bad_input_is_one_line_and_no_file(problem, shot_files, tmp_path, capsys):
    shot, _ = shot_files
    data = json.loads(shot.read_text())
    args = {"alpha": "0.5", "edge": "00ff00"}
    if problem == "missing":
        data["photo"] = "nowhere.png"
    elif problem == "corrupt":
        (tmp_path / "bad.png").write_bytes(b"\x89PNG not really")
        data["photo"] = "bad.png"
    elif problem == "size":
        cv2.imwrite(str(tmp_path / "small.png"), np.zeros((60, 80, 3), np.uint8))
        data["photo"] = "small.png"
    elif problem.startswith("alpha"):
        args["alpha"] = {"alpha_high": "1.5", "alpha_low": "-0.1", "alpha_nan": "nan"}[problem]
    elif problem == "color":
        args["edge"] = "purple"
    else:
        del data["photo"]
    shot.write_text(json.dumps(data))
    out = tmp_path / "out.png"
    code, err = _run(
        capsys,
        shot,
        "--scene",
        sample_scene_path(),
        "--alpha",
        args["alpha"],
        "--edges",
        "--edge-color",
        args["edge"],
        "-o",
        out,
    )
    assert code == 1
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_ao_options_with_the_phong_mode_warn(shot_files, tmp_path, capsys):
    """As for render: options the chosen mode does not read are a warning, not silence."""
    shot, _ = shot_files
    out = tmp_path / "phong.png"
    code, err = _run(
        capsys, shot, "--scene", sample_scene_path(), "--mode", "phong", "--samples", 8, "--intensity", 2, "-o", out
    )
    warnings = [line for line in err.splitlines() if line.startswith("warning:")]
    assert code == 0 and out.exists()
    assert [w.split()[1] for w in warnings] == ["--intensity", "--samples"]
    assert all("has no effect in mode phong" in w for w in warnings)
