"""Edges of the photo and of the planned CAD, and how well the first support the second.

* :func:`photo_edges`: Canny on the grey photo after a light Gaussian blur, thresholds set
  automatically from the median gradient magnitude, capped by the measured noise (so a darker or
  brighter exposure, or another light, gives the same edges), and the gradient direction.
* :func:`silhouettes`: the outline of every instance of an id buffer (instance boundaries and
  depth steps); :func:`cad_edge_owner`: the instance each CAD edge pixel belongs to (the
  nearest of its 3x3 neighbourhood: a silhouette is the occluder's outline).
* :func:`outline_normals`, :func:`oriented_support`, :func:`shifted_support`: is there a photo
  edge within the tolerance whose gradient direction lies within about 34 degrees of the
  outline's normal, at the planned place and at every shift up to a radius.
"""

from __future__ import annotations

import cv2
import numpy as np

from mrcheck.apps.discrepancies.ids import BACKGROUND

SILHOUETTE_STEP = 0.05  # relative depth jump that makes an outline (creases are not used for support)
FLOOR_FACTOR = 4.0  # Canny's high threshold over the median gradient (the noise floor)
NOISE_FLOOR_SIGMAS = 3.0  # ... which is at most this many measured noise sigmas (see photo_edges)
ORIENTATION_BINS = 8  # of edge normal directions over 180 degrees


