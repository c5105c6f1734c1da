"""Sample kernels and the rotation tile shared by the screen-space AO passes.

The kernel holds ``n`` offsets inside the unit sphere with random directions and lengths that
grow quadratically with the index, so more samples land near the centre, where occluders
matter most (NOTES 5: item 5 of docs/papers_notes.md). Per pixel each offset is reflected on a
random plane taken from a ``NOISE_SIZE`` x ``NOISE_SIZE`` tile (Mittring 2007), which turns
banding into high-frequency noise that the 4x4-periodic pattern lets the bilateral blur remove.
"""

from __future__ import annotations

import numpy as np

NOISE_SIZE = 4  # the rotation tile is NOISE_SIZE x NOISE_SIZE pixels
MIN_OFFSET = 0.1  # shortest offset, as a fraction of the sampling radius
PAPER_SAMPLE_COUNTS = (16, 36, 64, 128)  # Scheer & Keutel, table 1
Seed = int | list[int]  # a render's seed, or an accumulation frame's (frame_seed)


def _unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def sphere_kernel(samples: int, seed: Seed = 0) -> np.ndarray:
    """(samples, 3) float32 offsets inside the unit sphere, denser near the centre."""
    if samples < 1:
        raise ValueError("samples must be >= 1")
    rng = np.random.default_rng(seed)
    directions = _unit_vectors(rng, samples)
    t = (np.arange(samples) + 1.0) / samples
    lengths = MIN_OFFSET + (1.0 - MIN_OFFSET) * t * t
    return (directions * lengths[:, None]).astype(np.float32)


GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


def stratified_kernel(samples: int, seed: Seed = 0) -> np.ndarray:
    """(samples, 3) float32 offsets inside the unit sphere, denser near the centre, with evenly
    spread directions: the vector mode's kernel (docs/reference-compare.md: against the
    ray-traced reference its error was mostly variance, not bias).

    The same lengths as :func:`sphere_kernel` (quadratic in the index), but the directions are
    a spherical Fibonacci lattice (even coverage of the sphere, Keinert et al. 2015) in a random
    orientation (``seed``), assigned to the lengths in a golden-ratio order rather than by
    latitude (the short offsets are not all at one pole). Reflected per pixel on
    the rotation tile's plane and flipped into the normal's hemisphere as before, a pixel's
    estimate still averages occlusion over the same distribution (the paper's estimator,
    section 3), with less variance from pixel to pixel than independent random directions."""
    if samples < 1:
        raise ValueError("samples must be >= 1")
    i = np.arange(samples) + 0.5
    z = 1.0 - 2.0 * i / samples
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    lattice = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))  # a random rotation
    directions = (lattice @ q.T)[np.argsort((np.arange(samples) * GOLDEN) % 1.0)]
    t = (np.arange(samples) + 1.0) / samples
    lengths = MIN_OFFSET + (1.0 - MIN_OFFSET) * t * t
    return (directions * lengths[:, None]).astype(np.float32)


def frame_seed(seed: int, frame: int) -> Seed:
    """The seed of accumulation frame ``frame`` of a render seeded ``seed``: ``seed`` itself for
    frame 0 (a single frame is the render it always was), an independent stream for the others."""
    return seed if frame == 0 else [seed, frame]


def rotation_tile(seed: Seed = 0) -> np.ndarray:
    """(NOISE_SIZE, NOISE_SIZE, 3) float32 unit normals of the per-pixel reflection planes;
    ``seed``: an int or a :func:`frame_seed`."""
    rng = np.random.default_rng([*seed, 0x5EED] if isinstance(seed, list) else seed + 0x5EED)
    return _unit_vectors(rng, NOISE_SIZE * NOISE_SIZE).reshape(NOISE_SIZE, NOISE_SIZE, 3).astype(np.float32)


def defines(samples: int, stride: int = 1) -> dict:
    """The constants the AO shaders are compiled with (one place for Python and GLSL);
    ``stride`` 2 is half-resolution AO reading the full-resolution G-buffer."""
    return {"AO_SAMPLES": int(samples), "NOISE_SIZE": NOISE_SIZE, "AO_STRIDE": int(stride)}


__all__ = [
    "sphere_kernel",
    "stratified_kernel",
    "rotation_tile",
    "frame_seed",
    "Seed",
    "defines",
    "NOISE_SIZE",
    "PAPER_SAMPLE_COUNTS",
]
