"""Levels of detail: coarser copies of a part's mesh, each with its measured geometric error.

A far instance of a finely tessellated part costs llvmpipe as many triangles as a near one,
although most of them are smaller than a pixel. The geometry pass therefore draws each instance
with the coarsest level whose error, projected at the instance's nearest depth, stays below
``lod_px`` pixels (half a pixel by default, so silhouettes move by less than the pixel grid
resolves). CAD exports also subdivide flat faces (the generated hall's cartons do): those
vertices carry no shape, the decimation removes them at zero error, and near instances profit
too.

Levels are built with Open3D's quadric decimation (Garland & Heckbert), each about half the
triangles of the one before (steps of 4 left the hall's subdivided cartons at 4x their true
triangle count: the bigger step collapses shape before the last zero-error vertices), until a
step saves less than a quarter. The error of a level is
*measured*, not assumed: the larger of the distances from the original's vertices and triangle
centroids to the level's surface and from the level's vertices to the original's surface (a
Hausdorff distance sampled at those points), in the part's own units.

Building costs about 1.7 s per 100 k triangles (a 96 k-triangle robot: 1.7 s), while
drawing an instance at a coarser level saves about 50 ns per triangle and frame, so building
pays off after a few hundred instance-frames. Which parts get levels is decided from the scene
alone, never from what was rendered before, so a render stays reproducible byte for byte: parts
of MIN_TRIANGLES to MAX_TRIANGLES triangles placed at least MIN_INSTANCES times (the hall's
cartons, pallets, rack frames, conveyors), and single parts of at least MIN_SINGLE_TRIANGLES
(the robots). The robots are the trade-off: the `line` scene's three 96 k-triangle robots cost
5 s once, on the first render on a machine, and then save 8-9 ms of every 1024x768 frame
(paired rounds, 131 -> 123 ms), which an interactive review or a batch export gets back
quickly and a single one-off render does not. Built levels are cached on disk by the mesh's content
(``$MRCHECK_CACHE_DIR``, else ``$XDG_CACHE_HOME/mrcheck`` or ``~/.cache/mrcheck``;
``lod/<hash>.npz``), so later renderers and processes (export workers, the review server) load
them in milliseconds.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mrcheck.core.progress import shown_progress
from mrcheck.render.settings import DEFAULT_LOD_PX

if TYPE_CHECKING:  # imported where used: importing Open3D takes about 3 s
    import open3d as o3d

LOD_PIXELS = DEFAULT_LOD_PX  # the default allowed error, pixels (mrcheck.render.settings)
MIN_TRIANGLES = 64  # fewer: a coarser copy saves less than its extra draw call costs
MAX_TRIANGLES = 1_000_000  # more: building the chain takes seconds; drawn as it is
STEP = 2  # each level about 1/STEP of the triangles of the one before
MIN_SAVING = 0.75  # stop when a step keeps more than this share of the triangles
CACHE_VERSION = 1  # bump when the levels a mesh gets change
MIN_INSTANCES = 4  # fewer: levels of a small part would not pay off in a one-off render
MIN_SINGLE_TRIANGLES = 50_000  # ... unless it is this big (robots): see the module's docstring


@dataclass(frozen=True)
class Level:
    vertices: np.ndarray  # (V, 3) float32, the part's local frame
    faces: np.ndarray  # (F, 3) uint32
    error: float  # measured distance to the original surface, part units


def eligible(triangles: int, instances: int) -> bool:
    return MIN_TRIANGLES <= triangles <= MAX_TRIANGLES and (
        instances >= MIN_INSTANCES or triangles >= MIN_SINGLE_TRIANGLES
    )


def cache_dir() -> Path:
    explicit = os.environ.get("MRCHECK_CACHE_DIR")
    if explicit:
        return Path(explicit)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mrcheck"


def _cache_path(vertices: np.ndarray, faces: np.ndarray) -> Path:
    key = hashlib.blake2b(vertices.tobytes(), digest_size=16)
    key.update(faces.tobytes())
    key.update(f"{STEP} {MIN_SAVING} {CACHE_VERSION}".encode())
    return cache_dir() / "lod" / f"{key.hexdigest()}.npz"


def levels_for(vertices: np.ndarray, faces: np.ndarray, name: str | None = None) -> list[Level]:
    """:func:`build_levels` through the on-disk cache (an unwritable cache only costs time);
    ``name`` (the part's) labels the progress bar of a build."""
    vertices = np.ascontiguousarray(vertices, np.float32)
    faces = np.ascontiguousarray(faces, np.uint32)
    path = _cache_path(vertices, faces)
    try:
        with np.load(path) as data:
            return [Level(data[f"v{i}"], data[f"f{i}"], float(e)) for i, e in enumerate(data["errors"])]
    except (OSError, KeyError, ValueError):
        pass  # not cached yet, or a damaged file: build (and replace it)
    levels = build_levels(vertices, faces, name)
    arrays: dict[str, Any] = {"errors": np.array([level.error for level in levels])}
    for i, level in enumerate(levels):
        arrays[f"v{i}"], arrays[f"f{i}"] = level.vertices, level.faces
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".tmp", delete=False) as tmp:
            np.savez(tmp, **arrays)
        os.replace(tmp.name, path)  # whole or not at all: concurrent renderers may race here
    except OSError:
        pass
    return levels


