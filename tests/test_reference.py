"""The ray-traced reference AO: convergence, analytic values, precision far from the origin, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval.reference import REFERENCE_LOD_PX, reference_ao
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import load_scene

from .conftest import box, scene_of

SCENE = str(sample_scene_path())


def gbuffer(ctx, scene, camera):
    renderer = Renderer(scene, ctx=ctx)
    try:
        # single-sampled, as `mrcheck reference` renders (every pixel a point of the surface its centre sees)
        frame = renderer.render(
            camera, ["phong"], RenderSettings(lod_px=REFERENCE_LOD_PX, antialias=False), want_normals=True
        )
        return frame.depth, frame.normals
    finally:
        renderer.release()


def world_points(camera, depth):
    """(H, W, 3) world coordinates of the G-buffer points (NaN on the background)."""
    H, W = depth.shape
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    z = np.where(depth > 0, depth.astype(np.float64), np.nan)
    p_cam = np.stack(((u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z), -1)
    return (p_cam - camera.t) @ camera.R  # R^T (p - t), row-vector form


def crease_ao_expected(x, r, c, steps=1500):
    """AO, by midpoint quadrature over the hemisphere, of a point on a floor at distance x from
    an infinitely tall wall, rays of at most r, hits weighted 1 / (1 + c (d/r)^2), cosine-
    weighted: AO = 1 - (1/pi) * integral(hit * att * cos(theta) sin(theta) dtheta dphi).
    Written from the definition, independent of the implementation under test."""
    theta = (np.arange(steps) + 0.5) * (np.pi / 2) / steps
    phi = (np.arange(2 * steps) + 0.5) * np.pi / (2 * steps)  # only sin(phi) > 0 faces the wall
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    toward = np.sin(th) * np.sin(ph)  # direction component toward the wall
    with np.errstate(divide="ignore"):
        d = np.where(toward > 0, x / toward, np.inf)
    weight = np.where(d < r, 1.0 / (1.0 + c * (d / r) ** 2), 0.0)
    integrand = weight * np.cos(th) * np.sin(th)
    occlusion = integrand.sum() * (np.pi / 2 / steps) * (np.pi / (2 * steps)) / np.pi
    return 1.0 - occlusion


@pytest.mark.slow
def test_quadrature_sanity():
    # the two limits the quadrature must reproduce: at the crease half the hemisphere is wall
    assert crease_ao_expected(0.0, 1.0, 1.0) == pytest.approx(0.5, abs=1e-3)
    assert crease_ao_expected(2.0, 1.0, 0.0) == pytest.approx(1.0, abs=1e-9)


def _wall_scene(offset=(0.0, 0.0, 0.0)):
    # a large floor (top at z = 0) and a box standing on it: its face y = 6 is a wall 10 m tall
    return scene_of(box((60, 60, 0.2), (0, 0, -0.1)), box((8, 2, 10), (0, 7, 5)), offset=offset)


def _wall_camera(offset=(0.0, 0.0, 0.0), width=160, height=120):
    o = np.asarray(offset, np.float64)
    return Camera.from_look_at(o + (0, 2.5, 3.0), o + (0, 6, 0), (0, 0, 1), 60, width, height)


def _floor_pixels(camera, depth, normals):
    """Floor pixels (world z = 0, normal up) and their distance to the wall face y = 6."""
    X = world_points(camera, depth)
    up = (normals.astype(np.float64) @ camera.R)[..., 2]  # world z of the normal
    floor = (depth > 0) & (np.abs(X[..., 2]) < 1e-3) & (up > 0.99) & (np.abs(X[..., 0]) < 1)
    return floor, 6.0 - X[..., 1]


@pytest.mark.slow
def test_floor_and_crease_match_the_analytic_values(ctx):
    scene, camera = _wall_scene(), _wall_camera()
    depth, normals = gbuffer(ctx, scene, camera)
    floor, x = _floor_pixels(camera, depth, normals)

    # only the floor pixels are traced (the rest passed as background) to keep the test fast
    depth = np.where(floor, depth, 0.0).astype(np.float32)
    r, c = 1.0, 1.0
    ao = reference_ao(scene, camera, depth, normals, 1024, "world", r, falloff=c, seed=1)
    # open floor farther than r from everything: not a single ray may hit (no self-intersection)
    far = floor & (x > r + 0.05)
    assert far.sum() > 200 and np.all(ao[far] == 1.0)
    # a floor pixel next to the crease, at about 0.3 r from the wall: attenuation matters there
    candidates = np.where(floor, np.abs(x - 0.3 * r), np.inf)
    j, i = np.unravel_index(np.argmin(candidates), candidates.shape)
    assert abs(x[j, i] - 0.3 * r) < 0.05
    expected = crease_ao_expected(x[j, i], r, c)
    assert 0.6 < expected < 0.95  # a real test, not 0.5 or 1
    assert ao[j, i] == pytest.approx(expected, abs=0.02)
    # the whole band 0.1 r .. 0.8 r from the wall, pixel by pixel
    band = floor & (x > 0.1 * r) & (x < 0.8 * r)
    errors = [ao[jj, ii] - crease_ao_expected(x[jj, ii], r, c, steps=400) for jj, ii in zip(*np.nonzero(band))][:60]
    assert len(errors) >= 20 and np.max(np.abs(errors)) < 0.02

    # c = 0, radius far smaller than the wall: the pixel nearest the crease is about 0.5
    r0 = 2.0
    ao0 = reference_ao(scene, camera, depth, normals, 1024, "world", r0, falloff=0.0, seed=2)
    candidates = np.where(floor, x, np.inf)
    j, i = np.unravel_index(np.argmin(candidates), candidates.shape)
    assert x[j, i] < 0.05 * r0
    assert ao0[j, i] == pytest.approx(crease_ao_expected(x[j, i], r0, 0.0), abs=0.02)
    assert ao0[j, i] == pytest.approx(0.5, abs=0.05)
    assert np.all(ao0[floor & (x > r0 + 0.05)] == 1.0)


@pytest.mark.slow
def test_converges_on_the_sample_scene(ctx):
    scene = load_scene(SCENE)
    camera = scene.camera("robot", 96, 72)
    depth, normals = gbuffer(ctx, scene, camera)
    for mode, radius in (("screen", 0.05 * 72), ("world", 0.2)):
        coarse = reference_ao(scene, camera, depth, normals, 256, mode, radius, seed=0)
        fine = reference_ao(scene, camera, depth, normals, 1024, mode, radius, seed=1)
        assert coarse.dtype == np.float32 and coarse.shape == (72, 96)
        assert (fine < 0.9).mean() > 0.02  # there is occlusion to converge on
        assert np.abs(coarse - fine).mean() < 0.01
        assert np.array_equal(reference_ao(scene, camera, depth, normals, 256, mode, radius, seed=0), coarse)


def test_translation_by_a_million_metres_gives_the_same_reference(ctx):
    offset = (1e6, -1e6, 1e6)
    results = []
    for o in ((0.0, 0.0, 0.0), offset):
        scene, camera = _wall_scene(o), _wall_camera(o, 96, 72)
        depth, normals = gbuffer(ctx, scene, camera)
        results.append(reference_ao(scene, camera, depth, normals, 128, "screen", 0.05 * 72, seed=3))
    near, far = results
    assert (near < 0.95).mean() > 0.02
    assert np.abs(near - far).mean() < 0.005


@pytest.mark.slow
def test_cli_writes_the_ao_contract(ctx, tmp_path, capsys):
    out = tmp_path / "sub" / "ref.npy"
    assert (
        main(
            [
                "reference",
                SCENE,
                "--view",
                "overview",
                "--width",
                "64",
                "--height",
                "48",
                "--rays",
                "32",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert str(out) in captured.out and "rays/s" in captured.err
    ao = np.load(out)
    assert ao.dtype == np.float32 and ao.shape == (48, 64)
    assert 0.0 <= ao.min() < 1.0 and ao.max() <= 1.0
    scene = load_scene(SCENE)
    depth, _ = gbuffer(ctx, scene, scene.camera("overview", 64, 48))
    assert (depth == 0).any() and np.all(ao[depth == 0] == 1.0)  # background is 1.0


@pytest.mark.parametrize(
    "args",
    [
        ["--width", "32", "--height", "24", "-o", "{tmp}/ref.npy"],  # neither view nor camera
        ["--view", "robot", "--width", "32", "--height", "24", "-o", "{tmp}/ref.txt"],  # bad suffix
        ["--view", "robot", "--camera", "{tmp}/cam.json", "-o", "{tmp}/ref.npy"],  # both
        ["--view", "nowhere", "--width", "32", "--height", "24", "-o", "{tmp}/ref.npy"],  # unknown view
        ["--view", "robot", "--width", "32", "--height", "24", "--falloff", "-1", "-o", "{tmp}/ref.npy"],
        ["--view", "robot", "--width", "32", "--height", "24", "--seed", "-1", "-o", "{tmp}/ref.npy"],
        [
            "--view",
            "robot",
            "--width",
            "32",
            "--height",
            "24",
            "--rays",
            "100000",
            "-o",
            "{tmp}/ref.npy",
        ],  # a typo, hours
        ["--view", "robot", "--width", "32", "--height", "24", "-o", "/proc/ref.npy"],  # unwritable: before the rays
    ],
)
def test_cli_bad_input_is_one_error_line_and_no_file(tmp_path, capsys, args):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["reference", SCENE, *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "options, warned",
    [
        (
            ["--radius-mode", "world", "--radius-px", "5"],
            "--radius-px has no effect in radius mode world (it applies to screen)",
        ),
        (
            ["--radius-mode", "screen", "--radius", "0.5"],
            "--radius has no effect in radius mode screen (it applies to world)",
        ),
        (["--radius-mode", "world", "--radius", "0.5"], None),
        (["--radius-px", "5"], None),
    ],
)
def test_cli_warns_about_the_radius_its_radius_mode_ignores(tmp_path, capsys, options, warned):
    """As render warns about an option its mode does not read: the user meant one or the other."""
    out = tmp_path / "ref.npy"
    assert main(["reference", SCENE, "--view", "robot", "--width", "32", "--rays", "4", *options, "-o", str(out)]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert warnings == ([f"warning: {warned}"] if warned else [])


def test_cli_refuses_a_screen_radius_larger_than_the_image(tmp_path, capsys):
    out = tmp_path / "ref.npy"
    args = ["reference", SCENE, "--view", "robot", "--width", "64", "--rays", "4", "-o", str(out)]
    assert main([*args, "--radius-px", "49"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "radius of 49 px is larger than the image (48 px high)" in err[0], err
    assert not out.exists()
    assert main([*args, "--radius-px", "48"]) == 0
