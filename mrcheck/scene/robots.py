"""Real industrial robot models for generated factory scenes: files, joint limits, working poses.

Four URDF robots ship in ``factory_scenes/assets/robots/<name>/`` (each folder holds
``robot.urdf``, its visual meshes, the licence of its source package and a ``SOURCE.md``
saying where it comes from and what was changed):

==============  =====================  ===========================================  =========
name            robot                  zero pose, as loaded (metres)                base r
==============  =====================  ===========================================  =========
``kuka_iiwa``   KUKA LBR iiwa 14 R820  upright, 1.31 tall                           0.15
``ur5``         Universal Robots UR5   arm level at shoulder height, 0.86 long      0.11
``ur10``        Universal Robots UR10  arm level at shoulder height, 1.23 long      0.095
``abb_irb140``  ABB IRB 140            upper arm up, forearm forward: 0.81 tall     0.33
==============  =====================  ===========================================  =========

(base r: :func:`base_footprint`. A UR's zero pose dips 3-5 cm below its base, so it is no
working pose; :func:`sample_joints` never returns one like it.)

All four are authored (or, for the IRB 140, rescaled when copied) in metres with z up and
the robot's origin on its vertical axis at the foot of its base, so a manifest part needs
``units = "m"`` and a translate to where the robot stands::

    [[parts]]
    name = "robot_1"
    mesh = "robots/ur10/robot.urdf"   # as written by copy_robot(name, scene_dir / "robots")
    units = "m"
    joints = { shoulder_pan_joint = 0.3, shoulder_lift_joint = -1.2 }

A scene generator copies the robot next to its manifest (:func:`copy_robot`), draws a pose
(:func:`sample_joints`) and sizes a pedestal from :func:`base_footprint`.
"""

from __future__ import annotations

import filecmp
import math
import shutil
import threading
from functools import lru_cache, partial
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import robot_assets_dir

ROBOT_NAMES = ("kuka_iiwa", "ur5", "ur10", "abb_irb140")

URDF_NAME = "robot.urdf"
WORKING_SHARE = 0.6  # sampled joints stay in the middle 60 % of their range: no pose at a hard stop
FLOOR_CLEARANCE = 0.05  # m the forearm and wrist keep above the base plane (no tool lying on the floor)
BASE_TOLERANCE = 0.001  # m: mesh noise; the UR base itself reaches 3 mm below its origin
MAX_TRIES = 200  # poses drawn per sample_joints call; every robot accepts well over 10 % of them


def _check_name(name) -> str:
    if name not in ROBOT_NAMES:
        raise MrcheckError(f"unknown robot {name!r} (known robots: {', '.join(ROBOT_NAMES)})")
    return name


def robot_dir(name) -> Path:
    """The folder of one robot: ``factory_scenes/assets/robots/<name>``.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.

    Returns
    -------
    pathlib.Path
        Holds ``robot.urdf``, ``meshes/``, the licence file and ``SOURCE.md``.

    Raises
    ------
    MrcheckError
        For a name not in :data:`ROBOT_NAMES`.
    """
    return robot_assets_dir() / _check_name(name)


def robot_urdf(name) -> Path:
    """The shipped ``robot.urdf`` of one robot (see :func:`robot_dir`)."""
    return robot_dir(name) / URDF_NAME


# -- the URDF model --------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _kinematics(name):
    """The yourdfpy model without meshes: joints and limits only, loads in milliseconds."""
    import yourdfpy

    return yourdfpy.URDF.load(
        str(robot_urdf(name)),
        build_scene_graph=False,
        load_meshes=False,
        build_collision_scene_graph=False,
        load_collision_meshes=False,
    )


