"""Mesh files: one CAD export or a posed URDF robot read into float64 vertices and faces, validated.

Formats: glTF (``.glb``, ``.gltf``), OBJ, STL, PLY, OFF through trimesh; URDF through yourdfpy,
posed by the manifest's ``joints`` (held to the URDF's limits). NaN/infinite coordinates and
meshes with no proper triangle are errors; degenerate (zero-area) triangles among good ones are
dropped, with a warning when they are more than a few.
"""

from __future__ import annotations

import io
import logging
import math
import os
import tempfile
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from mrcheck.core.errors import MrcheckError, warn
from mrcheck.core.inputs import check_input

MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".stl", ".ply", ".off", ".urdf")
DEGENERATE_WARNING_SHARE = 0.001  # warn when more than 0.1 % of a mesh's triangles have zero area
VALIDATION_CHUNK = 1 << 20  # triangles checked per step (bounds the validation's memory)


def read_mesh(path: Path, joints: dict | None = None, package_folders=()):
    """(vertices (n, 3) float64, faces (m, 3) int64) of a mesh file or a posed URDF, validated.

    NaN/infinite coordinates and meshes with no proper triangle are errors; degenerate
    (zero-area) triangles among good ones are dropped with a warning, as CAD exports often
    carry a few. ``package_folders``: where a URDF's ``package://`` meshes are looked up besides
    the defaults (:mod:`mrcheck.scene.packages`).
    """
    path = Path(path)
    if (
        check_input(path, "mesh file").st_size == 0
    ):  # the readers' own errors for this are cryptic (index out of bounds)
        raise MrcheckError("mesh file is empty", path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise MrcheckError(f"unsupported mesh format {suffix or '(none)'} (use {', '.join(MESH_SUFFIXES)})", path)
    if joints and suffix != ".urdf":
        raise MrcheckError("joints are only meaningful for a URDF part", path)
    try:
        if suffix == ".urdf":
            vertices, faces = _read_urdf(path, joints or {}, package_folders)
        else:
            import trimesh

            # process=False: no vertex merging; a 10 M-triangle export loads in seconds, not minutes.
            # An open file, not the name: trimesh names the mesh's scene node after the file and
            # hashes that name as UTF-8, which one that is not valid UTF-8 has not; the resolver
            # finds an OBJ's materials and a glTF's buffers beside it, as trimesh.load(path) does
            # force="mesh": a Trimesh (trimesh types it as any Geometry); anything else
            # has no faces, an error like any other below
            mesh: Any
            with open(path, "rb") as handle:
                mesh = trimesh.load(
                    handle,
                    file_type=suffix[1:],
                    force="mesh",
                    process=False,
                    resolver=trimesh.resolvers.FilePathResolver(str(path)),
                )
            vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    except MrcheckError:
        raise
    except Exception as exc:  # trimesh and yourdfpy raise many types for corrupt files
        reason = " ".join(str(exc).split())[:200]
        # a KeyError's text is only the key ('y' for a PLY cut in its vertex list): name the type too
        reason = (
            f"{type(exc).__name__}: {reason}"
            if reason and isinstance(exc, (KeyError, IndexError))
            else reason or type(exc).__name__
        )
        what = "cannot read mesh" if isinstance(exc, OSError) else "cannot read mesh: corrupt, truncated or not a mesh"
        raise MrcheckError(f"{what} ({reason})", path) from None
    return validate_mesh(vertices, faces, path)


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.messages = []

    def emit(self, record):
        self.messages.append(" ".join(record.getMessage().split()))


def _utf8(name: str) -> bool:
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:  # a file name that is not valid UTF-8 (surrogate escapes)
        return False
    return True


def _ascii_aliases(folder: str, handler):
    """``handler`` (URDF mesh reference -> path) giving, for a path that is not valid UTF-8, a
    symlink to it in ``folder`` instead: lxml, which parses the URDF, and trimesh, which loads
    its meshes, take file names as UTF-8 only."""

    def aliased(fname: str) -> str:
        found = handler(fname)
        if _utf8(found) or not os.path.isfile(found):
            return found
        alias = os.path.join(folder, f"mesh{len(os.listdir(folder))}{os.path.splitext(found)[1]}")
        os.symlink(os.path.abspath(found), alias)
        return alias

    return aliased


def _read_urdf(path: Path, joints: dict, package_folders=()):
    import yourdfpy

    from mrcheck.scene import packages

    # yourdfpy logs what goes wrong (malformed XML, a mesh file it cannot find) and carries on;
    # its messages are kept for the one-line error instead of being printed around it
    handler = packages.handler(path, partial(yourdfpy.filename_handler_magic, dir=str(path.parent)), package_folders)
    logger, collect = logging.getLogger("yourdfpy"), _Collect()
    logger.addHandler(collect)
    propagate, logger.propagate = logger.propagate, False
    try:
        with tempfile.TemporaryDirectory(prefix="mrcheck-urdf-") as aliases:
            # the URDF's bytes when its name is not UTF-8 (lxml encodes a file object's name too)
            robot = yourdfpy.URDF.load(
                str(path) if _utf8(str(path)) else io.BytesIO(path.read_bytes()),
                filename_handler=_ascii_aliases(aliases, handler),
                build_collision_scene_graph=False,
                load_collision_meshes=False,
            )
    except Exception as exc:
        reason = "; ".join(collect.messages[:1] + [" ".join(str(exc).split()) or type(exc).__name__])
        raise MrcheckError(f"cannot read URDF ({reason[:200]})", path) from None
    finally:
        logger.removeHandler(collect)
        logger.propagate = propagate
    missing = [m[len("Can't find ") :] for m in collect.messages if m.startswith("Can't find ")]
    if missing:
        names = sorted({m[len(packages.PREFIX) :].split("/")[0] for m in missing if m.startswith(packages.PREFIX)})
        hint = f" ({packages.hint(', '.join(names))})" if names else ""
        raise MrcheckError(f"URDF mesh file(s) not found: {', '.join(missing)}{hint}", path)
    unknown = sorted(set(joints) - set(robot.actuated_joint_names))
    if unknown:
        raise JointError(
            f"unknown joint(s) {', '.join(unknown)} (the robot {path.name} has: "
            f"{', '.join(robot.actuated_joint_names)})"
        )
    for name, value in joints.items():
        _check_joint_limits(robot.joint_map[name], float(value), path)
    cfg = [float(joints.get(name, 0.0)) for name in robot.actuated_joint_names]
    robot.update_cfg(np.array(cfg))
    mesh = robot.scene.to_mesh() if hasattr(robot.scene, "to_mesh") else robot.scene.dump(concatenate=True)
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


class JointError(MrcheckError):
    """A joint value of a manifest that the robot does not accept: the manifest's entry is
    wrong, not the URDF, so the manifest reader names itself and the part."""


JOINT_LIMIT_SLACK = 1e-6  # rad or m: values written with fewer digits than the URDF's limits


def urdf_joint_range(joint) -> tuple[float, float] | None:
    """(lower, upper) of a URDF joint's limit, None for a continuous joint or one without a
    limit (robots.joint_limits samples those over a full turn; a manifest value is not held to one)."""
    limit = joint.limit
    if joint.type == "continuous" or limit is None or limit.lower is None or limit.upper is None:
        return None
    return float(limit.lower), float(limit.upper)


def _check_joint_limits(joint, value: float, path: Path):
    """An error for a value beyond the URDF's limits. An error rather than a warning: the robot
    cannot take that pose, so the scene would show a robot that is not there, and as-built
    checks would measure against it; the common cause is a value typed in degrees."""
    limits = urdf_joint_range(joint)
    if limits is None or not limits[0] < limits[1]:  # no (or a degenerate) range given: nothing to hold it to
        return
    lower, upper = limits
    if lower - JOINT_LIMIT_SLACK <= value <= upper + JOINT_LIMIT_SLACK:
        return
    unit = "m" if joint.type == "prismatic" else "rad"
    hint = ""
    if joint.type == "revolute" and lower <= math.radians(value) <= upper:
        hint = f"; degrees? joint values are radians ({value:g} deg = {math.radians(value):.4g} rad)"
    raise JointError(
        f"joint {joint.name!r} = {value:g} is outside its limits {lower:.4g} .. {upper:.4g} {unit} in {path.name}{hint}"
    )


def validate_mesh(vertices, faces, path):
    vertices = np.asarray(vertices, np.float64).reshape(-1, 3)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    if len(faces) == 0 or len(vertices) == 0:
        raise MrcheckError("mesh has no triangles", path)
    if not np.all(np.isfinite(vertices)):
        bad = int((~np.isfinite(vertices)).any(axis=1).sum())
        raise MrcheckError(f"mesh has {bad} vertices with NaN or infinite coordinates", path)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise MrcheckError("mesh has triangles that index missing vertices", path)
    good = np.empty(len(faces), bool)
    for start in range(0, len(faces), VALIDATION_CHUNK):  # chunks: no float64 copy of all triangles
        good[start : start + VALIDATION_CHUNK] = _proper(vertices[faces[start : start + VALIDATION_CHUNK]])
    if not good.any():
        raise MrcheckError(f"mesh has only degenerate (zero-area) triangles ({len(faces)} of them)", path)
    if not good.all():
        # a handful is normal in CAD and scan meshes (the KUKA model has one); more says the
        # export or its unit is broken, which the user should hear about
        if (~good).mean() > DEGENERATE_WARNING_SHARE:
            warn(f"dropped {int((~good).sum())} degenerate triangles of {len(faces)}", path)
        faces = faces[good]
    return vertices, faces


DEGENERATE_RATIO = 1e-9  # see _proper


def _proper(tri: np.ndarray) -> np.ndarray:
    """(m,) bool: the triangles (m, 3, 3) float64 that have an area, judged by their own size.

    Twice the area is the longest edge L times the height h on it; a triangle with
    ``2 * area <= (DEGENERATE_RATIO * L) ** 2`` (h at most 1e-18 L: below float64's resolution
    of its own edges) has none. Measured against the triangle's own edge, not the mesh's
    extent: a mesh that also holds an element 1e12 m away made every metre-sized triangle of it
    zero-area under (extent * 1e-9) ** 2 = 4e6 m^2, and dropped them.
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, bc, ca = b - a, c - b, a - c
    cross = np.cross(ab, -ca)
    # squared throughout: no square roots over millions of triangles
    doubled_area_sq = np.einsum("ij,ij->i", cross, cross)
    longest_sq = np.maximum(
        np.maximum(np.einsum("ij,ij->i", ab, ab), np.einsum("ij,ij->i", bc, bc)), np.einsum("ij,ij->i", ca, ca)
    )
    return doubled_area_sq > DEGENERATE_RATIO**4 * longest_sq**2


__all__ = ["read_mesh", "validate_mesh", "urdf_joint_range", "JointError", "MESH_SUFFIXES", "DEGENERATE_RATIO"]
