"""Ray-traced reference AO: the ground truth the screen-space methods are judged against.

For every non-background pixel of a render, the visible surface point ``P`` (the G-buffer depth
unprojected through K) and its normal ``n`` are taken to world orientation, and ``N`` cosine-
weighted hemisphere rays are cast against the FULL scene geometry (every part, every instance)
with Open3D's Embree ray caster::

    AO = clamp(1 - (1/N) * sum_i hit_i / (1 + c * (d_i / r)^2), 0, 1)

* ``hit_i`` = 1 when ray ``i`` meets any triangle within the maximum distance ``r`` (hits
  beyond ``r`` do not count), ``d_i`` its distance to the first hit;
* the directions are cosine-distributed about ``n``, so the cosine weight of the definition is
  in the sampling: ``(1/pi) * integral(V(w) cos(w, n) dw) = E_cos[V]``. This is what the vector
  method (D2) estimates at intensity 1; its factor 2 is there because its offsets are uniform
  over the hemisphere (``(1/pi) * integral(V cos) = 2 E_uniform[V cos]``);
* ``r`` is the world radius (``radius_mode="world"``, as ssao's ``R``) or, per pixel, the
  vector method's ``r_S = radius_px * Z / f_y`` (``radius_mode="screen"``);
* background pixels are 1.0.

A point at the foot of an infinitely tall wall (a 90-degree crease) gets 0.5 for every ``c``:
half the cosine-weighted hemisphere sees the wall at distance 0.

The render the pixels come from must be drawn at full detail (:data:`REFERENCE_LOD_PX`): a
coarser level of detail (:mod:`mrcheck.render.lod`) moves the surface by up to its on-screen error,
which puts ray origins inside the full-detail parts and counts them as occluded.

Precision: Open3D casts in float32, and factory scenes may sit 1e6 m from the origin. The
triangle soup is therefore built in float64 and cast to float32 only RELATIVE TO THE CAMERA
CENTRE (world orientation), and the pixel points are formed there directly: with
``X_cam = R X_world + t`` and ``C = -R^T t``, ``X_world - C = R^T X_cam`` needs no large numbers.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.scene.model import Scene
from mrcheck.scene.raycast import build_caster

# Level-of-detail error of the render whose G-buffer the rays start from: none. Measured with the
# sample cell's robot view at 320x240: vector's RMSE against the reference was 0.134 from a render
# at the default 0.5 px and 0.073 at full detail (the rays saw the full-detail robot from inside).
REFERENCE_LOD_PX = 0.0

# 4096 rays per pixel take about 3 minutes at 640x480 here (6-8 M rays/s), while 256 and 1024
# rays already agree within 0.01 (tests/test_reference.py): more is a typo, not a better reference
MAX_RAYS = 4096
RAY_CHUNK = 1 << 21  # rays per cast: ~50 MB of float32 rays, enough to keep every core busy
ORIGIN_EPSILON = 2e-5  # ray origin offset along the normal, relative to the depth Z
GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)
RADIUS_MODES = ("world", "screen")
PROGRESS_STAGE = "reference AO"  # the stage reference_ao reports its rays under


def _base_pattern(rays: int) -> np.ndarray:
    """(N, 2) float64 points of a rank-1 (Fibonacci) lattice in the unit square: stratified in
    both coordinates for any N, so the estimate converges much faster than independent rays."""
    k = np.arange(rays, dtype=np.float64)
    return np.column_stack(((k + 0.5) / rays, np.mod(k * GOLDEN, 1.0)))


def _tangent_frames(n: np.ndarray):
    """Orthonormal tangents (T, B) of unit normals (m, 3), branch-free (Duff et al. 2017): no
    degenerate "up" vector to pick, so every normal direction gets a valid frame."""
    sign = np.where(n[:, 2] >= 0.0, 1.0, -1.0).astype(n.dtype)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    T = np.column_stack((1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]))
    B = np.column_stack((b, sign + n[:, 1] ** 2 * a, -n[:, 1]))
    return T, B


def _check_rays(rays) -> None:
    if isinstance(rays, bool) or int(rays) != rays or not 1 <= rays <= MAX_RAYS:
        raise MrcheckError(f"rays must be a whole number in [1, {MAX_RAYS}], got {rays!r}")


def _check_radius_mode(radius_mode) -> None:
    if radius_mode not in RADIUS_MODES:
        raise MrcheckError(f"radius mode must be one of {', '.join(RADIUS_MODES)}, got {radius_mode!r}")


def _check_parameters(rays, radius_mode, radius, falloff) -> None:
    _check_rays(rays)
    _check_radius_mode(radius_mode)
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius > 0):
        raise MrcheckError(f"radius must be positive, got {radius!r}")
    # c < 0 would divide by zero at d/r = 1/sqrt(-c); the render modes reject it too
    if not (isinstance(falloff, (int, float)) and math.isfinite(falloff) and falloff >= 0):
        raise MrcheckError(f"falloff must be >= 0, got {falloff!r}")


def _validate(camera, depth, normals, rays, radius_mode, radius, falloff):
    H, W = camera.height, camera.width
    if depth.shape != (H, W):
        raise MrcheckError(f"depth has shape {depth.shape}, the camera wants {(H, W)}")
    if normals.shape != (H, W, 3):
        raise MrcheckError(f"normals have shape {normals.shape}, the camera wants {(H, W, 3)}")
    _check_parameters(rays, radius_mode, radius, falloff)


@dataclass(frozen=True)
class _Surface:
    """The covered pixels' ray starts, relative to the camera centre in world orientation."""

    origins: np.ndarray  # (m, 3) float32, lifted off the surface along the normal
    frames: np.ndarray  # (m, 3 axes, 3) float32 tangent, bitangent, normal
    radius: np.ndarray  # (m,) float64 maximum ray distance r per pixel


