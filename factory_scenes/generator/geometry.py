"""Primitive solids for part meshes: boxes, cylinders, oriented bars, steel sections, bolts.

Every builder returns a closed ``trimesh.Trimesh`` in the caller's units (the part builders
work in metres, the roller conveyor in millimetres). Parts are unions of such closed pieces
that may touch or overlap; no booleans are computed, because screen-space AO only needs the
visible surfaces, and the creases where pieces meet are what it darkens.
"""

from __future__ import annotations

import numpy as np
import trimesh


def box_between(a, b) -> trimesh.Trimesh:
    """Axis-aligned box spanning two opposite corners, given in any order.

    Accepting unordered corners lets mirrored pieces be written as ``s * x`` with
    ``s`` = -1 or +1 instead of sorting every coordinate pair.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return trimesh.creation.box(bounds=np.array([np.minimum(a, b), np.maximum(a, b)]))


def box_at(center, size) -> trimesh.Trimesh:
    """Axis-aligned box of extents ``size`` centred on ``center``."""
    half = np.asarray(size, dtype=float) / 2.0
    center = np.asarray(center, dtype=float)
    return box_between(center - half, center + half)


def grid_box(a, b, divisions: int) -> trimesh.Trimesh:
    """Axis-aligned box like :func:`box_between` whose faces are ``divisions`` x ``divisions`` grids.

    The extra triangles are the "box subdivision" knob of the scene generator's triangle
    budget (a tessellated CAD export of a carton looks like this). ``divisions`` = 1 is
    exactly :func:`box_between`.
    """
    if divisions <= 1:
        return box_between(a, b)
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    n = int(divisions)
    t = np.linspace(0.0, 1.0, n + 1)
    u, v = np.meshgrid(t, t, indexing="ij")
    cell = np.arange(n + 1) * (n + 1)
    i00 = (cell[:-1, None] + np.arange(n)[None, :]).ravel()  # lower-left corner of each cell
    quads = np.stack([i00, i00 + n + 1, i00 + n + 2, i00 + 1], axis=1)
    grid_faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    vertices, faces = [], []
    for axis in range(3):
        p, q = (axis + 1) % 3, (axis + 2) % 3  # (p, q, axis) is right-handed
        for side, value in ((0, lo[axis]), (1, hi[axis])):
            grid = np.empty(((n + 1) ** 2, 3))
            grid[:, axis] = value
            grid[:, p] = lo[p] + u.ravel() * (hi[p] - lo[p])
            grid[:, q] = lo[q] + v.ravel() * (hi[q] - lo[q])
            f = grid_faces if side == 1 else grid_faces[:, ::-1]  # outward winding
            faces.append(f + sum(len(x) for x in vertices))
            vertices.append(grid)
    return trimesh.Trimesh(np.concatenate(vertices), np.concatenate(faces), process=False)


def cylinder_between(p0, p1, radius, sections=16) -> trimesh.Trimesh:
    """Closed cylinder whose axis runs from ``p0`` to ``p1``."""
    return trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1], dtype=float), sections=sections)


def bar_between(p0, p1, width, height=None) -> trimesh.Trimesh:
    """Rectangular bar (``width`` x ``height`` section) whose axis runs from ``p0`` to ``p1``.

    For members that are not axis-aligned (truss diagonals, rack bracing, stair stringers).
    The section's ``height`` side lies in the vertical plane through the axis, so bracing in
    a vertical plane keeps its faces in that plane; a vertical axis puts ``height`` along x.
    """
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    w = axis / length
    side = np.cross(w, (0.0, 0.0, 1.0))
    if np.linalg.norm(side) < 1e-9:  # vertical bar
        side = np.array([0.0, 1.0, 0.0])
    u = side / np.linalg.norm(side)  # horizontal, across the bar: width
    v = np.cross(w, u)  # in the vertical plane: height
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = u, v, w
    frame[:3, 3] = (p0 + p1) / 2.0
    height = width if height is None else height
    return trimesh.creation.box(extents=(width, height, length), transform=frame)


def combine(pieces) -> trimesh.Trimesh:
    """One mesh from many closed sub-pieces (they may touch or overlap; no booleans)."""
    return trimesh.util.concatenate(list(pieces))


def transformed(mesh: trimesh.Trimesh, matrix) -> trimesh.Trimesh:
    """Copy of ``mesh`` moved by a 4x4 ``matrix``."""
    out = mesh.copy()
    out.apply_transform(matrix)
    return out


def translation(x, y, z) -> np.ndarray:
    return trimesh.transformations.translation_matrix((x, y, z))


def rotation_z(angle_rad) -> np.ndarray:
    return trimesh.transformations.rotation_matrix(angle_rad, (0.0, 0.0, 1.0))


# Maps an object built along local +z onto world +x, with local +y becoming world +z:
# lets i_profile() serve both columns (vertical) and beams (horizontal).
Z_TO_X = np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float)
# Maps local +z onto world +y, local +y onto world +z (a beam along y; local x becomes -x).
Z_TO_Y = np.array([[-1, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float)


def anchor_bolt(x, y, z, size=1.0, sections=16) -> list[trimesh.Trimesh]:
    """Washer, hex nut and protruding thread of an anchor bolt on a plate whose top is z.

    ``size`` = 1 is roughly an M20 bolt in metres; the small stacked cylinders give the
    tight creases around base plates that SSAO should darken. ``sections`` rounds the
    washer (the thread gets three quarters of it; the nut is always a hexagon).
    """
    s = size
    return [
        cylinder_between((x, y, z), (x, y, z + 0.004 * s), 0.020 * s, sections=sections),  # washer
        cylinder_between((x, y, z + 0.004 * s), (x, y, z + 0.020 * s), 0.017 * s, sections=6),  # nut
        cylinder_between((x, y, z + 0.020 * s), (x, y, z + 0.040 * s), 0.010 * s, sections=sections * 3 // 4),  # thread
    ]


def bolt_pattern(half_spacing, z, size=1.0, sections=16) -> list[trimesh.Trimesh]:
    """Four anchor bolts on the corners of a square of side 2 * ``half_spacing``."""
    pieces = []
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            pieces += anchor_bolt(sx * half_spacing, sy * half_spacing, z, size, sections)
    return pieces


def i_profile(length, depth, width, web, flange) -> trimesh.Trimesh:
    """I-section (flanges + web as boxes) running along local +z from 0 to ``length``.

    The flanges are normal to y (``depth`` is measured along y), the web lies in the
    y-z plane. Dimensions as for a rolled section, e.g. HEB 300: 0.3, 0.3, 0.011, 0.019.
    """
    hd, hw = depth / 2.0, width / 2.0
    return combine(
        [
            box_between((-hw, hd - flange, 0.0), (hw, hd, length)),
            box_between((-hw, -hd, 0.0), (hw, -hd + flange, length)),
            box_between((-web / 2.0, -hd + flange, 0.0), (web / 2.0, hd - flange, length)),
        ]
    )


def rect_minus(outer, holes) -> list[tuple[float, float, float, float]]:
    """Rectangles (x0, y0, x1, y1) that tile ``outer`` minus the axis-aligned ``holes``.

    Grid decomposition on every hole edge, cells merged along x within a row: a floor slab
    around pits, a wall around its door and windows.
    """
    x0, y0, x1, y1 = outer
    holes = [(max(a, x0), max(b, y0), min(c, x1), min(d, y1)) for a, b, c, d in holes]
    holes = [h for h in holes if h[0] < h[2] and h[1] < h[3]]
    xs = sorted({x0, x1, *[h[0] for h in holes], *[h[2] for h in holes]})
    ys = sorted({y0, y1, *[h[1] for h in holes], *[h[3] for h in holes]})
    rects = []
    for ya, yb in zip(ys, ys[1:]):
        run = None
        for xa, xb in zip(xs, xs[1:]):
            cx, cy = (xa + xb) / 2.0, (ya + yb) / 2.0
            solid = not any(h[0] < cx < h[2] and h[1] < cy < h[3] for h in holes)
            if solid and run is not None:
                run[2] = xb
            elif solid:
                run = [xa, ya, xb, yb]
            if not solid and run is not None:
                rects.append(tuple(run))
                run = None
        if run is not None:
            rects.append(tuple(run))
    return rects


__all__ = [
    "box_between",
    "box_at",
    "grid_box",
    "cylinder_between",
    "bar_between",
    "combine",
    "transformed",
    "translation",
    "rotation_z",
    "Z_TO_X",
    "Z_TO_Y",
    "anchor_bolt",
    "bolt_pattern",
    "i_profile",
    "rect_minus",
]
