"""The robots of the generated cells: which model, which pose, what it costs in triangles.

A thin layer over :mod:`mrcheck.scene.robots` (the URDF models, their licences and pose sampling):
choosing a model by the seed within a triangle allowance and drawing poses that stay inside
the cell's fence. Robot meshes are in metres with the base origin at the foot of the base.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from mrcheck.scene import robots

ROBOT_COLORS = {  # linear RGB, the makers' paint
    "kuka_iiwa": (0.85, 0.85, 0.82),
    "ur5": (0.55, 0.62, 0.7),
    "ur10": (0.55, 0.62, 0.7),
    "abb_irb140": (0.95, 0.45, 0.05),
}
POSE_TRIES = 20  # poses drawn before settling for the closest one
MIN_TOP = 0.5  # m above its base the posed robot reaches at least (arm up, not lying flat)


@lru_cache(maxsize=None)
def robot_triangles(name: str) -> int:
    """Triangles of the posed robot as mrcheck renders it (the same for every pose)."""
    return len(robots.robot_mesh(name)[1])


def choose_robot(rng: np.random.Generator, max_triangles: float) -> str:
    """A robot model drawn by ``rng`` among those within ``max_triangles``.

    When none is that small, the smallest: a cell always gets a robot.
    """
    fitting = [n for n in robots.ROBOT_NAMES if robot_triangles(n) <= max_triangles]
    if not fitting:
        fitting = [min(robots.ROBOT_NAMES, key=robot_triangles)]
    return fitting[int(rng.integers(len(fitting)))]


def working_pose(name: str, rng: np.random.Generator, reach: float) -> dict[str, float]:
    """A pose from :func:`mrcheck.scene.robots.sample_joints` that stays within ``reach`` metres of
    the robot's vertical axis (inside the fence) and lifts the arm at least MIN_TOP above the
    base (sample_joints also allows an arm stretched flat over the pedestal, which looks like a
    robot lying down); after POSE_TRIES draws, the draw that came closest."""
    best, best_miss = None, np.inf
    for _ in range(POSE_TRIES):
        joints = robots.sample_joints(name, rng)
        vertices, _ = robots.robot_mesh(name, joints)
        radius = float(np.hypot(vertices[:, 0], vertices[:, 1]).max())
        miss = max(0.0, radius - reach) + max(0.0, MIN_TOP - float(vertices[:, 2].max()))
        if miss == 0.0:
            return joints
        if miss < best_miss:
            best, best_miss = joints, miss
    return best


def pedestal_scale(name: str) -> float:
    """Plan scale of the sample cell's pedestal (0.6 m top plate) that holds the robot's base."""
    return max(1.0, (robots.base_footprint(name) + 0.04) / 0.3)


__all__ = ["ROBOT_COLORS", "robot_triangles", "choose_robot", "working_pose", "pedestal_scale"]
