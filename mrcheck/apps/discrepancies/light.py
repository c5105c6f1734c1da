"""The photo's light, estimated from the photo, and the planned scene relit by it.

Which outline pixels can a photo show at all depends on its light: two faces of one colour
differ only by their shading, and a yellow post against a pale wall is a luminance edge under
one light and none under another. The planned render is lit by a headlight; judging a sun-lit
photo on the outline that render shows flagged unchanged fence posts and panels, lights and roof
decks (docs/discrepancy-evaluation.md, issue 22). So the light is fitted to the photo with the
renderer's own model (``shaders/composite.glsl``: linear colour = albedo * (ambient + diffuse *
max(n . l, 0)), specular ignored), over the planned surfaces the photo sees away from any CAD
edge: a grid of directions ``l`` over the sphere, for each the least-squares ambient and diffuse
weights, the direction of least residual kept. The planned render's own light is fitted the same
way, and :func:`relit` re-shades the render from it to the photo's.

Limit: the evaluation's photos are renders with the ``sun`` light, i.e. this very model; a real
hall's light (several lamps, specular metal) fits it less well, which is not measured yet.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.render.antialias import linear_to_srgb, srgb_to_linear

LIGHT_DIRECTIONS = 400  # directions tried, spread evenly over the sphere (about 10 degrees apart)
FIT_PIXELS = 20000  # surface pixels the fit uses at most (a fixed, even subsample)
EDGE_CLEARANCE = 3  # px a fitted pixel keeps from every CAD edge (mixed surfaces there)
# direct light at most this many times the ambient: a view of mostly one orientation (a floor) is
# fitted as well by a light grazing it with a huge weight (6.3 times the ambient in the sample
# cell's overview at 320x240, 63 degrees off the sun); the renderer's own ratio is 0.75
MAX_DIRECT = 2.0


@dataclass(frozen=True)
class Light:
    """A directional light in the renderer's model: colour = albedo * (ambient + diffuse * max(n . l, 0))."""

    direction: np.ndarray  # (3,) unit, camera space (OpenCV axes), towards the light
    ambient: float
    diffuse: float
    residual: float  # rms of the fit, in units of albedo


def sphere_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors evenly spread over the sphere (a Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (1.0 + 5.0**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack((r * np.cos(phi), r * np.sin(phi), z), -1)


def _fit_pixels(photo: np.ndarray, ids: np.ndarray, cad: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Flat indices of the pixels the fit uses: a planned surface with a normal, clear of CAD
    edges, not clipped in the photo; an even subsample of at most :data:`FIT_PIXELS`."""
    k = 2 * EDGE_CLEARANCE + 1
    near_edge = cv2.dilate(cad.astype(np.uint8), np.ones((k, k), np.uint8)) > 0
    usable = (ids >= 0) & ~near_edge & (np.abs(normals).sum(-1) > 0.5) & (photo.max(-1) < 255)
    flat = np.flatnonzero(usable)
    return flat[:: max(1, len(flat) // FIT_PIXELS)]


def estimate_light(
    photo: np.ndarray, albedo: np.ndarray, normals: np.ndarray, ids: np.ndarray, cad: np.ndarray
) -> Light | None:
    """The light that best explains ``photo`` (uint8 sRGB) given the planned per-pixel linear
    ``albedo`` and camera-space ``normals``; None when too few surface pixels are clear of edges."""
    flat = _fit_pixels(photo, ids, cad, normals)
    if len(flat) < 100:
        return None
    seen = srgb_to_linear(photo).reshape(-1, 3)[flat].sum(-1)
    a = albedo.reshape(-1, 3)[flat].sum(-1)
    n = normals.reshape(-1, 3)[flat]
    keep = a > 1e-3
    q, n, w = seen[keep] / a[keep], n[keep], a[keep]  # shading; weighted by albedo (dark parts are noisy)
    directions = sphere_directions(LIGHT_DIRECTIONS)
    ambient, diffuse, rms = fit_all_directions(q, w, np.maximum(n @ directions.T, 0.0))
    # darkening what it faces is no light either; bright beyond MAX_DIRECT is a grazing floor fit
    rms = np.where((diffuse >= 0.0) & (diffuse <= MAX_DIRECT * ambient), rms, np.inf)
    if not np.isfinite(rms).any():
        return None
    best = int(np.argmin(rms))
    return Light(directions[best], float(ambient[best]), float(diffuse[best]), float(rms[best]))


def fit_all_directions(q: np.ndarray, w: np.ndarray, d: np.ndarray) -> tuple:
    """``(ambient, diffuse, rms)`` per column of ``d`` ((m, k): max(n . l, 0) of every pixel
    for every direction): the weighted least squares of ``q ~ ambient + diffuse * d`` (weights
    ``w``), solved for all directions at once by its 2x2 normal equations. Why not
    ``np.linalg.lstsq`` per direction: on 20 000 pixels the 400 calls took 0.21-0.22 s, these
    products 0.05 s after the first call (measured, the same light chosen). Where
    ``d`` is the same for every pixel (a direction that faces none of them: d = 0) the two
    weights are not determined; they get lstsq's minimum-norm answer. ``rms`` in units of
    albedo."""
    w2 = w * w
    s11, b1, yy = w2.sum(), w2 @ q, w2 @ (q * q)
    s12, s22, b2 = w2 @ d, w2 @ (d * d), (w2 * q) @ d
    det = s11 * s22 - s12 * s12
    solvable = det > 1e-12 * s11 * np.maximum(s22, 1e-300)
    safe = np.where(solvable, det, 1.0)
    level, d0 = b1 / s11, s12 / s11  # the singular case: q ~ level, d = d0 throughout
    ambient = np.where(solvable, (b1 * s22 - b2 * s12) / safe, level / (1.0 + d0 * d0))
    diffuse = np.where(solvable, (s11 * b2 - s12 * b1) / safe, level * d0 / (1.0 + d0 * d0))
    residual = (
        yy - 2.0 * (ambient * b1 + diffuse * b2) + ambient**2 * s11 + 2.0 * ambient * diffuse * s12 + diffuse**2 * s22
    )
    rms = np.sqrt(np.maximum(residual, 0.0) / len(q) / np.mean(w2))
    return ambient, diffuse, rms


def shading(normals: np.ndarray, light: Light) -> np.ndarray:
    """(..., ) float32 ambient + diffuse * max(n . l, 0) of every normal."""
    return (light.ambient + light.diffuse * np.maximum(normals @ light.direction, 0.0)).astype(np.float32)


def relit(render: np.ndarray, normals: np.ndarray, render_light: Light, photo_light: Light) -> np.ndarray:
    """(h, w, 3) uint8 sRGB: ``render`` re-shaded from its own (fitted) light to the photo's, pixel
    by pixel in its own raster (``normals``: its G-buffer's). Dividing out the render's shading
    keeps the colours the rasteriser gave every pixel and makes the fit's errors common to both
    lights; pixels without a normal (the background) stay as rendered."""
    ratio = shading(normals, photo_light) / np.maximum(shading(normals, render_light), 1e-3)
    out = linear_to_srgb(srgb_to_linear(render) * ratio[..., None])
    return np.where((np.abs(normals).sum(-1) > 0.5)[..., None], out, render)


__all__ = [
    "Light",
    "estimate_light",
    "relit",
    "shading",
    "sphere_directions",
    "fit_all_directions",
    "LIGHT_DIRECTIONS",
    "FIT_PIXELS",
    "EDGE_CLEARANCE",
    "MAX_DIRECT",
]
