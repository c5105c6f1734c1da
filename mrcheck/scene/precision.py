"""Float32 local coordinates that keep a mesh's triangles (issue 17's reversed-Z float depth and
camera-relative float64 parts; issue 19's scenes at map coordinates).

A part's vertices are kept relative to its own centre; float32 holds them when rounding moves a
vertex by at most FLOAT32_SHARE of a small triangle. A part that float32 cannot hold (a factory at
5e6 m with a stray element at the origin) stays float64 and the geometry pass draws it in tiles
that float32 holds, each relative to its own centre (:func:`float32_tiles`).
"""

from __future__ import annotations

import numpy as np

FLOAT32_STEP = 2.0**-24  # float32 rounds to this share of a coordinate's magnitude (at most)
FLOAT32_SHARE = 1e-3  # local coordinates may round a vertex by this share of a small triangle
SMALL_TRIANGLE = 5  # "a small triangle": this percentile of the triangles' longest edges
SIZE_SAMPLE = 1 << 14  # make_part judges a mesh on at most this many triangles (a fixed stride)


def longest_edges(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) float64 longest edge of each triangle."""
    tri = np.asarray(vertices, np.float64)[faces]
    return np.linalg.norm(tri[:, [1, 2, 0]] - tri, axis=2).max(axis=1)


def float32_holds(radius: float, longest: np.ndarray) -> bool:
    """Whether float32 coordinates up to ``radius`` from their origin keep triangles with these
    longest edges: rounding by at most FLOAT32_SHARE of a small one (the shipped meshes: at most
    5e-5 of theirs). Triangles of one point have no size to keep."""
    sized = longest[longest > 0]
    return not sized.size or radius * FLOAT32_STEP <= FLOAT32_SHARE * float(np.percentile(sized, SMALL_TRIANGLE))


def float32_tiles(vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """The triangles of a float64 mesh in groups that float32 holds relative to each group's own
    bounding-box centre (:func:`float32_holds`), as arrays of face indices, in a fixed order.

    A group that does not hold is cut in two at the middle of its triangles' centroids along the
    axis where they spread most, so that a far element parts from the rest in one cut (the
    factory at 5e6 m from its stray element at the origin) and a huge triangle from the small
    ones beside it after a few. A single triangle always holds.
    """
    longest = longest_edges(vertices, faces)
    centroids = np.asarray(vertices, np.float64)[faces].mean(axis=1)
    tiles, todo = [], [np.arange(len(faces))]
    while todo:
        group = todo.pop()
        used = vertices[faces[group]].reshape(-1, 3)
        lo, hi = used.min(axis=0), used.max(axis=0)
        if float32_holds(float(np.abs(used - (lo + hi) / 2.0).max()), longest[group]):
            tiles.append(group)
            continue
        c = centroids[group]
        axis = int(np.argmax(np.ptp(c, axis=0)))
        if np.ptp(c[:, axis]) > 0:
            left = c[:, axis] <= (c[:, axis].min() + c[:, axis].max()) / 2.0
        else:  # every centroid in one point: halves (both non-empty, as a single triangle holds)
            left = np.arange(len(group)) < len(group) // 2
        todo += [group[~left], group[left]]
    return sorted(tiles, key=lambda group: int(group[0]))


def float32_or_float64(local: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``local`` as float32, or kept float64 when float32 would round it beyond FLOAT32_SHARE of
    its small triangles: a mesh holding a factory at map coordinates and a stray element at the
    origin has its centre halfway, 2.5e6 m from both, where float32 steps 0.25 m. The consumers
    then work in float64 and the geometry pass draws it in :func:`float32_tiles`."""
    sample = faces[:: max(1, -(-len(faces) // SIZE_SAMPLE))]  # a stride rounded up: at most SIZE_SAMPLE
    if not len(sample) or float32_holds(float(np.abs(local).max()), longest_edges(local, sample)):
        return local.astype(np.float32)
    return local


__all__ = ["FLOAT32_STEP", "FLOAT32_SHARE", "longest_edges", "float32_holds", "float32_tiles", "float32_or_float64"]
