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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LOD_PIXELS = 0.5
MIN_TRIANGLES = 64           # fewer: a coarser copy saves less than its extra draw call costs
MIN_INSTANCES = 4            # fewer: the one-off build (about 1 s per 100 k triangles) does not
                             # pay off within a few renders; single robots are drawn as they are
MAX_TRIANGLES = 1_000_000    # more: building the chain takes seconds; drawn as it is
STEP = 2                     # each level about 1/STEP of the triangles of the one before
MIN_SAVING = 0.75            # stop when a step keeps more than this share of the triangles


@dataclass(frozen=True)
class Level:
    vertices: np.ndarray   # (V, 3) float32, the part's local frame
    faces: np.ndarray      # (F, 3) uint32
    error: float           # measured distance to the original surface, part units


def eligible(triangles: int) -> bool:
    return MIN_TRIANGLES <= triangles <= MAX_TRIANGLES


def build_levels(vertices: np.ndarray, faces: np.ndarray) -> list[Level]:
    """The coarser levels of a mesh, finest first (the original itself is not included)."""
    original = _mesh(vertices, faces)
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(vertices, np.float64), axis=0)))
    # Welding exact duplicates lets the decimation collapse across flat-shaded seams; the
    # G-buffer takes normals from depth derivatives, so shared vertices change no shading.
    welded = original.merge_close_vertices(diagonal * 1e-7)
    samples = np.concatenate([np.asarray(vertices, np.float32),
                              np.asarray(vertices, np.float32)[np.asarray(faces)].mean(axis=1)])
    to_original = _distance_query(vertices, faces)
    levels, previous = [], len(faces)
    while previous // STEP >= 4:
        coarse = welded.simplify_quadric_decimation(target_number_of_triangles=previous // STEP)
        coarse.remove_degenerate_triangles()
        coarse.remove_unreferenced_vertices()
        count = len(coarse.triangles)
        if count == 0 or count > previous * MIN_SAVING:
            break
        v = np.asarray(coarse.vertices, np.float32)
        f = np.asarray(coarse.triangles, np.uint32)
        error = max(float(to_original(v).max()), float(_distance_query(v, f)(samples).max()))
        levels.append(Level(v, f, error))
        welded, previous = coarse, count
    return levels


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

    return o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(vertices, np.float64)),
                                     o3d.utility.Vector3iVector(np.asarray(faces, np.int32)))


def _distance_query(vertices, faces):
    """points (N, 3) -> (N,) unsigned distance to the mesh's surface."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(vertices, np.float32)),
                        o3d.core.Tensor(np.asarray(faces, np.uint32)))
    return lambda points: scene.compute_distance(o3d.core.Tensor(np.asarray(points, np.float32))).numpy()


__all__ = ["Level", "LOD_PIXELS", "allowed_error", "build_levels", "choose", "eligible"]
