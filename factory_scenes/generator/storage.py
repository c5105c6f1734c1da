"""Storage: EUR pallets, their loads (carton stacks, crates) and adjustable pallet racking.

Units and frames: metres, Z up, floor at z = 0. A pallet and its load share one frame (long
side along x, origin at the centre of the footprint on the floor), so a load is placed with
the same instance transforms as its pallet. A rack bay's frame: the row runs along +x from
its upright frame at x = 0 to the next one at x = RACK_BAY_PITCH, the aisle (front) side is -y.
"""

from __future__ import annotations

import numpy as np
import trimesh

from .detail import SAMPLE_DETAIL, Detail
from .geometry import (
    anchor_bolt,
    bar_between,
    box_between,
    combine,
    grid_box,
    rotation_z,
    transformed,
    translation,
)

PALLET_HEIGHT = 0.144  # m, EUR pallet (EN 13698-1)
CARTON_SIZE = 0.38  # m, edge of a carton in plan
CARTON_HEIGHT = 0.28  # m
RACK_DEPTH = 1.1  # m, upright frame depth (front post to back post, outside)
RACK_POST = 0.09  # m, upright post width along the row
RACK_BEAM_HEIGHT = 0.12  # m, box beam section height
RACK_BAY_PITCH = 2.8  # m, upright to upright: 2.7 m clear beam, three EUR pallets crosswise
RACK_SLOTS = (-0.9, 0.0, 0.9)  # m, pallet centres across a bay, from its middle