def _surface(camera: Camera, depth, normals, jj, ii, radius_mode: str, radius: float) -> _Surface:
    """Surface points and normals of pixels (jj, ii) relative to the camera centre in world
    orientation (R^T X_cam: no large numbers), in float64 until the float32 ray origins."""
    z = depth[jj, ii].astype(np.float64)
    p_cam = np.column_stack(((ii - camera.cx) * z / camera.fx, (jj - camera.cy) * z / camera.fy, z))
    n_cam = normals[jj, ii].astype(np.float64)
    n_len = np.linalg.norm(n_cam, axis=1, keepdims=True)
    # a zero normal on a covered pixel (degenerate triangle): face the camera rather than NaN
    n_cam = np.where(
        n_len > 1e-6, n_cam / np.maximum(n_len, 1e-12), -p_cam / np.linalg.norm(p_cam, axis=1, keepdims=True)
    )
    R = camera.R
    p_rel = p_cam @ R  # = (R^T p_cam^T)^T
    n_world = n_cam @ R
    r = np.full(z.shape, float(radius)) if radius_mode == "world" else float(radius) * z / camera.fy
    # the G-buffer point lies on its triangle only to float32/raster precision: lift it off the
    # surface by a small amount relative to its depth so that no ray hits its own triangle
    origins = (p_rel + n_world * (ORIGIN_EPSILON * z)[:, None]).astype(np.float32)
    T, B = _tangent_frames(n_world)
    return _Surface(origins, np.stack((T, B, n_world), axis=1).astype(np.float32), r)


def _chunk_rays(surface: _Surface, sl: slice, base: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """(m N, 6) float32 rays of the pixels ``sl``: the lattice ``base`` shifted per pixel,
    cosine-distributed about the normal, each direction scaled by the pixel's r."""
    m, rays = sl.stop - sl.start, len(base)
    u = np.mod(base[None, :, :] + shifts[sl, None, :], 1.0).astype(np.float32)  # (m, N, 2)
    # cosine-weighted hemisphere (Malley): uniform disc lifted to the hemisphere
    rad = np.sqrt(u[..., 0])
    phi = np.float32(2.0 * math.pi) * u[..., 1]
    local = np.stack((rad * np.cos(phi), rad * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u[..., 0]))), -1)
    # directions scaled by r: t is then d / r, and tfar = 1 is the maximum distance for
    # every pixel at once (the screen radius differs per pixel)
    dirs = np.einsum("mna,mak->mnk", local, surface.frames[sl]) * surface.radius[sl, None, None].astype(np.float32)
    ray_array = np.empty((m, rays, 6), np.float32)
    ray_array[..., :3] = surface.origins[sl, None, :]
    ray_array[..., 3:] = dirs
    return ray_array.reshape(-1, 6)


