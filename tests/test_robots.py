"""The shipped industrial robots: real sizes through a manifest, working poses, copies, a render."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.render.renderer import Renderer
from mrcheck.scene import robots
from mrcheck.scene.model import load_scene

# Size at the zero pose, metres, from the makers' data sheets (ranges allow for covers and
# cable connectors): (axis, low, high) of the scene bounds' maximum, and the largest distance
# of any point from the base origin in any sampled pose (the robot never grows).
#   iiwa: stretched upright, 1.31 m tall.  UR5 / UR10: arm horizontal along +x, 0.85 / 1.3 m
#   reach.  IRB 140: upper arm up, forearm forward: 0.81 m tall, flange 0.52 m forward.
ZERO_POSE_SIZE = {
    "kuka_iiwa": [(2, 1.25, 1.36)],
    "ur5": [(0, 0.80, 0.90), (2, 0.10, 0.20)],
    "ur10": [(0, 1.18, 1.30), (2, 0.15, 0.26)],
    "abb_irb140": [(2, 0.75, 0.85), (0, 0.45, 0.58)],
}
MAX_DISTANCE = {"kuka_iiwa": 1.35, "ur5": 1.10, "ur10": 1.52, "abb_irb140": 1.12}
FOOTPRINT = {"kuka_iiwa": (0.10, 0.20), "ur5": (0.07, 0.13), "ur10": (0.09, 0.13), "abb_irb140": (0.20, 0.35)}
BASE_TOLERANCE = 0.005  # m: the UR base mesh reaches 3 mm below its origin


def _part(name, mesh, joints, translate=(0.0, 0.0, 0.0)) -> str:
    table = ", ".join(f"{k} = {v!r}" for k, v in joints.items())
    return (
        f'\n[[parts]]\nname = "{name}"\nmesh = "{mesh}"\nunits = "m"\n'
        f"translate = [{translate[0]}, {translate[1]}, {translate[2]}]\njoints = {{ {table} }}\n"
    )


@pytest.fixture(scope="module")
def copies(tmp_path_factory):
    """{robot: copied robot.urdf}: every robot copied once into a scene folder."""
    folder = tmp_path_factory.mktemp("scene")
    return folder, {name: robots.copy_robot(name, folder / "robots") for name in robots.ROBOT_NAMES}


def _load_posed(copies, name, joints):
    """The scene of one manifest part: the copied robot at pose ``joints``, in metres."""
    folder, urdfs = copies
    manifest = folder / f"{name}.toml"
    manifest.write_text("format = 1\n" + _part(name, urdfs[name].relative_to(folder).as_posix(), joints))
    scene = load_scene(manifest)
    assert [p.units for p in scene.parts] == ["m"]
    return scene


@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_each_robot_loads_through_a_manifest_at_its_real_size(copies, name):
    bounds = _load_posed(copies, name, {}).bounds()
    for axis, low, high in ZERO_POSE_SIZE[name]:
        assert low < bounds[1, axis] < high, (name, bounds)
    if not name.startswith("ur"):  # a UR's zero pose (arm level with the shoulder) dips 3-5 cm
        assert abs(bounds[0, 2]) < BASE_TOLERANCE  # below its base: no working pose, never sampled
    low, high = FOOTPRINT[name]
    assert low < robots.base_footprint(name) < high


@pytest.mark.slow
@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_sampled_poses_are_seeded_within_limits_and_above_the_base(copies, name):
    limits = robots.joint_limits(name)
    a1 = robots.sample_joints(name, np.random.default_rng(1))
    a2 = robots.sample_joints(name, np.random.default_rng(1))
    b = robots.sample_joints(name, np.random.default_rng(2))
    assert a1 == a2 and list(a1) == list(limits)
    assert a1 != b
    for pose in (a1, b):
        for joint, value in pose.items():
            lo, hi = limits[joint]
            mid, half = (lo + hi) / 2, (hi - lo) / 2 * robots.WORKING_SHARE
            assert lo <= mid - half - 1e-4 <= value <= mid + half + 1e-4 <= hi, (joint, value)

    scene_a, scene_b = _load_posed(copies, name, a1), _load_posed(copies, name, b)
    va, vb = (s.parts[0].vertices.astype(np.float64) + s.parts[0].transforms[0, :3, 3] for s in (scene_a, scene_b))
    assert va.shape == vb.shape and not np.allclose(va, vb, atol=1e-3)  # same mesh, moved links
    for scene, vertices in ((scene_a, va), (scene_b, vb)):
        assert scene.bounds()[0, 2] >= -BASE_TOLERANCE  # nothing below the base plane
        assert np.linalg.norm(vertices, axis=1).max() < MAX_DISTANCE[name]


@pytest.mark.parametrize(
    "value, message",
    [
        ("50.0", "joint 'lbr_iiwa_joint_2' = 50 is outside its limits -2.094 .. 2.094 rad in robot.urdf"),
        (
            "90",
            "= 90 is outside its limits -2.094 .. 2.094 rad in robot.urdf; degrees? joint values are radians "
            "(90 deg = 1.571 rad)",
        ),
        ("-2.1", "= -2.1 is outside its limits"),
        ("nan", "joint 'lbr_iiwa_joint_2' must be a finite number"),
        ("inf", "must be a finite number"),
        ("true", "must be a finite number (radians, or metres for a prismatic joint), got True"),
        ('"a"', "must be a finite number (radians, or metres for a prismatic joint), got 'a'"),
        ("[1.0]", "must be a finite number"),
    ],
)
def test_bad_joint_values_are_errors_of_the_manifest(copies, value, message):
    folder, urdfs = copies
    manifest = folder / "bad_joint.toml"
    mesh = urdfs["kuka_iiwa"].relative_to(folder).as_posix()
    manifest.write_text(
        "format = 1\n" + _part("arm", mesh, {}).replace("joints = {  }", f"joints = {{ lbr_iiwa_joint_2 = {value} }}")
    )
    with pytest.raises(MrcheckError) as err:
        load_scene(manifest)
    assert str(err.value).startswith(f"{manifest}: part 'arm': ") and message in str(err.value), str(err.value)
    assert "\n" not in str(err.value)


def test_joint_values_at_their_limits_and_unknown_joints(copies):
    folder, urdfs = copies
    lo, hi = robots.joint_limits("kuka_iiwa")["lbr_iiwa_joint_2"]
    assert _load_posed(copies, "kuka_iiwa", {"lbr_iiwa_joint_2": round(hi, 6), "lbr_iiwa_joint_4": round(lo, 6)}).parts
    manifest = folder / "bad_joint.toml"
    manifest.write_text(
        "format = 1\n" + _part("arm", urdfs["kuka_iiwa"].relative_to(folder).as_posix(), {"elbow": 0.5})
    )
    with pytest.raises(
        MrcheckError, match=r"part 'arm': unknown joint\(s\) elbow \(the robot robot.urdf has: lbr_iiwa_joint_1,"
    ):
        load_scene(manifest)


@pytest.mark.slow
def test_robot_mesh_is_the_posed_robot_in_metres():
    pose = robots.sample_joints("ur5", np.random.default_rng(7))
    vertices, faces = robots.robot_mesh("ur5", pose)
    assert vertices.dtype == np.float64 and faces.shape[1] == 3
    assert vertices[:, 2].min() >= -BASE_TOLERANCE and 0.3 < vertices[:, 2].max() < MAX_DISTANCE["ur5"]
    zero, _ = robots.robot_mesh("ur5")
    assert zero.shape == vertices.shape and not np.allclose(zero, vertices)
    with pytest.raises(MrcheckError, match="shoulder_pan_joint"):
        robots.robot_mesh("ur5", {"joint_1": 0.5})  # an IRB 140 joint name: lists the UR's


def test_copy_robot_brings_the_licence_and_is_idempotent(tmp_path):
    licences = {"kuka_iiwa": "LICENSE.txt", "ur5": "LICENSE", "ur10": "LICENSE", "abb_irb140": "LICENSE"}
    for name, licence in licences.items():
        urdf = robots.copy_robot(name, tmp_path)
        assert urdf == tmp_path / name / "robot.urdf" and urdf.is_file()
        source = robots.robot_dir(name)
        for file in (licence, "SOURCE.md", "robot.urdf"):
            assert (tmp_path / name / file).read_bytes() == (source / file).read_bytes()
        assert "package://" not in urdf.read_text() or name == "kuka_iiwa"  # iiwa paths were relative already
        assert not list((tmp_path / name).rglob("collision*"))
        stamps = {p: p.stat().st_mtime_ns for p in (tmp_path / name).rglob("*")}
        assert robots.copy_robot(name, tmp_path) == urdf
        assert stamps == {p: p.stat().st_mtime_ns for p in (tmp_path / name).rglob("*")}
    text = (tmp_path / "abb_irb140" / "LICENSE").read_text()
    assert "MIT License" in text and "Peter Corke" in text


def test_joint_limits_come_from_the_urdf():
    assert robots.joint_limits("abb_irb140")["joint_2"] == (-1.7453, 1.9199)
    assert len(robots.joint_limits("kuka_iiwa")) == 7 and len(robots.joint_limits("ur10")) == 6
    assert robots.joint_limits("ur5")["elbow_joint"] == pytest.approx((-math.pi, math.pi))


@pytest.mark.parametrize(
    "call",
    [
        robots.robot_dir,
        robots.joint_limits,
        robots.base_footprint,
        lambda n: robots.sample_joints(n, np.random.default_rng(0)),
        lambda n: robots.copy_robot(n, "/nonexistent"),
        robots.robot_mesh,
    ],
)
def test_unknown_robot_names_list_the_known_ones(call):
    with pytest.raises(MrcheckError) as caught:
        call("kuka_kr16")
    assert "kuka_kr16" in str(caught.value) and all(n in str(caught.value) for n in robots.ROBOT_NAMES)


@pytest.mark.slow
def test_the_four_robots_render_side_by_side(ctx, copies):
    """Smoke test: a floor and the four robots in a row, upright, seen level from the front."""
    folder, urdfs = copies
    upright = {
        "kuka_iiwa": {},
        "ur5": {"shoulder_lift_joint": -math.pi / 2},
        "ur10": {"shoulder_lift_joint": -math.pi / 2},
        "abb_irb140": {},
    }
    xs = [-2.4, -0.8, 0.8, 2.4]
    floor = trimesh.creation.box((7.0, 3.0, 0.1), trimesh.transformations.translation_matrix((0, 0, -0.05)))
    floor.export(folder / "floor.stl")
    text = 'format = 1\n\n[[parts]]\nname = "floor"\nmesh = "floor.stl"\nunits = "m"\n'
    for x, name in zip(xs, robots.ROBOT_NAMES):
        text += _part(name, urdfs[name].relative_to(folder).as_posix(), upright[name], (x, 0.0, 0.0))
    (folder / "lineup.toml").write_text(text)
    scene = load_scene(folder / "lineup.toml")
    assert len(scene.parts) == 5

    # level camera at 0.45 m: the floor (z <= 0) is only ever seen below the image centre
    camera = Camera.from_look_at((0, -6.5, 0.45), (0, 0, 0.45), (0, 0, 1), 45.0, 160, 120)
    renderer = Renderer(scene, ctx=ctx)
    depth = renderer.render(camera, ["phong"]).depth
    assert depth.shape == (120, 160)
    for x, name in zip(xs, robots.ROBOT_NAMES):
        u, v = camera.project(np.array([[x, 0.0, 0.6]]))[0]
        window = depth[int(v) - 8 : int(camera.cy) - 1, int(u) - 6 : int(u) + 7]  # above the horizon
        assert (window > 0).sum() >= 10, name
    assert (depth[int(camera.cy) + 2 :] > 0).mean() > 0.1  # the floor in front
    assert not depth[:5].any()  # sky above the robots
