"""Cast shadows the photo shows: their edges are not unexplained structure (issue 41).

A sun-lit hall shows the shadows of its columns, beams, conveyors and pallets on the floor: long,
sharp photo edges no CAD edge explains, which the detector reported as "extra" structure (on
Open3D photos with cast shadows, most of the false flags left once the floor's texture was set
aside). A planned surface point is in shadow when a ray from it towards the sun hits the planned
scene; where a shadowed block of pixels meets a lit one, the photo can show a shadow's edge.

The sun is found from the shadows themselves (:func:`fit_sun`): for each direction of a grid over
the sky (:data:`SKY_DIRECTIONS`, about 6 degrees apart) the planned floor (``PlannedView.ground``,
every :data:`FIT_STRIDE`-th pixel) is split into the points that direction shadows and the rest,
and the direction whose split best explains the photo's brightness there (photo over planned
albedo; the variance a lit / shadowed two-level model explains) wins, refined on a finer cone
around it. Why not the shading
fit of :mod:`.light`: on Open3D photos (sun, sky, textured albedo) its direction was a median 36
degrees off the true sun (90 % within 85), as the floor that fills most views fixes the sun's
height only; the shadows' own fit is a median 2.5 degrees off, 90 % within 25 (seeds 0-4, five
views: a long beam's shadow does not fix the turn about the beam).

Shadows are predicted only when the fit finds them: the shadowed floor at most
``1 - MIN_CONTRAST`` as bright as the lit floor. The sun's remaining uncertainty is taken in by
the boundary of :data:`CONE_DEG` around the fitted direction as well (union). Rays are cast for
every :data:`STRIDE` x :data:`STRIDE` block (a shadow's edge is a few pixels wide in the blur).

Limits: only the planned scene casts shadows (an added object's own shadow is its structure);
what stands outside the model (an unmodelled building, people) casts none here; one sun.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.discrepancies.ids import world_points
from mrcheck.apps.discrepancies.light import sphere_directions
from mrcheck.core.camera import Camera
from mrcheck.render.antialias import srgb_to_linear

SKY_DIRECTIONS = 800  # of the whole sphere; the ~360 above 6 degrees of elevation are tried
FIT_STRIDE = 4  # px between the floor points the sun is fitted on
MIN_FIT_POINTS = 200  # fewer floor points: no fit
MIN_SHADOWED = 0.01  # a direction must shadow at least this share of them (and leave 10 % lit)
MIN_CONTRAST = 0.3  # the shadowed floor must be this much darker than the lit (see fit_sun)
CONE_DEG = 3.0  # the fitted sun's uncertainty taken into the prediction (half the grid)
CONE_STEPS = 6  # directions on that cone, besides the fitted one
STRIDE = 2  # px: one shadow ray per STRIDE x STRIDE block
OFFSET_M = 0.005  # a ray starts this far off its surface (along the normal): no self-hit


@dataclass(frozen=True)
class Sun:
    """The sun the photo's shadows show: ``direction`` (3,) unit, world, towards the sun;
    ``contrast``: 1 - shadowed / lit floor brightness (medians)."""

    direction: np.ndarray
    contrast: float


def fit_sun(caster, camera: Camera, planned, photo: np.ndarray) -> Sun | None:
    """The sun whose planned shadows the photo shows best (module docstring), or None: no floor,
    too few floor points, or no direction's shadows darker by :data:`MIN_CONTRAST`."""
    if caster is None or planned.ground is None:
        return None
    sub = (slice(FIT_STRIDE // 2, None, FIT_STRIDE), slice(FIT_STRIDE // 2, None, FIT_STRIDE))
    floor = planned.ground[sub] & (planned.depth[sub] > 0)
    if floor.sum() < MIN_FIT_POINTS:
        return None
    q = srgb_to_linear(photo)[sub].sum(-1) / np.maximum(planned.albedo[sub].sum(-1), 1e-3)
    points, offset = _surface_points(camera, planned.depth, planned.normals, sub, caster.origin)
    origins, brightness = (points + offset)[floor], q[floor]
    sky = sphere_directions(SKY_DIRECTIONS)
    best = _best(caster, origins, brightness, sky[sky[:, 2] > np.sin(np.radians(6.0))])
    if best is None:
        return None
    best = _best(caster, origins, brightness, np.array([*cone(best.direction, 3.0, 8), *cone(best.direction, 1.5, 8)]))
    return best if best is not None and best.contrast >= MIN_CONTRAST else None


def _best(caster, origins: np.ndarray, brightness: np.ndarray, directions: np.ndarray) -> Sun | None:
    """The direction whose shadow split explains most of the floor's brightness: the share of its
    variance a two-level model (lit, shadowed) explains, ``p (1 - p) (lit - shadowed)^2 / var``
    (least squares; the darkest split alone would prefer a direction that shadows a few of the
    truly shadowed points, with the same contrast: on seed 0, three of five views 22-31 degrees off)."""
    best, best_score = None, -np.inf
    variance = float(brightness.var()) or 1e-12
    for direction in directions:
        rays = np.concatenate([origins, np.broadcast_to(direction, origins.shape)], 1).astype(np.float32)
        shadowed = caster.cast(rays).hit
        share = float(shadowed.mean())
        if share < MIN_SHADOWED or share > 0.9:
            continue
        lit, dark = float(brightness[~shadowed].mean()), float(brightness[shadowed].mean())
        score = share * (1.0 - share) * (lit - dark) ** 2 / variance
        if score > best_score and lit > dark:
            contrast = 1.0 - float(np.median(brightness[shadowed]) / max(np.median(brightness[~shadowed]), 1e-6))
            best, best_score = Sun(np.asarray(direction, np.float64), contrast), score
    return best


def shadow_edges(caster, camera: Camera, depth: np.ndarray, normals: np.ndarray, sun: Sun | None) -> np.ndarray:
    """(H, W) bool: pixels within a block of a predicted shadow boundary of ``sun`` (module
    docstring); ``caster``: the planned scene's :class:`~mrcheck.scene.raycast.SceneCaster`
    around the camera centre; ``depth`` and ``normals``: the planned view's (photo pixels)."""
    edges = np.zeros(depth.shape, bool)
    if caster is None or sun is None:
        return edges
    sub = (slice(STRIDE // 2, None, STRIDE), slice(STRIDE // 2, None, STRIDE))
    seen = depth[sub] > 0
    if not seen.any():
        return edges
    points, offset = _surface_points(camera, depth, normals, sub, caster.origin)
    origins = (points + offset)[seen]
    for direction in cone(sun.direction, CONE_DEG, CONE_STEPS):
        lit = np.ones(seen.shape, bool)
        rays = np.concatenate([origins, np.broadcast_to(direction, origins.shape)], 1)
        lit[seen] = ~caster.cast(rays.astype(np.float32)).hit
        edges |= _boundary(lit, seen, depth.shape)
    return edges


def cone(axis: np.ndarray, degrees: float, steps: int) -> list[np.ndarray]:
    """``axis`` (unit) and ``steps`` unit directions ``degrees`` around it, evenly spaced."""
    axis = axis / np.linalg.norm(axis)
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    a = np.radians(degrees)
    around = [
        np.cos(a) * axis + np.sin(a) * (np.cos(k) * u + np.sin(k) * v) for k in 2 * np.pi * np.arange(steps) / steps
    ]
    return [axis, *around]


def _surface_points(camera: Camera, depth: np.ndarray, normals: np.ndarray, sub, origin) -> tuple:
    """World points (relative to ``origin``) of the subsampled pixels' planned surfaces and their
    :data:`OFFSET_M` offsets along the surface normal (world), each (h, w, 3)."""
    world = world_points(camera, depth)[sub] - np.asarray(origin).reshape(1, 1, 3)
    return world, OFFSET_M * (normals[sub] @ camera.R)


def _boundary(lit: np.ndarray, seen: np.ndarray, shape: tuple) -> np.ndarray:
    """Full-size pixels of the blocks where lit and shadowed surface blocks meet."""
    kernel = np.ones((3, 3), np.uint8)
    shadowed = (seen & ~lit).astype(np.uint8)
    sunny = (seen & lit).astype(np.uint8)
    meet = (cv2.dilate(shadowed, kernel) > 0) & (cv2.dilate(sunny, kernel) > 0) & seen
    return cv2.resize(meet.astype(np.uint8), (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST) > 0


__all__ = ["Sun", "fit_sun", "shadow_edges", "cone", "CONE_DEG", "MIN_CONTRAST"]
