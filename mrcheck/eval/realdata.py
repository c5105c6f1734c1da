"""Readers for the shared real data sets (``../shared/data/real/``, see its README): scenes,
cameras and published poses as mrcheck records. Nothing here is copied into the repository.

* LM-O (BOP, CC BY-SA 4.0): ``scene_gt.json`` / ``scene_camera.json``; model-to-camera poses
  ``X_cam = R X_model + t`` with t in millimetres; the PLY meshes in millimetres. BOP's
  rotations are not quite orthonormal, so the nearest rotation (SVD) is taken.
* M3T (DLR, MIT): the two OBJ meshes in metres with their mesh-to-camera poses of frame 200 as
  the data set's README derives them (world = the colour camera).
* The tea box (ViSP, GPL-2.0+): the ``.cao`` cuboid's 8 points in metres.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.scene.meshes import read_mesh
from mrcheck.scene.model import Part, Scene, make_part


def real_root() -> Path:
    """The shared real data folder: ``$MRCHECK_REAL_DATA``, else ``../shared/data/real`` beside
    the repository (or beside its parent folder, for a worktree kept one level down); the
    first candidate when none exists."""
    env = os.environ.get("MRCHECK_REAL_DATA")
    if env:
        return Path(env)
    repo = Path(__file__).resolve().parents[2]
    candidates = [folder / "shared" / "data" / "real" for folder in (repo.parent, repo.parent.parent)]
    return next((c for c in candidates if c.exists()), candidates[0])


def nearest_rotation(R) -> np.ndarray:
    """The rotation closest to ``R`` (Frobenius; SVD with the determinant fixed)."""
    u, _, vt = np.linalg.svd(np.asarray(R, np.float64).reshape(3, 3))
    d = np.sign(np.linalg.det(u @ vt))
    return u @ np.diag([1.0, 1.0, d]) @ vt


def pose_matrix(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


@dataclass
class RealObject:
    """One object in a photo: ``name``, mesh ``vertices`` (n, 3) and ``faces`` in metres in its
    own frame, ``pose`` (4, 4) model to camera in metres."""

    name: str
    source: Path
    vertices: np.ndarray
    faces: np.ndarray
    pose: np.ndarray


@dataclass
class RealPhoto:
    """A photo with published poses: ``camera`` the intrinsics (pose: identity), ``objects``."""

    name: str
    photo: Path
    camera: Camera
    objects: list


def anchored_scene(photo: RealPhoto, anchor: int) -> tuple[Scene, Camera]:
    """The photo's objects as one scene whose world is object ``anchor``'s model frame (the
    others placed by ``inv(T_anchor) @ T_obj``), and the true camera (world to camera =
    ``T_anchor``)."""
    T_a = photo.objects[anchor].pose
    inv = np.linalg.inv(T_a)
    parts: list[Part] = [
        make_part(obj.name, obj.source, obj.vertices, obj.faces, inv @ obj.pose) for obj in photo.objects
    ]
    scene = Scene(name=f"{photo.name}-{photo.objects[anchor].name}", source=photo.photo, parts=parts)
    return scene, photo.camera.with_pose(T_a[:3, :3], T_a[:3, 3])


LMO_NAMES = {1: "ape", 5: "can", 6: "cat", 8: "driller", 9: "duck", 10: "eggbox", 11: "glue", 12: "holepuncher"}


def lmo_photo(root: Path, image: int, meshes: dict | None = None) -> RealPhoto:
    """LM-O photo ``image`` (test/000002) with every annotated object; ``meshes`` caches
    obj_id -> (vertices m, faces) between photos."""
    folder = Path(root) / "lmo" / "test" / "000002"
    gt = json.loads((folder / "scene_gt.json").read_text())[str(image)]
    cam = json.loads((folder / "scene_camera.json").read_text())[str(image)]
    K = np.array(cam["cam_K"], np.float64).reshape(3, 3)
    meshes = {} if meshes is None else meshes
    objects = []
    for entry in gt:
        oid = int(entry["obj_id"])
        path = Path(root) / "lmo" / "models" / f"obj_{oid:06d}.ply"
        if oid not in meshes:
            vertices, faces = read_mesh(path)
            meshes[oid] = (np.asarray(vertices, np.float64) / 1000.0, np.asarray(faces))
        R = nearest_rotation(entry["cam_R_m2c"])
        t = np.array(entry["cam_t_m2c"], np.float64) / 1000.0
        vertices, faces = meshes[oid]
        objects.append(RealObject(LMO_NAMES.get(oid, f"obj{oid}"), path, vertices, faces, pose_matrix(R, t)))
    rgb = folder / "rgb" / f"{image:06d}.png"
    return RealPhoto(f"lmo-{image:06d}", rgb, Camera(640, 480, K), objects)


# Mesh-to-camera poses of frame 200 (m3t/README.md, "Poses": inv(world2body) @ geometry2body).
_M3T_R = np.array([[0.607674, 0.786584, -0.109620], [0.408914, -0.428214, -0.805868], [-0.680823, 0.444881, -0.581860]])
M3T_POSES = {"triangle": (-0.081218, -0.000632, 0.621793), "schauma": (0.006327, 0.081186, 0.491812)}
M3T_K = ((698.128, 0.0, 478.459), (0.0, 698.617, 274.426), (0.0, 0.0, 1.0))


def m3t_photo(root: Path, frame: int = 200) -> RealPhoto:
    """M3T's colour frame ``frame`` with both bodies at the published pose of frame 200."""
    folder = Path(root) / "m3t" / "data"
    objects = []
    for name, t in M3T_POSES.items():
        path = folder / "_body" / f"{name}.obj"
        vertices, faces = read_mesh(path)
        pose = pose_matrix(nearest_rotation(_M3T_R), np.array(t))
        objects.append(RealObject(name, path, np.asarray(vertices, np.float64), np.asarray(faces), pose))
    photo = folder / "_sequence" / f"color_camera_image_{frame}.png"
    return RealPhoto(f"m3t-{frame}", photo, Camera(960, 540, np.array(M3T_K)), objects)


def camera_scene(photo: RealPhoto) -> tuple[Scene, Camera]:
    """The photo's objects in the camera frame (world = camera; true camera R = I, t = 0)."""
    parts = [make_part(obj.name, obj.source, obj.vertices, obj.faces, obj.pose) for obj in photo.objects]
    return Scene(name=photo.name, source=photo.photo, parts=parts), photo.camera


def cao_points(path: Path) -> np.ndarray:
    """The ``# 3D Points`` block of a ViSP ``.cao`` file: (n, 3) metres."""
    lines = [line.split("#")[0].split() for line in Path(path).read_text().splitlines()]
    lines = [line for line in lines if line]
    count = int(lines[1][0])  # lines[0] is the format's "V1"
    return np.array([[float(v) for v in line[:3]] for line in lines[2 : 2 + count]])


def cuboid_faces() -> np.ndarray:
    """(12, 3) outward triangles of the 8 corners ordered ``(x, y, z)`` in {lo, hi}^3, x slowest."""
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))], np.int64)


def cuboid_corners(points: np.ndarray) -> np.ndarray:
    """The 8 corners of the bounding box of ``points``, x slowest (see :func:`cuboid_faces`)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


__all__ = [
    "RealObject",
    "RealPhoto",
    "real_root",
    "nearest_rotation",
    "anchored_scene",
    "camera_scene",
    "lmo_photo",
    "m3t_photo",
    "cao_points",
    "cuboid_faces",
    "cuboid_corners",
    "M3T_POSES",
]