class _PosedModel:
    """One robot's visual meshes reduced to convex-hull points, for fast pose checks.

    :func:`sample_joints` tries many poses; loading the meshes for each (what
    :func:`mrcheck.scene.meshes.read_mesh` does) would take 0.1-0.3 s per try. The lowest and the
    outermost point of a mesh are vertices of its convex hull, so the hull points give the same
    answers from a few hundred points per link.
    """

    def __init__(self, name):
        import yourdfpy

        path = robot_urdf(name)
        # loaded exactly as mrcheck.scene.meshes.read_mesh loads a URDF part, so the poses checked here
        # are the poses rendered
        handler = partial(yourdfpy.filename_handler_magic, dir=str(path.parent))
        self.urdf = yourdfpy.URDF.load(
            str(path), filename_handler=handler, build_collision_scene_graph=False, load_collision_meshes=False
        )
        self.lock = threading.Lock()  # update_cfg mutates the shared model
        graph = self.urdf.scene.graph
        depth = _actuated_depth(self.urdf)
        self.nodes = []  # (scene node, hull points (n, 4) homogeneous, actuated joints above its link)
        for node in graph.nodes_geometry:
            mesh = self.urdf.scene.geometry[graph[node][1]]
            points = np.asarray(mesh.convex_hull.vertices, np.float64)
            link = graph.transforms.parents[node]
            self.nodes.append((node, np.hstack([points, np.ones((len(points), 1))]), depth.get(link, 0)))

    def points(self, cfg):
        """[(world hull points (n, 3), depth), ...] of every visual at the pose ``cfg``."""
        with self.lock:
            self.urdf.update_cfg(np.asarray(cfg, np.float64))
            graph = self.urdf.scene.graph
            return [((graph[node][0] @ pts.T).T[:, :3], depth) for node, pts, depth in self.nodes]


def _actuated_depth(urdf) -> dict:
    """{link: number of actuated joints between the root and it} (0: fixed to the base)."""
    parent_joint = {j.child: j for j in urdf.robot.joints}
    actuated = set(urdf.actuated_joint_names)
    depth = {}
    for link in urdf.link_map:
        count, current = 0, link
        while current in parent_joint:
            joint = parent_joint[current]
            count += joint.name in actuated
            current = joint.parent
        depth[link] = count
    return depth


@lru_cache(maxsize=None)
def _posed_model(name) -> _PosedModel:
    return _PosedModel(_check_name(name))


@lru_cache(maxsize=None)
def _base_points(name) -> np.ndarray:
    """(n, 3) hull points of the geometry fixed to the base (independent of the pose)."""
    model = _posed_model(name)
    zero = np.zeros(len(joint_limits(name)))
    fixed = [pts for pts, depth in model.points(zero) if depth == 0]
    return np.concatenate(fixed)


def _base_plane(name) -> float:
    """z (m) of the lowest point of the base: the floor or pedestal top the robot stands on."""
    return float(_base_points(name)[:, 2].min())


# -- public API ------------------------------------------------------------------------------------
def joint_limits(name) -> dict[str, tuple[float, float]]:
    """The range of every actuated joint, from the URDF.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.

    Returns
    -------
    dict of str to (float, float)
        ``{joint name: (lower, upper)}`` in radians (metres for a prismatic joint), in the
        URDF's actuated-joint order. Continuous joints and joints without a limit get
        ``(-pi, pi)``: every orientation once.
    """
    from mrcheck.scene.meshes import urdf_joint_range

    urdf = _kinematics(_check_name(name))  # checked first: the cache needs a hashable name
    limits = {}
    for joint_name in urdf.actuated_joint_names:
        limits[joint_name] = urdf_joint_range(urdf.joint_map[joint_name]) or (-math.pi, math.pi)
    return limits


