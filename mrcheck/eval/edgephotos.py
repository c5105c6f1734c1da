"""Test photos for the edge registration, made by another renderer than mrcheck's.

A registration tested on mrcheck's own renders would be tested on its own edges. These photos
are ray cast with Open3D (Embree) instead, and made to look like a camera's:

* sun and sky: Lambert sun light with cast shadows (a second ray per sample towards the sun:
  shadow edges the CAD knows nothing about) plus a sky term brighter on upward faces;
* albedo: the part colours' luminance (``colour``: the colours themselves, linear RGB as the
  scene gives them) with a smooth world-space variation (a few random sinusoids,
  +-``albedo_noise``) and per-sample grain;
* the lens: rays through the *distorted* pixel positions (``cv2.undistortPoints`` of every
  sample position), so the photo carries the camera's distortion exactly;
* the sensor: 2x2 supersampling (optical integration), Gaussian blur, Gaussian noise, 8 bits;
* the hall differs from the CAD: ``clutter`` boxes the CAD lacks stand on visible floor spots,
  and one visible CAD part (an instance covering 1-12 % of the view) is left out (both can be
  turned off: the discrepancy evaluation photographs an as-built scene as it is).

:func:`make_case` adds a rough pose ``offset_px`` off (median over the scene points) and the
scene points the error is measured on (:func:`reprojection_error`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.eval.realdata import cuboid_faces
from mrcheck.scene.model import Scene

_SUPERSAMPLE = 2
_LEFT_OUT_SHARE = (0.01, 0.12)


@dataclass
class PhotoCase:
    """One test photo: ``photo`` (H, W) uint8 grey; ``truth`` the camera it was taken with (lens
    distortion included); ``rough`` the start pose; ``points`` (n, 3) world points on the CAD
    surfaces in view; ``left_out`` the instance id missing in the photo (or None);
    ``clutter`` boxes added (count); ``offset_px`` the rough pose's median error on ``points``."""

    photo: np.ndarray
    truth: Camera
    rough: Camera
    points: np.ndarray
    left_out: str | None
    clutter: int
    offset_px: float


def _soup(scene: Scene, origin: np.ndarray, skip=None, colour: bool = False):
    """(V, 3) float32 vertices relative to ``origin``, (F, 3) faces, (F,) instance index,
    albedo (F,) luminance or, with ``colour``, (F, 3) linear RGB, instance ids; ``skip``: an
    instance id left out."""
    verts, faces, owner, albedo, names, base = [], [], [], [], [], 0
    for part in scene.parts:
        value = np.asarray(part.color, np.float32) if colour else float(np.dot(part.color, (0.2126, 0.7152, 0.0722)))
        for T, name in zip(part.transforms, part.instance_ids):
            names.append(name)
            if name == skip or len(part.faces) == 0:
                continue
            verts.append((part.vertices.astype(np.float64) @ T[:3, :3].T + (T[:3, 3] - origin)).astype(np.float32))
            faces.append(part.faces.astype(np.int64) + base)
            owner.append(np.full(len(part.faces), len(names) - 1))
            albedo.append(np.full((len(part.faces), *np.shape(value)), value, np.float32))
            base += len(part.vertices)
    return (np.concatenate(verts), np.concatenate(faces), np.concatenate(owner), np.concatenate(albedo), names)


def _box(centre, size, yaw):
    """(8, 3) vertices and (12, 3) faces of a box standing on z = centre[2]."""
    c, s = np.cos(yaw), np.sin(yaw)
    x, y, z = (np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (0.0, 1.0)]) * size).T
    v = np.column_stack([c * x - s * y, s * x + c * y, z]) + centre
    f = cuboid_faces()  # corners x slowest, as v above
    return v, f


def _rays(camera: Camera, factor: int):
    """Unit world directions (relative to the camera centre) through the distorted sample
    positions of ``factor`` x ``factor`` samples per pixel, (H*f, W*f, 3)."""
    h, w = camera.height * factor, camera.width * factor
    jj, ii = np.mgrid[0:h, 0:w].astype(np.float64)
    uv = np.stack([(ii + 0.5) / factor - 0.5, (jj + 0.5) / factor - 0.5], axis=-1).reshape(-1, 1, 2)
    xy = cv2.undistortPoints(
        uv,
        camera.K,
        camera.dist if camera.dist.size else None,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-10),
    ).reshape(-1, 2)
    d = np.column_stack([xy, np.ones(len(xy))]) @ camera.R  # R^T d, row-wise
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).reshape(h, w, 3)


def _cast(vertices, faces, origin_rays):
    import open3d as o3d

    rc = o3d.t.geometry.RaycastingScene()
    rc.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces.astype(np.uint32)))
    return rc, rc.cast_rays(o3d.core.Tensor(origin_rays.astype(np.float32)))


