"""Which planned part instance every photo pixel sees, and what lies behind it (ray casts).

For every photo pixel the undistorted (ideal) pixel comes from
:func:`mrcheck.mr.overlay.distortion_map`; one ray per pixel is cast through it with
:class:`mrcheck.scene.raycast.SceneCaster` (the triangle soup of every part at every instance,
relative to the camera centre for float32 precision). The hit's instance index
(:func:`mrcheck.scene.raycast.instance_labels`) gives the part instance, its ``t`` the camera-space
depth (the ray's z is 1). No renderer change is needed and the ids are exactly in the photo's
(distorted) frame.
"""

from __future__ import annotations

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.lens import distortion_map
from mrcheck.scene.model import Scene
from mrcheck.scene.raycast import NO_HIT, build_caster, instance_labels

BACKGROUND = NO_HIT  # the id of a pixel that sees no part
BEHIND_PASSES = 10  # ray casts per pixel at most to get behind its first instance


def undistorted_pixels(camera: Camera, maps=None) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) float64 (H, W): the undistorted pixel each photo pixel looks through (``maps``:
    :func:`mrcheck.mr.overlay.distortion_map` of the camera, when the caller has it)."""
    if maps is None:
        maps = distortion_map(camera)
    if maps is None:
        v, u = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
        return u, v
    return maps[0].astype(np.float64), maps[1].astype(np.float64)


def world_points(camera: Camera, depth: np.ndarray, maps=None) -> np.ndarray:
    """(H, W, 3) float64 world point of each photo pixel's planned surface at camera ``depth``
    (through its undistorted pixel; meaningless where ``depth`` is 0, nothing seen)."""
    u, v = undistorted_pixels(camera, maps)
    cam = np.stack(((u - camera.cx) / camera.fx * depth, (v - camera.cy) / camera.fy * depth, depth), -1)
    return (cam - camera.t.reshape(1, 1, 3)) @ camera.R  # world = R^T (p - t)


def object_ids(scene: Scene, camera: Camera, maps=None, caster=None):
    """Per photo pixel the index of the visible instance (-1 = nothing) and its depth.

    Returns ``(ids (H, W) int32, depth (H, W) float32 (0 = nothing), labels)``; ``labels[i]``
    is ``(part name, instance id)``. Rays go through the *undistorted* pixel of each photo
    pixel, so the buffer is in the photo's lens geometry. ``caster``: the
    :class:`~mrcheck.scene.raycast.SceneCaster` of ``scene`` around ``camera.center``, when the
    caller has built it already.
    """
    h, w = camera.height, camera.width
    u, v = undistorted_pixels(camera, maps)
    valid = u > -1e5
    labels = instance_labels(scene)
    ids = np.full((h, w), BACKGROUND, np.int32)
    depth = np.zeros((h, w), np.float32)
    if caster is None:
        caster = build_caster(scene, camera.center)
    if caster is None:  # an empty scene
        return ids, depth, labels
    d_cam = np.stack(((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, np.ones_like(u)), -1)[valid]
    rays = np.zeros((len(d_cam), 6), np.float32)
    rays[:, 3:] = d_cam @ camera.R  # world orientation, origin at the camera centre
    hits = caster.cast(rays)
    ids[valid] = hits.instance.astype(np.int32)
    depth[valid] = np.where(hits.hit, hits.t, 0.0).astype(np.float32)
    return ids, depth, labels


def behind_ids(
    scene: Scene,
    camera: Camera,
    ids: np.ndarray,
    depth: np.ndarray,
    maps=None,
    passes: int = BEHIND_PASSES,
    caster=None,
):
    """What the planned scene shows at each pixel *without* the pixel's own instance: ``(ids,
    depth)`` of the nearest hit of another instance behind it (-1 / 0 = nothing, or not found in
    ``passes`` casts). Each pass re-casts the rays still inside their first instance from just
    behind their last hit, so one extra pass or two serve every instance of the view at once.
    ``caster`` as in :func:`object_ids`."""
    h, w = camera.height, camera.width
    u, v = undistorted_pixels(camera, maps)
    out_ids = np.full((h, w), BACKGROUND, np.int32)
    out_depth = np.zeros((h, w), np.float32)
    if caster is None:
        caster = build_caster(scene, camera.center)
    yy, xx = np.nonzero(ids >= 0)
    if caster is None or len(yy) == 0:
        return out_ids, out_depth
    dirs = (
        np.stack(((u[yy, xx] - camera.cx) / camera.fx, (v[yy, xx] - camera.cy) / camera.fy, np.ones(len(yy))), -1)
        @ camera.R
    )
    first = ids[yy, xx]
    t = depth[yy, xx].astype(np.float64)
    found_id = np.full(len(yy), BACKGROUND, np.int32)
    found_t = np.zeros(len(yy), np.float32)
    active = np.arange(len(yy))
    for _ in range(passes):
        if len(active) == 0:
            break
        step = 1e-3 + 1e-4 * t[active]  # just behind the last hit (t is depth: the ray's z is 1)
        rays = np.concatenate((dirs[active] * (t[active] + step)[:, None], dirs[active]), 1).astype(np.float32)
        hits = caster.cast(rays)
        t_new = t[active] + step + np.where(hits.hit, hits.t.astype(np.float64), 0.0)
        done = ~hits.hit | (hits.instance != first[active])
        found_id[active[done]] = hits.instance[done]
        found_t[active[done]] = np.where(hits.hit[done], t_new[done], 0.0)
        t[active] = t_new
        active = active[~done]
    out_ids[yy, xx] = found_id
    out_depth[yy, xx] = found_t
    return out_ids, out_depth


__all__ = ["object_ids", "behind_ids", "undistorted_pixels", "world_points", "BACKGROUND", "BEHIND_PASSES"]