def sample_joints(name, rng) -> dict[str, float]:
    """A plausible working pose: random joints in the middle of their ranges, arm above the base.

    Each joint is drawn uniformly from the middle :data:`WORKING_SHARE` (60 %) of its range and
    rounded to 1e-4 rad (readable manifests; 0.1 mm at 1 m). A pose is kept only if no part
    of the robot goes below its base plane and the forearm and wrist (links behind the third
    actuated joint) stay :data:`FLOOR_CLEARANCE` above it; otherwise a new pose is drawn, at
    most :data:`MAX_TRIES` times.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.
    rng : numpy.random.Generator or int
        The random source (an int is used as a seed). The same generator state gives the same
        pose; the generator is advanced by the draws.

    Returns
    -------
    dict of str to float
        ``{joint name: value}`` for every actuated joint, as in :func:`joint_limits`; fits a
        manifest part's ``joints`` table as it is.

    Raises
    ------
    RuntimeError
        If no draw passes (does not happen for the shipped robots: each accepts more than a
        tenth of its draws).
    """
    limits = joint_limits(name)
    rng = np.random.default_rng(rng)  # a Generator passes through unchanged
    lo, hi = np.array(list(limits.values())).T
    middle, half = (lo + hi) / 2.0, (hi - lo) / 2.0 * WORKING_SHARE
    for _ in range(MAX_TRIES):
        q = np.round(rng.uniform(middle - half, middle + half), 4)
        if _above_base(name, q):
            return {joint: float(value) for joint, value in zip(limits, q)}
    raise RuntimeError(f"{name}: no pose above the base in {MAX_TRIES} draws")


def _above_base(name, q) -> bool:
    floor = _base_plane(name)
    for points, depth in _posed_model(name).points(q):
        low = float(points[:, 2].min())
        if low < floor - BASE_TOLERANCE:
            return False
        # depth 3+: behind the elbow (UR, IRB 140) or the third axis (iiwa); the upper arm may
        # lie low (a UR's does at its zero pose), the forearm and tool may not
        if depth >= 3 and low < floor + FLOOR_CLEARANCE:
            return False
    return True


def copy_robot(name, dest) -> Path:
    """Copy one robot (URDF, meshes, licence, ``SOURCE.md``) into ``dest/<name>/``.

    Files already there with the same bytes are left alone (their times too), others are
    overwritten, so calling it again is cheap and changes nothing; files in ``dest/<name>/``
    that the robot does not have are kept.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.
    dest : path-like
        Folder to copy into, typically ``<scene folder>/robots``; created if missing.

    Returns
    -------
    pathlib.Path
        ``dest/<name>/robot.urdf``, for a manifest's ``mesh`` entry (relative to the manifest).
    """
    src = robot_dir(name)
    out = Path(dest) / name
    for file in sorted(src.rglob("*")):
        if not file.is_file() or "__pycache__" in file.parts:
            continue
        target = out / file.relative_to(src)
        if target.is_file() and filecmp.cmp(file, target, shallow=False):
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(file, target)  # bytes only: the installed copy may be read-only
    return out / URDF_NAME


def robot_mesh(name, joints=None) -> tuple[np.ndarray, np.ndarray]:
    """The posed robot as one triangle mesh, exactly as a manifest part renders it.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.
    joints : dict of str to float, optional
        Joint values (radians); joints not given are 0.

    Returns
    -------
    vertices : (n, 3) float64
        Metres, in the robot's base frame (z up, base origin at 0).
    faces : (m, 3) int64

    Raises
    ------
    MrcheckError
        For an unknown robot or joint name.
    """
    from mrcheck.scene.meshes import read_mesh

    return read_mesh(robot_urdf(name), joints or {})


def base_footprint(name) -> float:
    """Radius (m) of the robot's base around its vertical axis, to size a pedestal or plinth.

    The largest horizontal distance of any point of the base (the geometry that no joint
    moves, cable connectors included) from the robot's origin; a round pedestal of this
    radius centred on the origin holds the whole base.

    Parameters
    ----------
    name : str
        One of :data:`ROBOT_NAMES`.

    Returns
    -------
    float
        Metres: about 0.15 (iiwa), 0.11 (UR5, its cable connector), 0.095 (UR10), 0.33 (IRB 140,
        whose base reaches back behind its axis).
    """
    points = _base_points(_check_name(name))  # cached per robot
    return float(np.hypot(points[:, 0], points[:, 1]).max())


__all__ = [
    "ROBOT_NAMES",
    "WORKING_SHARE",
    "FLOOR_CLEARANCE",
    "robot_dir",
    "robot_urdf",
    "joint_limits",
    "sample_joints",
    "copy_robot",
    "robot_mesh",
    "base_footprint",
]
