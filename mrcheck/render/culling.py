"""Which part instances the geometry pass draws: frustum culling, then occlusion culling.

llvmpipe pays for every triangle it is given (vertex shading and set-up run on the CPU), so
from a hall's aisle, where the first row of racks hides the rows behind it, most of the cost
is spent on geometry that never reaches a pixel. Both tests work on the instance's bounding
box (the part's local bounds under its model-view matrix) and are conservative: an instance is
skipped only when none of its fragments could pass the depth test, so the image is the same as
drawing everything.

1. Frustum: the box lies behind the camera or outside one of the four side planes through the
   image borders (1 px margin).
2. Occlusion, in two phases within one frame (no previous frame is needed, so single renders
   and the export get it too):

   a. the *occluders* -- instances whose box covers at least :data:`OCCLUDER_AREA` of the image,
      or spans the camera plane (floor, walls, the near racks and stacks) -- are drawn first;
   b. a hierarchical depth buffer (Hi-Z) of what they left is built: the farthest depth of every
      8x8 block on the GPU (``shaders/hiz_reduce.glsl``, a 1/64 read-back), then a max pyramid
      on the CPU;
   c. every other instance is tested at the pyramid level where its screen rectangle spans at
      most 2x2 texels: if the box's nearest depth is farther than the farthest depth of those
      texels, everything it could draw there is hidden, and it is skipped.
3. Back faces, per triangle: a triangle of a *closed*, consistently outward-wound body faces
   away from a camera outside that body only where the body's own front faces hide it (a ray
   from outside enters a closed surface before it can leave it). :func:`closed_faces` finds
   those triangles once per mesh; the geometry pass draws them with back-face culling for the
   instances whose bounding box lies wholly in front of the camera (so the camera is outside
   every body, and no near plane cuts one open), and every other triangle without. CAD exports
   wind inconsistently and leave shells open, which is why this is decided per body, not per
   scene. About half the triangles of closed parts never reach the rasteriser, the fragments
   behind them are never depth-tested (the `line` scene's aisle view: 21 of 60 ms).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import moderngl
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from mrcheck.core.camera import Camera
from mrcheck.render.gl import color_texture, load_program

# An instance whose bounding box covers this share of the image is drawn as an occluder.
OCCLUDER_AREA = 0.005
# Each Hi-Z costs a reduction pass and a 1/64 read-back (about 2 ms at 1280x1024 here), but
# above all it stalls llvmpipe's pipeline, which otherwise shades the vertices of the next draws
# while its threads rasterise the previous ones (the geometry pass flushes every 20 k triangles
# so that they overlap): measured, two Hi-Z builds that culled nothing cost 20-25 ms on the 0.66 M
# triangles of the `line` scene's aisle view, and on the generated 20 M hall's aisle (2.2 M
# candidate triangles after level of detail) culling 4268 instances made the pass 4-7 % slower
# (212 against 198 ms), while at full detail (`--lod-px 0`, 16.7 M candidates) it made it 28 %
# faster (471 against 656 ms). Only with this many candidate triangles (after level of detail)
# is occlusion culling tried at all.
MIN_CANDIDATE_TRIANGLES = 4_000_000
HIZ_BLOCK = 8
# The candidates are drawn in this many bands of nearest depth, a Hi-Z rebuilt before each, so
# that far instances are tested against the nearer ones too, not only against the occluders
# (the generated 20 M hall's aisle: 3.3 M triangles drawn with 2 bands, 2.5 M with 4, in the
# same time, as every band costs a pipeline stall).
DEPTH_BANDS = 2


class Instanced(Protocol):
    """What culling reads of a part (the geometry pass's parts on the GPU): its instances'
    ``transforms`` (k, 4, 4) local -> world and their largest stretch ``scales`` (k,), the
    ``local_corners`` (8, 4) of its local bounds and its ``triangles`` at full detail."""

    transforms: np.ndarray
    scales: np.ndarray
    local_corners: np.ndarray

    @property
    def triangles(self) -> int: ...


@dataclass
class Batch:
    """Instances of one part that are drawn together.

    ``mv`` (k, 4, 4) float64 model-view matrices; ``z_near`` (k,) the nearest camera-space z of
    each box (<= 0: the box spans the camera plane); ``z_far`` (k,) the farthest; ``rect`` (k, 4)
    the box's screen rectangle in pixels (x0, y0, x1, y1), clipped to the image; ``scale`` (k,)
    the largest stretch of each instance's transform.
    """

    part: Instanced
    mv: np.ndarray
    z_near: np.ndarray
    z_far: np.ndarray
    rect: np.ndarray
    scale: np.ndarray

    def subset(self, keep: np.ndarray) -> "Batch":
        return Batch(self.part, self.mv[keep], self.z_near[keep], self.z_far[keep], self.rect[keep], self.scale[keep])

    def __len__(self) -> int:
        return len(self.mv)


class Boxes:
    """The world-space bounding-box corners of every instance of every part, in one array
    (built once per scene), so that the frustum test of a frame is a few array operations over
    all instances, not a loop over parts (the 20 M hall's 50 parts: 13 ms per frame before).

    Stored as three contiguous (N, 8) planes, x, y and z: the camera-space corners are then
    nine multiply-adds over whole planes, with no BLAS call. A (N * 8, 3) @ (3, 3) product
    wakes OpenBLAS's threads, which stall when the cores are busy: measured on the 20 M hall's
    14 k instances, 40 ms per frame with another process rendering, against 5-9 ms for this
    (on a quiet machine 5.5 against 5.9 ms).
    """

    def __init__(self, parts: Sequence[Instanced]):
        self.parts = parts
        counts = [len(part.transforms) for part in parts]
        self.start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        corners = [np.einsum("kij,cj->ikc", part.transforms[:, :3], part.local_corners) for part in parts]
        self.xyz = np.ascontiguousarray(np.concatenate(corners, axis=1)) if corners else np.zeros((3, 0, 8))

    def camera_space(self, V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, 8) camera-space x, y and z of every corner under the view matrix ``V``."""
        X, Y, Z = self.xyz
        return tuple(V[i, 0] * X + V[i, 1] * Y + V[i, 2] * Z + V[i, 3] for i in range(3))


def frustum(boxes: Boxes, camera: Camera) -> list[Batch]:
    """Per part of ``boxes`` (objects with ``transforms``, ``scales`` and ``local_corners``), the
    instances in the view frustum."""
    V = camera.view_matrix()
    w, h = camera.width, camera.height
    # side planes in camera space through the image corners (with a 1 px margin)
    u0, u1 = (-1.5 - camera.cx) / camera.fx, (w + 0.5 - camera.cx) / camera.fx
    v0, v1 = (-1.5 - camera.cy) / camera.fy, (h + 0.5 - camera.cy) / camera.fy
    x, y, z = boxes.camera_space(V)
    keep = ~(
        (z <= 0).all(axis=1)
        | (x < u0 * z).all(axis=1)
        | (x > u1 * z).all(axis=1)
        | (y < v0 * z).all(axis=1)
        | (y > v1 * z).all(axis=1)
    )
    kept = np.flatnonzero(keep)
    x, y, z = x[kept], y[kept], z[kept]
    z_near, z_far = z.min(axis=1), z.max(axis=1)
    # The projection of a box is the hull of its projected corners when all lie in front of
    # the camera; a box that reaches behind it may cover any pixel.
    with np.errstate(divide="ignore", invalid="ignore"):
        u = camera.fx * x / z + camera.cx
        v = camera.fy * y / z + camera.cy
    rect = np.stack([u.min(axis=1), v.min(axis=1), u.max(axis=1), v.max(axis=1)], axis=1)
    rect[z_near <= 0] = (0.0, 0.0, w, h)
    rect = np.clip(rect, 0.0, [w, h, w, h])
    batches = []
    bounds = np.searchsorted(kept, boxes.start)  # the kept instances of part i: bounds[i]:bounds[i + 1]
    for i, part in enumerate(boxes.parts):
        a, b = bounds[i], bounds[i + 1]
        if a == b:
            continue
        local = kept[a:b] - boxes.start[i]
        batches.append(Batch(part, V @ part.transforms[local], z_near[a:b], z_far[a:b], rect[a:b], part.scales[local]))
    return batches


def closed_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F,) bool: the triangles of bodies that are closed, consistently wound and outward.

    Vertices at the same position are one vertex (flat-shaded exports repeat them per face).
    A body (triangles connected through shared edges) qualifies when each of its edges is
    used exactly twice, once in each direction, and its signed volume is positive; a zero-area
    triangle is never marked (its edges prove nothing), nor is anything touching one.
    """
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    n = len(faces)
    if n == 0:
        return np.zeros(0, bool)
    points, merged = np.unique(np.asarray(vertices, np.float64), axis=0, return_inverse=True)
    f = merged.reshape(-1)[faces]
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)  # directed edges, 3 per face
    face_of = np.repeat(np.arange(n), 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    edge, edge_index, uses = np.unique(lo * len(points) + hi, return_inverse=True, return_counts=True)
    forward = np.bincount(edge_index, weights=(a < b).astype(float), minlength=len(edge))
    good_edge = (uses == 2) & (forward == 1)  # two uses, opposite directions
    bad_face = np.bincount(face_of, weights=good_edge[edge_index], minlength=n) < 3
    bad_face |= (a == b).reshape(-1, 3).any(axis=1)
    # bodies: faces and edges as nodes of one graph, joined where a face uses an edge
    graph = coo_matrix((np.ones(3 * n), (face_of, n + edge_index)), shape=(n + len(edge),) * 2)
    _, label = connected_components(graph, directed=False)
    label = label[:n]
    points = points - (points.min(axis=0) + points.max(axis=0)) / 2  # less cancellation below
    p0, p1, p2 = (points[f[:, i]] for i in range(3))
    term = np.einsum("ij,ij->i", p0, np.cross(p1, p2))  # 6x signed volume
    volume = np.bincount(label, weights=term)
    # a two-sided sheet is closed too, with no volume; its sign is float noise: not marked
    outward = volume > 1e-6 * np.bincount(label, weights=np.abs(term))
    bad_body = np.bincount(label, weights=bad_face) > 0
    return ~bad_body[label] & outward[label]


def split_occluders(batches: list[Batch], camera: Camera) -> tuple[list[Batch], list[Batch]]:
    """(occluders, candidates): instances covering >= OCCLUDER_AREA of the image, and the rest."""
    area_min = OCCLUDER_AREA * camera.width * camera.height
    occluders: list[Batch] = []
    candidates: list[Batch] = []
    for batch in batches:
        r = batch.rect
        big = ((r[:, 2] - r[:, 0]) * (r[:, 3] - r[:, 1]) >= area_min) | (batch.z_near <= 0)
        for group, mask in ((occluders, big), (candidates, ~big)):
            if mask.any():
                group.append(batch.subset(mask))
    return occluders, candidates


def depth_bands(batches: list[Batch], count: int) -> list[list[Batch]]:
    """Split ``batches`` by nearest depth into ``count`` bands of about equal triangle count,
    nearest band first (each band is tested against the Hi-Z of everything drawn before it)."""
    if not batches:
        return []
    z = np.concatenate([b.z_near for b in batches])
    weight = np.concatenate([np.full(len(b), float(b.part.triangles)) for b in batches])
    order = np.argsort(z)
    cumulative = np.cumsum(weight[order])
    cuts = np.searchsorted(cumulative, cumulative[-1] * np.arange(1, count) / count)
    edges = np.concatenate([[-np.inf], z[order][np.minimum(cuts, len(z) - 1)], [np.inf]])
    bands = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        band = [b.subset(m) for b in batches if (m := (b.z_near >= lo) & (b.z_near < hi)).any()]
        if band:
            bands.append(band)
    return bands


class HiZ:
    """Farthest-depth pyramid of a G-buffer's linear depth, for :meth:`occluded` tests."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        # one variant per sample count of the G-buffer (0: single-sampled; 4: anti-aliased)
        self.variants: dict[int, moderngl.VertexArray] = {}
        self._target: moderngl.Framebuffer | None = None
        self.levels: list[np.ndarray] = []

    def _target_for(self, size: tuple[int, int]) -> moderngl.Framebuffer:
        reduced = (-(-size[0] // HIZ_BLOCK), -(-size[1] // HIZ_BLOCK))
        if self._target is None or self._target.size != reduced:
            self.release_target()
            texture = self.ctx.texture(reduced, 1, dtype="f4")
            self._target = self.ctx.framebuffer([texture])
        return self._target

    def _variant(self, samples: int) -> moderngl.VertexArray:
        if samples not in self.variants:
            program = load_program(self.ctx, "hiz_reduce", {"HIZ_BLOCK": HIZ_BLOCK, "MSAA": samples})
            program["u_depth"] = 0
            self.variants[samples] = self.ctx.vertex_array(program, [])
        return self.variants[samples]

    def build(self, depth: moderngl.Texture, samples: int = 0) -> None:
        """Reduce ``depth`` (R32F linear z, 0 = background; ``samples`` > 1: multisampled, the
        farthest sample counts) on the GPU, read back, build the pyramid."""
        target = self._target_for(depth.size)
        target.use()
        depth.use(0)
        self._variant(samples if samples > 1 else 0).render(moderngl.TRIANGLES, vertices=3)
        w, h = target.size
        level = np.frombuffer(color_texture(target).read(), np.float32).reshape(h, w)
        self.levels = [level]
        while max(level.shape) > 1:
            h, w = level.shape
            # padding counts as infinitely far: outside the image nothing is hidden
            level = np.pad(level, ((0, h % 2), (0, w % 2)), constant_values=np.inf)
            level = level.reshape(level.shape[0] // 2, 2, level.shape[1] // 2, 2).max(axis=(1, 3))
            self.levels.append(level)

    def occluded(self, rect: np.ndarray, z_near: np.ndarray) -> np.ndarray:
        """(k,) bool: boxes with screen ``rect`` (pixels) whose nearest depth is behind everything drawn."""
        h, w = self.levels[0].shape
        # pixels a fragment of the box may touch, as block indices (rounded outwards)
        b = np.floor(rect / HIZ_BLOCK).astype(np.int64)
        b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0, w - 1)
        b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0, h - 1)
        span = np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])
        # the level where the rectangle spans at most 2x2 texels: span < 2**L
        level = np.minimum(np.ceil(np.log2(span + 1.0)).astype(np.int64), len(self.levels) - 1)
        far = np.empty(len(rect), np.float32)
        for L in np.unique(level):
            i = np.flatnonzero(level == L)
            x0, y0, x1, y1 = (b[i, k] >> L for k in range(4))
            grid = self.levels[L]
            far[i] = np.maximum.reduce([grid[y0, x0], grid[y0, x1], grid[y1, x0], grid[y1, x1]])
        return z_near > far

    def release_target(self) -> None:
        if self._target is not None:
            self._target.color_attachments[0].release()
            self._target.release()
            self._target = None

    def release(self) -> None:
        self.release_target()
        for vao in self.variants.values():
            vao.release()
        self.variants.clear()


__all__ = [
    "Batch",
    "Boxes",
    "Instanced",
    "HiZ",
    "closed_faces",
    "frustum",
    "split_occluders",
    "OCCLUDER_AREA",
    "MIN_CANDIDATE_TRIANGLES",
]