def _shade(hit, rays, albedo, rc, rng, sun, albedo_noise, origin) -> np.ndarray:
    """Linear radiance of every ray, (N,) or (N, 3) as ``albedo`` per face: sun (with shadow
    rays) + sky, textured albedo."""
    import open3d as o3d

    t = hit["t_hit"].numpy()
    ok = np.isfinite(t)
    prim = np.where(ok, hit["primitive_ids"].numpy(), 0).astype(np.int64)
    n = hit["primitive_normals"].numpy().astype(np.float64)
    n = np.where((np.einsum("ij,ij->i", n, rays) > 0)[:, None], -n, n)  # facing the camera
    p = rays * np.where(ok, t, 0.0)[:, None]
    world = p + origin
    waves = rng.normal(size=(4, 3)) * rng.uniform(2.0, 12.0, size=(4, 1))  # wavelengths 0.5-3 m
    phase = rng.uniform(0, 2 * np.pi, 4)
    texture = 1.0 + albedo_noise * np.mean(np.sin(world @ waves.T + phase), axis=1)
    # one texture and grain for every channel: a stain darkens a colour, it does not change it
    a = albedo[prim] * _per_channel(texture * (1.0 + 0.04 * rng.standard_normal(len(t))), albedo)
    lit = np.maximum(n @ sun, 0.0)
    shadow_rays = np.column_stack([p + n * 1e-3, np.broadcast_to(sun, p.shape)])
    todo = ok & (lit > 0)
    blocked = np.zeros(len(t), bool)
    if np.any(todo):
        occ = rc.test_occlusions(o3d.core.Tensor(shadow_rays[todo].astype(np.float32))).numpy()
        blocked[todo] = occ
    sky = 0.35 * (0.6 + 0.4 * n[:, 2])
    radiance = a * _per_channel(1.2 * lit * ~blocked + sky, albedo)
    return np.where(_per_channel(ok, albedo), radiance, 0.9), ok


def _per_channel(values: np.ndarray, albedo: np.ndarray) -> np.ndarray:
    """(N,) ``values`` shaped to multiply an (N,) or (N, 3) albedo."""
    return values[:, None] if albedo.ndim == 2 else values


def synthetic_photo(
    scene: Scene,
    camera: Camera,
    seed: int,
    clutter: int = 6,
    leave_out: bool = True,
    noise: float = 0.02,
    blur: float = 0.7,
    albedo_noise: float = 0.15,
    colour: bool = False,
):
    """``(photo, left_out, clutter_count)``: the (H, W) uint8 photo of ``scene`` from ``camera``;
    with ``colour`` (H, W, 3) uint8 RGB, the channel order :func:`mrcheck.core.images.read_image`
    gives a photo file."""
    rng = np.random.default_rng(seed)
    origin = camera.center
    f = _SUPERSAMPLE
    rays = _rays(camera, f).reshape(-1, 3)
    verts, faces, owner, albedo, names = _soup(scene, origin, colour=colour)
    left, placed = None, 0
    if clutter or leave_out:  # the first hits say where clutter stands and what is in view
        _, first = _cast(verts, faces, np.column_stack([np.zeros_like(rays), rays]))
        left = _pick_left_out(owner, first, names, rng) if leave_out else None
        if left is not None:
            verts, faces, owner, albedo, names = _soup(scene, origin, skip=left, colour=colour)
        verts, faces, albedo, placed = _add_clutter(verts, faces, albedo, rays, first, clutter, rng)
    elevation, azimuth = rng.uniform(np.radians(35), np.radians(65)), rng.uniform(0, 2 * np.pi)
    sun = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    rc, hit = _cast(verts, faces, np.column_stack([np.zeros_like(rays), rays]))
    radiance, _ = _shade(hit, rays, albedo, rc, rng, sun, albedo_noise, origin)
    image = radiance.reshape(camera.height, f, camera.width, f, *radiance.shape[1:]).mean(axis=(1, 3))
    image = image / max(np.percentile(image, 99.5), 1e-6) * 0.8
    image = np.clip(image, 0, 1) ** (1 / 2.2)
    if blur > 0:
        image = cv2.GaussianBlur(image.astype(np.float32), (0, 0), blur)
    image = image + noise * rng.standard_normal(image.shape)
    return np.clip(np.rint(image * 255), 0, 255).astype(np.uint8), left, placed


def _pick_left_out(owner, hit, names, rng):
    prim = hit["primitive_ids"].numpy()
    ok = np.isfinite(hit["t_hit"].numpy())
    share = np.bincount(owner[prim[ok].astype(np.int64)], minlength=len(names)) / ok.size
    lo, hi = _LEFT_OUT_SHARE
    candidates = np.flatnonzero((share >= lo) & (share <= hi))
    return names[int(rng.choice(candidates))] if len(candidates) else None


