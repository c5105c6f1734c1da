"""Crytek SSAO (Mittring 2007; Kajalin 2009) as in Jakobsen's thesis, section 4.3.1 and
appendix A: a whole sphere of constant camera-space radius ``radius_world``, no normal, the
thesis' depth range check. The math is in ``shaders/ao_crytek.glsl``.

Kernel: the thesis loops over the eight corners of a cube (``normalize(x, y, z)``, x, y, z =
+-1), scaled by a radius that grows each round. The corners come in antipodal pairs, so behind
any plane through P lie exactly half of them -- which is what makes a flat surface read exactly
half occluded. We keep that property with the shared random kernel arranged in antipodal pairs
(offset 2m + 1 = -offset 2m, lengths growing with m, denser near the centre), reflected per
pixel on the 4x4 tile's random plane (a reflection keeps the pairs antipodal).
"""

from __future__ import annotations

import numpy as np

from mrcheck.render.ao import kernel
from mrcheck.render.ao.base import AOPass


def antipodal_kernel(samples: int, seed: kernel.Seed = 0) -> np.ndarray:
    """(samples, 3) float32: the shared sphere kernel's first ceil(samples / 2) directions with
    lengths growing to 1, each followed by its negation (an odd count leaves the last unpaired)."""
    pairs = (samples + 1) // 2
    half = kernel.sphere_kernel(pairs, seed)
    out = np.empty((2 * pairs, 3), np.float32)
    out[0::2], out[1::2] = half, -half
    return out[:samples]


class CrytekAO(AOPass):
    shader = "ao_crytek"
    mode = "crytek"
    offsets = staticmethod(antipodal_kernel)


__all__ = ["CrytekAO", "antipodal_kernel"]
