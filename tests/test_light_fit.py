"""The photo's light (``mrcheck.apps.discrepancies.light``): the fit of all directions at once
by the 2x2 normal equations picks the light that a least-squares fit per direction picks."""

from __future__ import annotations

import numpy as np

from mrcheck.apps.discrepancies import light


def _per_direction(q, w, d):
    """The reference: ``np.linalg.lstsq`` for one direction after another (the straightforward loop the batched solve replaces)."""
    out = []
    for column in d.T:
        design = np.stack((np.ones_like(column), column), -1) * w[:, None]
        coef, *_ = np.linalg.lstsq(design, q * w, rcond=None)
        rms = np.sqrt(np.mean((design @ coef - q * w) ** 2) / np.mean(w * w))
        out.append((coef[0], coef[1], rms))
    return np.array(out).T


def _pixels(rng, count=3000):
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[:, 2] = -np.abs(n[:, 2])  # facing the camera (OpenCV: towards -z)
    return n


def test_the_joint_fit_matches_least_squares_per_direction():
    rng = np.random.default_rng(3)
    n = _pixels(rng)
    sun = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])
    w = rng.uniform(0.05, 1.0, len(n))
    q = 0.4 + 0.6 * np.maximum(n @ sun, 0.0) + rng.normal(0, 0.02, len(n))
    directions = light.sphere_directions(light.LIGHT_DIRECTIONS)
    d = np.maximum(n @ directions.T, 0.0)
    d[:, 7] = 0.0  # a direction that faces no pixel
    d[:, 8] = 0.25  # one that lights every pixel alike
    got, want = np.array(light.fit_all_directions(q, w, d)), _per_direction(q, w, d)
    assert np.allclose(got, want, rtol=1e-7, atol=1e-9), np.abs(got - want).max(axis=1)
    assert np.argmin(got[2]) == np.argmin(want[2])


def test_the_estimated_light_is_the_one_that_lit_the_pixels():
    rng = np.random.default_rng(5)
    h, w = 120, 160
    normals = _pixels(rng, h * w).reshape(h, w, 3).astype(np.float32)
    albedo = rng.uniform(0.2, 0.8, (h, w, 1)) * np.ones((1, 1, 3))
    sun = light.sphere_directions(light.LIGHT_DIRECTIONS)[123]
    linear = albedo * (0.5 + 0.5 * np.maximum(normals @ sun, 0.0))[..., None]
    from mrcheck.render.antialias import linear_to_srgb

    photo = linear_to_srgb(linear.astype(np.float32))
    found = light.estimate_light(
        photo, albedo.astype(np.float32), normals, np.zeros((h, w), np.int32), np.zeros((h, w), bool)
    )
    assert found is not None and np.dot(found.direction, sun) > 0.99
    assert abs(found.ambient - 0.5) < 0.03 and abs(found.diffuse - 0.5) < 0.03