def _add_clutter(verts, faces, albedo, rays, hit, count, rng):
    """Boxes on floor spots (upward normals) seen in the photo; grey, also in a colour photo."""
    t = hit["t_hit"].numpy()
    n = hit["primitive_normals"].numpy()
    floor = np.flatnonzero(
        np.isfinite(t) & (np.abs(n[:, 2]) > 0.95) & (t < np.nanpercentile(np.where(np.isfinite(t), t, np.nan), 60))
    )
    placed = 0
    if count and len(floor):
        boxes_v, boxes_f, boxes_a = [verts], [faces], [albedo]
        base = len(verts)
        for k in rng.choice(floor, size=min(count, len(floor)), replace=False):
            point = rays[k] * t[k]
            size = rng.uniform(0.2, 0.9, 3) * np.array([1, 1, 1.2]) * max(t[k] / 8.0, 0.3)
            v, fc = _box(point, size, rng.uniform(0, np.pi))
            boxes_v.append(v.astype(np.float32))
            boxes_f.append(fc + base)
            boxes_a.append(np.full((12, *albedo.shape[1:]), rng.uniform(0.1, 0.8), np.float32))
            base += 8
            placed += 1
        verts, faces, albedo = np.concatenate(boxes_v), np.concatenate(boxes_f), np.concatenate(boxes_a)
    return verts, faces, albedo, placed


def scene_points(scene: Scene, camera: Camera, count: int = 2000, seed: int = 0) -> np.ndarray:
    """(n, 3) world points on the CAD surfaces seen by ``camera`` (pinhole rays, random pixels)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, camera.width - 1, count)
    v = rng.uniform(0, camera.height - 1, count)
    d = np.linalg.solve(camera.K, np.stack([u, v, np.ones(count)])).T @ camera.R
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    verts, faces, *_ = _soup(scene, camera.center)
    _, hit = _cast(verts, faces, np.column_stack([np.zeros_like(d), d]))
    t = hit["t_hit"].numpy()
    ok = np.isfinite(t)
    return d[ok] * t[ok, None] + camera.center


def reprojection_error(truth: Camera, estimate: Camera, points: np.ndarray) -> np.ndarray:
    """(n,) pixel distance between the points' projections (lens distortion included)."""

    def proj(cam):
        centre = points.mean(axis=0)
        rvec = cv2.Rodrigues(cam.R)[0]
        uv, _ = cv2.projectPoints(points - centre, rvec, cam.t + cam.R @ centre, cam.K, cam.dist)
        return uv.reshape(-1, 2)

    return np.linalg.norm(proj(truth) - proj(estimate), axis=1)


def corner_errors(truth: Camera, estimate: Camera, depth: float) -> np.ndarray:
    """(4,) pixel errors at the image corners (top left, top right, bottom right, bottom left)
    of the points that ``estimate`` sees there at ``depth``: what the reported corner
    uncertainty (:class:`~mrcheck.mr.edges.uncertainty.PoseUncertainty`) is a 1-sigma of."""
    w, h = estimate.width, estimate.height
    corners = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], np.float64)
    rays = np.linalg.solve(estimate.K, np.column_stack([corners, np.ones(4)]).T).T
    world = (depth * rays - estimate.t) @ estimate.R
    return np.linalg.norm(truth.project(world) - corners, axis=1)


def perturbed(camera: Camera, points: np.ndarray, offset_px: float, rng) -> Camera:
    """``camera`` moved in a random direction (rotation and translation mixed) by the amount
    that moves ``points`` by ``offset_px`` (median)."""
    depth = float(np.median((points @ camera.R.T + camera.t)[:, 2]))
    direction = rng.normal(size=6)
    direction[3:] *= depth  # radians and metres at the scene's depth
    direction /= np.linalg.norm(direction)

    def moved(s):
        R = cv2.Rodrigues(s * direction[:3])[0] @ camera.R
        return camera.with_pose(R, -R @ (camera.center + s * direction[3:]))

    lo, hi = 0.0, 1.0
    while np.median(reprojection_error(camera, moved(hi), points)) < offset_px and hi < 1e3:
        hi *= 2
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.median(reprojection_error(camera, moved(mid), points)) < offset_px else (lo, mid)
    return moved(hi)


def make_case(scene: Scene, camera: Camera, seed: int, offset_px: float | None = None, **photo_options) -> PhotoCase:
    """A photo of ``scene`` from ``camera`` (seeded), a rough pose 15-40 px off (or
    ``offset_px``) and the scene points to measure on."""
    rng = np.random.default_rng(seed + 1000)
    photo, left, placed = synthetic_photo(scene, camera, seed, **photo_options)
    points = scene_points(scene, camera, seed=seed)
    offset = float(offset_px if offset_px is not None else rng.uniform(15.0, 40.0))
    rough = perturbed(camera, points, offset, rng)
    return PhotoCase(
        photo, camera, rough, points, left, placed, float(np.median(reprojection_error(camera, rough, points)))
    )


__all__ = [
    "PhotoCase",
    "synthetic_photo",
    "scene_points",
    "reprojection_error",
    "corner_errors",
    "perturbed",
    "make_case",
]