def eur_pallet(detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """EUR pallet 1.2 x 0.8 x 0.144 m: 5 top boards, 3 cross boards, 9 blocks, 3 bottom boards.

    Long side along x, origin at the centre of the footprint on the floor. The coarsest level
    keeps the silhouette only: a deck, three rows of blocks and three bottom boards.
    """
    board, block_h = 0.022, 0.078
    z_block, z_cross, z_top = board, board + block_h, 2 * board + block_h
    pieces = []
    if detail.level == 0:
        pieces.append(box_between((-0.6, -0.4, z_top), (0.6, 0.4, PALLET_HEIGHT)))
        for yc, wy in ((-0.35, 0.100), (0.0, 0.145), (0.35, 0.100)):
            pieces.append(box_between((-0.6, yc - wy / 2, z_block), (0.6, yc + wy / 2, z_top)))
            pieces.append(box_between((-0.6, yc - wy / 2, 0.0), (0.6, yc + wy / 2, board)))
        return combine(pieces)
    top_widths = (0.145, 0.100, 0.145, 0.100, 0.145)
    gap = (0.8 - sum(top_widths)) / (len(top_widths) - 1)
    y = -0.4
    for w in top_widths:  # top deck boards along x
        pieces.append(box_between((-0.6, y, z_top), (0.6, y + w, PALLET_HEIGHT)))
        y += w + gap
    for x in (-0.5275, 0.0, 0.5275):  # cross boards along y
        pieces.append(box_between((x - 0.0725, -0.4, z_cross), (x + 0.0725, 0.4, z_top)))
        for yc, wy in ((-0.35, 0.100), (0.0, 0.145), (0.35, 0.100)):  # blocks
            pieces.append(box_between((x - 0.0725, yc - wy / 2, z_block), (x + 0.0725, yc + wy / 2, z_cross)))
    for yc, wy in ((-0.35, 0.100), (0.0, 0.145), (0.35, 0.100)):  # bottom boards along x
        pieces.append(box_between((-0.6, yc - wy / 2, 0.0), (0.6, yc + wy / 2, board)))
    return combine(pieces)


def carton_stack(layers, extra, rng, detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """Cartons 0.38 x 0.38 x 0.28 m stacked 3 x 2 per layer on a EUR pallet deck.

    ``layers`` full layers plus ``extra`` cartons on the next one. Authored in the
    pallet's frame (bottom at the deck, z = 0.144) so it shares the pallet instances'
    transforms. A little jitter from ``rng``, because real stacks are never perfect and
    uneven joints give the occlusion varied gap widths. Carton faces are split into
    ``detail.carton_divisions`` squared quads.
    """
    size, height = CARTON_SIZE, CARTON_HEIGHT
    slots = [(x, y) for x in (-0.4, 0.0, 0.4) for y in (-0.2, 0.2)]
    pieces = []
    for level in range(layers + 1):
        count = len(slots) if level < layers else extra
        for x, y in slots[:count]:
            dx, dy = rng.uniform(-0.003, 0.003, size=2)
            angle = np.radians(rng.uniform(-1.0, 1.0))
            z = PALLET_HEIGHT + level * height
            carton = grid_box((-size / 2, -size / 2, 0.0), (size / 2, size / 2, height), detail.carton_divisions)
            pieces.append(transformed(carton, translation(x + dx, y + dy, z) @ rotation_z(angle)))
    return combine(pieces)


def crate_load(detail: Detail) -> trimesh.Trimesh:
    """Wooden crate 1.16 x 0.76 x 0.7 m on a pallet deck: box with frame battens, lid cleats.

    Same frame as :func:`eur_pallet`; the battens stand 12 mm proud of the sides, which gives
    the narrow creases AO picks up. The sides are subdivided like carton faces.
    """
    z0, z1, hx, hy, t = PALLET_HEIGHT, PALLET_HEIGHT + 0.7, 0.58, 0.38, 0.012
    pieces = [grid_box((-hx, -hy, z0), (hx, hy, z1), detail.carton_divisions)]
    for z in (z0 + 0.05, z1 - 0.05):  # horizontal battens all round
        pieces.append(box_between((-hx - t, -hy - t, z - 0.04), (hx + t, -hy, z + 0.04)))
        pieces.append(box_between((-hx - t, hy, z - 0.04), (hx + t, hy + t, z + 0.04)))
        pieces.append(box_between((-hx - t, -hy, z - 0.04), (-hx, hy, z + 0.04)))
        pieces.append(box_between((hx, -hy, z - 0.04), (hx + t, hy, z + 0.04)))
    for sx in (-1.0, 1.0):  # corner posts
        for sy in (-1.0, 1.0):
            pieces.append(box_between((sx * (hx + t), sy * (hy + t), z0), (sx * (hx - 0.06), sy * (hy - 0.06), z1)))
    for x in (-0.35, 0.0, 0.35):  # lid cleats
        pieces.append(box_between((x - 0.04, -hy, z1), (x + 0.04, hy, z1 + 0.02)))
    return combine(pieces)


def _upright_frame(height, detail: Detail) -> list[trimesh.Trimesh]:
    """Upright frame in the y-z plane at x = 0: two posts, zig-zag bracing, base plates."""
    hd, hp = RACK_DEPTH / 2.0, RACK_POST / 2.0
    post_d = 0.07  # post depth across the row (y)
    pieces = []
    for y in (-hd + post_d / 2, hd - post_d / 2):
        pieces.append(box_between((-hp, y - post_d / 2, 0.0), (hp, y + post_d / 2, height)))
        pieces.append(box_between((-hp - 0.02, y - 0.07, 0.0), (hp + 0.02, y + 0.07, 0.008)))  # base plate
        if detail.bolts:
            pieces += anchor_bolt(0.0, y - 0.05 * np.sign(y), 0.008, 0.6, detail.sections)
    y_front, y_back = -hd + post_d, hd - post_d  # inner faces of the posts
    pieces.append(bar_between((0.0, y_front, 0.15), (0.0, y_back, 0.15), 0.03, 0.03))  # bottom horizontal
    pieces.append(bar_between((0.0, y_front, height - 0.1), (0.0, y_back, height - 0.1), 0.03, 0.03))
    z, step, flip = 0.15, 1.0 if detail.truss_bays else height, False
    while z + 0.2 < height - 0.1:  # diagonal bracing, zig-zag up the frame
        z1 = min(z + step, height - 0.1)
        a, b = (y_front, y_back) if not flip else (y_back, y_front)
        pieces.append(bar_between((0.0, a, z), (0.0, b, z1), 0.03, 0.025))
        z, flip = z1, not flip
    return pieces


def rack_frame(height, detail: Detail) -> trimesh.Trimesh:
    """One upright frame of pallet racking in the y-z plane at x = 0, ``height`` m tall.

    A row of n bays stands on n + 1 frames, RACK_BAY_PITCH apart.
    """
    return combine(_upright_frame(height, detail))


def rack_beams(beam_levels, detail: Detail) -> trimesh.Trimesh:
    """The beam pairs of one rack bay, between its frames at x = 0 and RACK_BAY_PITCH.

    ``beam_levels`` are the beam tops in metres (pallets stand on them); box beams 50 mm wide,
    front (aisle side, -y) and back, with connector plates at both ends.
    """
    hd, hp = RACK_DEPTH / 2.0, RACK_POST / 2.0
    x0, x1 = hp, RACK_BAY_PITCH - hp
    pieces = []
    for z in beam_levels:
        for y in (-hd, hd - 0.05):
            pieces.append(box_between((x0, y, z - RACK_BEAM_HEIGHT), (x1, y + 0.05, z)))
            if detail.bolts:
                for x in (x0, x1 - 0.012):
                    pieces.append(
                        box_between((x, y - 0.004, z - RACK_BEAM_HEIGHT - 0.03), (x + 0.012, y + 0.054, z + 0.01))
                    )
    return combine(pieces)


def rack_guard(detail: Detail) -> trimesh.Trimesh:
    """Row-end protector: two posts on base plates and a rail, 0.4 m tall, across the row
    end (along y, centred on y = 0), standing 0.15 m out from the end frame at x = 0."""
    hd = RACK_DEPTH / 2.0 + 0.05
    pieces = [box_between((-0.23, -hd, 0.25), (-0.15, hd, 0.4))]  # rail
    for y in (-hd + 0.05, hd - 0.05):
        pieces.append(box_between((-0.23, y - 0.04, 0.0), (-0.15, y + 0.04, 0.4)))
        pieces.append(box_between((-0.26, y - 0.09, 0.0), (-0.12, y + 0.09, 0.01)))
        if detail.bolts:
            pieces += anchor_bolt(-0.19, y - 0.065 * np.sign(y), 0.01, 0.6, detail.sections)
    return combine(pieces)


__all__ = [
    "PALLET_HEIGHT",
    "RACK_DEPTH",
    "RACK_BAY_PITCH",
    "RACK_SLOTS",
    "RACK_BEAM_HEIGHT",
    "eur_pallet",
    "carton_stack",
    "crate_load",
    "rack_frame",
    "rack_beams",
    "rack_guard",
]
