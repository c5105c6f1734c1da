"""The vector mode's stratified kernel (mrcheck.render.ao.kernel.stratified_kernel)."""

from __future__ import annotations

import numpy as np
import pytest

from mrcheck.render.ao.kernel import sphere_kernel, stratified_kernel


def _coverage_gap(directions: np.ndarray) -> float:
    """The largest angle (degrees) from any of 2000 test directions to its nearest kernel direction."""
    probe = np.random.default_rng(7).normal(size=(2000, 3))
    probe /= np.linalg.norm(probe, axis=1, keepdims=True)
    return float(np.degrees(np.arccos(np.clip((probe @ directions.T).max(axis=1), -1, 1))).max())


@pytest.mark.parametrize("samples", [16, 36, 64])
def test_same_lengths_as_the_random_kernel_with_evenly_spread_directions(samples):
    """The lengths (quadratic in the index) are the random kernel's; the directions cover the
    sphere more evenly than independent random ones (smaller largest gap); the same seed gives
    the same kernel."""
    ours, theirs = stratified_kernel(samples, 3), sphere_kernel(samples, 3)
    assert np.allclose(np.linalg.norm(ours, axis=1), np.linalg.norm(theirs, axis=1), atol=1e-6)
    unit = ours / np.linalg.norm(ours, axis=1, keepdims=True)
    random = theirs / np.linalg.norm(theirs, axis=1, keepdims=True)
    assert _coverage_gap(unit) < 0.8 * _coverage_gap(random)
    assert np.array_equal(stratified_kernel(samples, 3), ours)
    assert not np.array_equal(stratified_kernel(samples, 4), ours)