def _occlusion(caster, ray_array: np.ndarray, falloff: float) -> np.ndarray:
    """(n,) float64 weight of every ray: 0 without a hit within r, else 1 / (1 + c (d/r)^2)."""
    # the occlusion query (bool, any hit in [0, 1]) is cheaper than a closest-hit cast
    hit = caster.occluded(ray_array, tfar=1.0)
    if falloff == 0.0:
        return hit.astype(np.float64)
    weight = np.zeros(hit.shape, np.float64)
    idx = np.nonzero(hit)[0]
    if idx.size:
        # the distance is needed only for the rays that hit within r
        t_hit = caster.cast(ray_array[idx]).t.astype(np.float64)
        t_hit = np.minimum(t_hit, 1.0)  # the same first hit; guards float ties at t = 1
        weight[idx] = 1.0 / (1.0 + falloff * t_hit * t_hit)
    return weight


def reference_ao(
    scene: Scene,
    camera: Camera,
    depth,
    normals,
    rays: int,
    radius_mode: str,
    radius: float,
    falloff: float = 1.0,
    seed: int = 0,
    progress=None,
) -> np.ndarray:
    """(H, W) float32 ray-traced AO for the pixels of a render (definition: module docstring).

    Parameters
    ----------
    scene : the scene that was rendered (all parts and instances are occluders).
    camera : the camera of the render.
    depth : (H, W) camera-space z of the G-buffer, 0 = background (``Frame.depth`` of a render
        at ``lod_px=REFERENCE_LOD_PX``).
    normals : (H, W, 3) camera-space normals, OpenCV axes (``Frame.normals``, ``want_normals=True``).
    rays : N, cosine-weighted rays per pixel.
    radius_mode : "world": ``r = radius`` in scene units; "screen": ``radius`` is in pixels and
        ``r = radius * Z / f_y`` per pixel.
    radius : see ``radius_mode``. Also the maximum ray distance.
    falloff : c of the attenuation ``1 / (1 + c (d/r)^2)``; 0 counts every hit within r fully.
    seed : seed of the per-pixel shifts of the ray pattern (the same seed, the same result).
    progress : None, or ``progress(stage, done, total)`` called with :data:`PROGRESS_STAGE` and
        the rays cast so far.
    """
    depth = np.asarray(depth, np.float32)
    normals = np.asarray(normals, np.float32)
    _validate(camera, depth, normals, rays, radius_mode, radius, falloff)
    rays = int(rays)
    ao = np.ones(depth.shape, np.float32)
    jj, ii = np.nonzero(np.isfinite(depth) & (depth > 0.0))  # row (v), column (u) of every surface pixel
    caster = build_caster(scene, camera.center) if jj.size else None
    if caster is None:  # nothing covered, or no triangles: nothing occludes
        return ao
    surface = _surface(camera, depth, normals, jj, ii, radius_mode, radius)
    base = _base_pattern(rays)
    # Cranley-Patterson rotation: one random shift of the lattice per pixel, so neighbouring
    # pixels use different directions (no structured artefacts) and each stays stratified
    shifts = np.random.default_rng(seed).random((jj.size, 2))
    occlusion = np.zeros(jj.size, np.float64)
    per_chunk = max(1, RAY_CHUNK // rays)
    if progress is not None:
        progress(PROGRESS_STAGE, 0, jj.size * rays)
    for start in range(0, jj.size, per_chunk):
        sl = slice(start, min(start + per_chunk, jj.size))
        weight = _occlusion(caster, _chunk_rays(surface, sl, base, shifts), falloff)
        occlusion[sl] = weight.reshape(-1, rays).sum(axis=1)
        if progress is not None:
            progress(PROGRESS_STAGE, sl.stop * rays, jj.size * rays)
    ao[jj, ii] = np.clip(1.0 - occlusion / rays, 0.0, 1.0).astype(np.float32)
    return ao


# -- the command ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceRun:
    """What ``mrcheck reference`` did: the file written and the rays it cast in how long."""

    path: Path
    rays_cast: int
    seconds: float

    def timing_line(self) -> str:
        rate = f", {self.rays_cast / self.seconds / 1e6:.2f} M rays/s" if self.seconds > 0 and self.rays_cast else ""
        return f"reference AO: {self.rays_cast} rays in {self.seconds:.2f} s{rate}"


def _command_radius(radius_mode, radius_world, radius_px, camera) -> float:
    """The radius the command uses, its mode's default when not given; warns about the other
    mode's option (as render warns about an option its mode does not read)."""
    from mrcheck.render.renderer import (
        DEFAULT_RADIUS_FRACTION,
        DEFAULT_RADIUS_WORLD,
        check_screen_radius,
    )

    if radius_mode == "world":
        return DEFAULT_RADIUS_WORLD if radius_world is None else radius_world
    radius = DEFAULT_RADIUS_FRACTION * camera.height if radius_px is None else radius_px
    check_screen_radius(radius, camera.height, "the screen radius is in pixels")  # render's rule
    return radius


def _warn_ignored_radius(radius_mode, radius_world, radius_px) -> None:
    # one radius is used, the other dropped: the user meant one or the other
    ignored = {"world": ("--radius-px", radius_px, "screen"), "screen": ("--radius", radius_world, "world")}
    option, value, users = ignored[radius_mode]
    if value is not None:
        warnings.warn(MrcheckWarning(f"{option} has no effect in radius mode {radius_mode} (it applies to {users})"))


def reference_command(
    scene,
    view,
    camera_path,
    width,
    height,
    rays,
    radius_mode,
    radius_world,
    radius_px,
    falloff,
    seed,
    units,
    output,
    progress=None,
) -> ReferenceRun:
    """``mrcheck reference``: check everything, render the G-buffer, ray-trace the reference
    AO, write it; returns what was written. ``progress`` as in :func:`reference_ao`."""
    from mrcheck.core.output import (
        AO_SUFFIXES,
        check_not_inputs,
        check_output_path,
        write_ao,
    )
    from mrcheck.render.renderer import Renderer, RenderSettings
    from mrcheck.render.views import scene_and_camera, warn_if_nothing_in_view
    from mrcheck.scene.manifest import scene_files

    output = check_output_path(output, AO_SUFFIXES, "reference output")  # fail before the work
    check_not_inputs([output], [("the scene", scene_files(scene)), ("--camera", camera_path)])
    _check_radius_mode(radius_mode)
    _check_rays(rays)  # before a long scene load (_check_parameters below checks everything)
    _warn_ignored_radius(radius_mode, radius_world, radius_px)
    loaded, camera = scene_and_camera(scene, units, view, camera_path, width, height)
    radius = _command_radius(radius_mode, radius_world, radius_px, camera)
    _check_parameters(rays, radius_mode, radius, falloff)

    renderer = Renderer(loaded)
    try:
        # single-sampled: every pixel's point is on the surface its centre sees (mrcheck.eval.compare)
        frame = renderer.render(
            camera, ["phong"], RenderSettings(lod_px=REFERENCE_LOD_PX, antialias=False), want_normals=True
        )
        depth, normals = frame.depth, frame.normals
    finally:
        renderer.release()
    warn_if_nothing_in_view(depth, view, camera_path)

    start = time.perf_counter()
    ao = reference_ao(loaded, camera, depth, normals, rays, radius_mode, radius, falloff, seed, progress=progress)
    seconds = time.perf_counter() - start
    path = write_ao(Path(output), ao)
    return ReferenceRun(path, int(np.count_nonzero(depth > 0)) * int(rays), seconds)


__all__ = [
    "reference_ao",
    "reference_command",
    "ReferenceRun",
    "MAX_RAYS",
    "RADIUS_MODES",
    "REFERENCE_LOD_PX",
    "PROGRESS_STAGE",
]