def build_levels(vertices: np.ndarray, faces: np.ndarray, name: str | None = None) -> list[Level]:
    """The coarser levels of a mesh, finest first (the original itself is not included);
    ``name`` labels the progress bar."""
    original = _mesh(vertices, faces)
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(vertices, np.float64), axis=0)))
    # Welding exact duplicates lets the decimation collapse across flat-shaded seams; the
    # G-buffer takes normals from depth derivatives, so shared vertices change no shading.
    welded = original.merge_close_vertices(diagonal * 1e-7)
    samples = np.concatenate(
        [np.asarray(vertices, np.float32), np.asarray(vertices, np.float32)[np.asarray(faces)].mean(axis=1)]
    )
    to_original = _distance_query(vertices, faces)
    # A robot's chain takes seconds on a first render (then the disk cache has it): a bar, or the
    # terminal is silent that long after the scene's loading bar (the CLI's bar waits half a
    # second, so the many small parts that take milliseconds show none). One step per level.
    label = f"{name}, " if name else ""
    steps = _decimated(
        welded, len(faces), lambda v, f: max(float(to_original(v).max()), float(_distance_query(v, f)(samples).max()))
    )
    show = shown_progress()
    with contextlib.closing(
        show(steps, f"building levels of detail ({label}{len(faces):,} triangles)", "level")
    ) as levels:
        return list(levels)


def _decimated(welded, triangles: int, error_of):
    """Each coarser :class:`Level` of ``welded`` (``triangles`` of them), about 1/STEP of the one
    before, until a step saves too little; ``error_of(vertices, faces)`` is a level's error."""
    previous = triangles
    while previous // STEP >= 4:
        coarse = welded.simplify_quadric_decimation(target_number_of_triangles=previous // STEP)
        coarse.remove_degenerate_triangles()
        coarse.remove_unreferenced_vertices()
        count = len(coarse.triangles)
        if count == 0 or count > previous * MIN_SAVING:
            return
        v = np.asarray(coarse.vertices, np.float32)
        f = np.asarray(coarse.triangles, np.uint32)
        yield Level(v, f, error_of(v, f))
        welded, previous = coarse, count


def choose(errors: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """Per instance, the index of the coarsest level (0 = original, error 0) whose error is at
    most ``allowed`` (both in part units)."""
    ok = errors[None, :] <= allowed[:, None]
    ok[:, 0] = True
    return ok.shape[1] - 1 - np.argmax(ok[:, ::-1], axis=1)


def allowed_error(z_near: np.ndarray, scale: np.ndarray, focal: float, lod_px: float) -> np.ndarray:
    """The error (part units) that projects to ``lod_px`` pixels at depth ``z_near``; 0 for a
    box that reaches the camera plane. ``scale``: the instance transform's largest stretch."""
    return np.where(z_near > 0, lod_px * np.maximum(z_near, 0.0) / (focal * scale), 0.0)


def _mesh(vertices, faces):
    import open3d as o3d

    return o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.asarray(vertices, np.float64)),
        o3d.utility.Vector3iVector(np.asarray(faces, np.int32)),
    )


def _distance_query(vertices, faces):
    """points (N, 3) -> (N,) unsigned distance to the mesh's surface."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(_tensor(np.asarray(vertices, np.float32)), _tensor(np.asarray(faces, np.uint32)))
    return lambda points: scene.compute_distance(_tensor(np.asarray(points, np.float32))).numpy()


def _tensor(array: np.ndarray) -> o3d.core.Tensor:
    """An Open3D tensor of ``array``, of its dtype, on the CPU."""
    import open3d as o3d

    # Open3D's stubs make dtype and device required; they default to the array's and the CPU
    return o3d.core.Tensor(array)  # type: ignore[call-overload]


__all__ = ["Level", "LOD_PIXELS", "allowed_error", "build_levels", "cache_dir", "choose", "eligible", "levels_for"]