def photo_edges(photo: np.ndarray, high: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) bool Canny edges with thresholds from the median gradient magnitude (or Canny's
    ``high`` threshold as given), and (H, W) float32 the direction of the grey-level gradient
    (the edge normal) in [0, pi)."""
    grey, gx, gy = _blurred_gradient(photo)
    high = _threshold(photo, gx, gy) if high is None else float(high)
    return cv2.Canny(grey, 0.4 * high, high, L2gradient=True) > 0, np.mod(np.arctan2(gy, gx), np.pi)


def edge_threshold(photo: np.ndarray) -> float:
    """Canny's high threshold for ``photo``: a noise floor (about the median gradient) times
    :data:`FLOOR_FACTOR`, at least 20 grey levels per pixel."""
    return _threshold(photo, *_blurred_gradient(photo)[1:])


def _threshold(photo: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> float:
    mag = np.hypot(gx, gy)
    # the median of the *textured* pixels: a flat image half sky would set no threshold at all;
    # a noise floor (~ the median) times a factor keeps noise out at any exposure. On a clean
    # image (a render, a low-noise photo) the non-zero gradients are mostly edges, and their
    # median rejected the edges themselves (26 of 64 parts flagged on the planned scene as its
    # own noise-free photo at 640x480, 21 at 1024x768): the noise actually measured caps the
    # floor, at 3 sigma, above the median on the evaluation's noisy photos (sigma 2.7, median
    # 4.0-5.8), whose thresholds stay as they were
    floor = float(np.median(mag[mag > 0])) if np.any(mag > 0) else 1.0
    floor = min(floor, NOISE_FLOOR_SIGMAS * _noise_sigma(cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY)))
    return max(FLOOR_FACTOR * floor, 20.0)


def texture_edges(photo: np.ndarray, edges: np.ndarray, plain: np.ndarray) -> np.ndarray:
    """(H, W) bool: the ``edges`` no stronger than the texture of the ``plain`` pixels (planned
    floor away from every CAD edge): their gradient magnitude is below :data:`FLOOR_FACTOR`
    times the plain pixels' median, the rule Canny's threshold applies to the noise
    (:func:`edge_threshold`), with the floor's texture as the noise. Stains, wear and the
    texture of a concrete floor make such edges; an object standing there has its own outline,
    far stronger. No plain pixels: none."""
    if not np.any(plain):
        return np.zeros_like(edges)
    magnitude = np.hypot(*_blurred_gradient(photo)[1:])
    return edges & (magnitude < FLOOR_FACTOR * float(np.median(magnitude[plain])))


def _blurred_gradient(photo: np.ndarray):
    """(grey after a light Gaussian blur, its Sobel x and y gradients)."""
    grey = cv2.GaussianBlur(cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY), (0, 0), 1.0)
    return grey, cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1)


def _noise_sigma(grey: np.ndarray) -> float:
    """Standard deviation of the image noise, grey levels (Immerkaer 1996, "Fast noise variance
    estimation": a mask that cancels linear structure, so edges and shading count little)."""
    mask = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
    h, w = grey.shape
    if h < 3 or w < 3:
        return 0.0
    response = cv2.filter2D(grey.astype(np.float32), -1, mask)[1:-1, 1:-1]
    return float(np.sqrt(np.pi / 2.0) * np.abs(response).sum() / (6.0 * (w - 2) * (h - 2)))


def outline_normals(outline: np.ndarray) -> np.ndarray:
    """(H, W) float32 normal direction in [0, pi) of the line through each pixel of the binary
    ``outline``: the dominant gradient direction of its structure tensor (a 2 px wide line's
    gradient points across it)."""
    m = cv2.GaussianBlur(outline.astype(np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(m, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(m, cv2.CV_32F, 0, 1)
    jxx, jyy, jxy = (cv2.GaussianBlur(a, (0, 0), 1.5) for a in (gx * gx, gy * gy, gx * gy))
    return np.mod(0.5 * np.arctan2(2.0 * jxy, jxx - jyy), np.pi)


def orientation_bin(angle: np.ndarray) -> np.ndarray:
    """The bin (0 .. ORIENTATION_BINS - 1) of a normal direction in [0, pi)."""
    return (np.floor(angle / np.pi * ORIENTATION_BINS).astype(np.int32)) % ORIENTATION_BINS


def oriented_support(edges: np.ndarray, angle: np.ndarray, tol: float) -> np.ndarray:
    """(ORIENTATION_BINS, H, W) bool: is there a photo edge within ``tol`` px whose normal lies in
    bin b or a neighbouring bin (within about 34 degrees of the bin's centre)? A neighbour's edge
    crossing a CAD outline at an angle is no support for it."""
    b = orientation_bin(angle)
    out = np.empty((ORIENTATION_BINS, *edges.shape), bool)
    for k in range(ORIENTATION_BINS):
        near = edges & ((b == k) | (b == (k + 1) % ORIENTATION_BINS) | (b == (k - 1) % ORIENTATION_BINS))
        out[k] = cv2.distanceTransform((~near).astype(np.uint8), cv2.DIST_L2, 5) <= tol
    return out


def shifted_support(mask: np.ndarray, bins: np.ndarray, padded: np.ndarray, radius: int) -> np.ndarray:
    """(2 radius + 1, 2 radius + 1) share of the outline ``mask`` supported by an oriented photo
    edge when the outline is shifted by (dy, dx) (index [radius + dy, radius + dx]); ``padded``
    is :func:`oriented_support` padded by ``radius`` on every side."""
    ys, xs = np.nonzero(mask)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    total = np.zeros((2 * radius + 1, 2 * radius + 1), np.float32)
    for k in np.unique(bins[ys, xs]):
        template = (mask[y0:y1, x0:x1] & (bins[y0:y1, x0:x1] == k)).astype(np.float32)
        window = padded[k, y0 : y1 + 2 * radius, x0 : x1 + 2 * radius].astype(np.float32)
        total += cv2.matchTemplate(window, template, cv2.TM_CCORR)
    return total / len(ys)


def cad_edge_owner(ids: np.ndarray, depth: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(H, W) int32: for every CAD edge pixel the nearest instance of its 3x3 neighbourhood
    (a silhouette belongs to the occluder), -1 elsewhere."""
    h, w = ids.shape
    far = np.where(depth > 0, depth, np.inf)
    pd = np.pad(far, 1, constant_values=np.inf)
    pi = np.pad(ids, 1, constant_values=BACKGROUND)
    best_d, best_i = far.copy(), ids.copy()
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            d = pd[dy : dy + h, dx : dx + w]
            closer = d < best_d
            best_d = np.where(closer, d, best_d)
            best_i = np.where(closer, pi[dy : dy + h, dx : dx + w], best_i)
    return np.where(edges, best_i, BACKGROUND).astype(np.int32)


def silhouettes(ids: np.ndarray, depth: np.ndarray, step: float = SILHOUETTE_STEP) -> np.ndarray:
    """(H, W) bool: pixels on a boundary between instances (or instance and background) or on a
    depth step of more than ``step`` relative to the nearer side (a part occluding itself)."""
    out = np.zeros(ids.shape, bool)
    for axis in (0, 1):
        a = np.moveaxis(ids, axis, 0)
        z = np.moveaxis(depth, axis, 0)
        near = np.minimum(z[1:], z[:-1])
        jump = (a[1:] != a[:-1]) | (np.abs(z[1:] - z[:-1]) > step * np.where(near > 0, near, np.inf))
        o = np.moveaxis(out, axis, 0)
        o[1:] |= jump
        o[:-1] |= jump
    return out


__all__ = [
    "photo_edges",
    "edge_threshold",
    "outline_normals",
    "orientation_bin",
    "oriented_support",
    "shifted_support",
    "cad_edge_owner",
    "silhouettes",
    "SILHOUETTE_STEP",
    "ORIENTATION_BINS",
]
