"""Generate the embedded sample scene ``factory_scenes/sample_cell/``.

The scene is a small factory cell (floor slab 24 m x 16 m, steel hall frame 6 m high)
made for screen-space ambient occlusion: almost every part is a cluster of boxes and
cylinders that meet in concave creases, with small detail (bolts, nuts, rollers, welded
mesh wires, pallet slats, carton joints) next to large flat areas (floor, back wall).

Conventions: Z is up, world units are metres, the floor's top face is z = 0 and the cell
is centred on the world origin. Each part mesh is authored in its own frame (usually
origin at the centre of its footprint, on the floor; each builder's docstring says where)
and placed by the manifest's ``translate`` / ``rotate_deg`` or per-instance transforms.
The roller conveyor is deliberately authored in millimetres (``units = "mm"``) so that
the scene mixes CAD unit scales.

Run ``python factory_scenes/build_sample_cell.py``. It overwrites, next to itself::

    sample_cell/scene.toml             the manifest (format 1)
    sample_cell/meshes/*.glb           one mesh per part
    sample_cell/robots/kuka_iiwa/      KUKA LBR iiwa URDF + OBJ visuals from pybullet_data
    sample_cell/README.md

The output is deterministic (fixed dimensions, fixed seed for the carton jitter), so two
runs give byte-identical files.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

OUT_DIR = Path(__file__).resolve().parent / "sample_cell"
# the shared data folder sits beside the repository checkout: ../shared/data/
DEFAULT_PYBULLET_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "robots" / "pybullet_data"
ROBOT_DIR = "robots/kuka_iiwa"

SEED = 1234                # carton jitter; fixed so rebuilds are byte-identical
CREASE_ANGLE_DEG = 40.0    # sharper edges get split (flat) normals; 16-sided cylinders stay smooth
MAX_TRIANGLES = 200_000    # budget for the whole scene, instances included

# Layout of the cell, metres (world frame). Shared by several parts, so named once.
COLUMN_GRID_X = (-9.0, 0.0, 9.0)
COLUMN_GRID_Y = (-7.0, 7.0)                   # rows close to the slab edges keep views open
COLUMN_HEIGHT = 6.0
FENCE_RECT = (0.5, -5.0, 5.5, 0.0)            # x0, y0, x1, y1 of the robot cell fence
FENCE_PITCH = 1.0                             # post spacing
FENCE_OPENINGS = ((0.5, -2.5), (3.0, -5.0))   # panel midpoints left open: conveyor, door
ROBOT_XY = (3.0, -2.5)
PEDESTAL_TOP = 0.70
CONVEYOR_START = (-5.8, -2.5)                 # world x, y of the conveyor's upstream end
PALLET_HEIGHT = 0.144                         # EUR pallet, EN 13698-1


# --------------------------------------------------------------------------------------
# Primitive helpers
# --------------------------------------------------------------------------------------

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


def cylinder_between(p0, p1, radius, sections=16) -> trimesh.Trimesh:
    """Closed cylinder whose axis runs from ``p0`` to ``p1``."""
    return trimesh.creation.cylinder(
        radius=radius, segment=np.array([p0, p1], dtype=float), sections=sections
    )


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


def anchor_bolt(x, y, z, size=1.0) -> list[trimesh.Trimesh]:
    """Washer, hex nut and protruding thread of an anchor bolt on a plate whose top is z.

    ``size`` = 1 is roughly an M20 bolt in metres; the small stacked cylinders give the
    tight creases around base plates that SSAO should darken.
    """
    s = size
    return [
        cylinder_between((x, y, z), (x, y, z + 0.004 * s), 0.020 * s, sections=16),  # washer
        cylinder_between((x, y, z + 0.004 * s), (x, y, z + 0.020 * s), 0.017 * s, sections=6),  # nut
        cylinder_between((x, y, z + 0.020 * s), (x, y, z + 0.040 * s), 0.010 * s, sections=12),  # thread
    ]


def bolt_pattern(half_spacing, z, size=1.0) -> list[trimesh.Trimesh]:
    """Four anchor bolts on the corners of a square of side 2 * ``half_spacing``."""
    pieces = []
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            pieces += anchor_bolt(sx * half_spacing, sy * half_spacing, z, size)
    return pieces


def i_profile(length, depth, width, web, flange) -> trimesh.Trimesh:
    """I-section (flanges + web as boxes) running along local +z from 0 to ``length``.

    The flanges are normal to y (``depth`` is measured along y), the web lies in the
    y-z plane. Dimensions as for a rolled section, e.g. HEB 300: 0.3, 0.3, 0.011, 0.019.
    """
    hd, hw = depth / 2.0, width / 2.0
    return combine([
        box_between((-hw, hd - flange, 0.0), (hw, hd, length)),
        box_between((-hw, -hd, 0.0), (hw, -hd + flange, length)),
        box_between((-web / 2.0, -hd + flange, 0.0), (web / 2.0, hd - flange, length)),
    ])


# --------------------------------------------------------------------------------------
# Parts (metres unless stated otherwise)
# --------------------------------------------------------------------------------------

def floor_slab() -> trimesh.Trimesh:
    """Concrete slab 24 x 16 x 0.2 m, top face at z = 0."""
    return box_between((-12.0, -8.0, -0.2), (12.0, 8.0, 0.0))


def back_wall(length=22.0, height=3.0) -> trimesh.Trimesh:
    """Low clad wall as a backdrop: concrete plinth, ribbed sheet cladding, coping.

    Local frame: wall runs along x, its front face looks towards -y, origin at the
    middle of the front foot. The ribs (every 0.3 m) give a regular row of creases.
    """
    hl = length / 2.0
    pieces = [
        box_between((-hl, 0.0, 0.0), (hl, 0.2, height)),                # wall body
        box_between((-hl, -0.1, 0.0), (hl, 0.0, 0.4)),                  # plinth step
        box_between((-hl, -0.06, height), (hl, 0.26, height + 0.06)),   # coping
    ]
    for x in np.arange(-hl + 0.15, hl, 0.3):
        pieces.append(box_between((x - 0.03, -0.04, 0.4), (x + 0.03, 0.0, height)))
    return combine(pieces)


def steel_column(height=COLUMN_HEIGHT) -> trimesh.Trimesh:
    """HEB 300 column on a 0.5 m base plate with 4 anchor bolts and base stiffeners."""
    plate, cap = 0.03, 0.02
    web = 0.011
    pieces = [
        box_between((-0.25, -0.25, 0.0), (0.25, 0.25, plate)),                 # base plate
        transformed(i_profile(height - plate - cap, 0.3, 0.3, web, 0.019), translation(0, 0, plate)),
        box_between((-0.17, -0.17, height - cap), (0.17, 0.17, height)),       # cap plate
    ]
    # Stiffeners: in both channels of the I (perpendicular to the web) and outside both
    # flanges (in line with the web) -- the classic welded column foot.
    for s in (-1.0, 1.0):
        pieces.append(box_between((s * web / 2.0, -0.006, plate), (s * 0.15, 0.006, plate + 0.2)))
        pieces.append(box_between((-0.006, s * 0.15, plate), (0.006, s * 0.24, plate + 0.15)))
    pieces += bolt_pattern(0.2, plate)
    return combine(pieces)


def hall_beam(length=18.3) -> trimesh.Trimesh:
    """HEB 400 roof beam along x resting on the column caps; origin at its bottom centre."""
    beam = transformed(i_profile(length, 0.4, 0.3, 0.0135, 0.024), Z_TO_X)
    return transformed(beam, translation(-length / 2.0, 0.0, 0.2))


def roller_conveyor() -> trimesh.Trimesh:
    """8 m roller conveyor, authored in MILLIMETRES (the manifest declares units = "mm").

    Local frame: flow along +x from x = 0 to 8000, centreline y = 0, floor z = 0.
    Rollers: 80 x diameter 60 on a 100 pitch, top of rollers at 800; C-channel side
    frames with outward flanges, leg stations with cross braces and levelling feet,
    and a gear motor under the downstream end.
    """
    length, pitch, roller_r, axis_z = 8000.0, 100.0, 30.0, 770.0
    inner = 300.0                         # inner face of the side frame webs
    pieces = []
    for s in (-1.0, 1.0):                 # side frames: web + top and bottom flange
        web, lip = s * (inner + 4.0), s * (inner + 50.0)
        pieces.append(box_between((0.0, s * inner, 680.0), (length, web, 790.0)))
        pieces.append(box_between((0.0, web, 786.0), (length, lip, 790.0)))
        pieces.append(box_between((0.0, web, 680.0), (length, lip, 684.0)))
    for x in np.arange(pitch / 2.0, length, pitch):
        pieces.append(cylinder_between((x, -295.0, axis_z), (x, 295.0, axis_z), roller_r, 16))
        pieces.append(cylinder_between((x, -inner - 6.0, axis_z), (x, inner + 6.0, axis_z), 6.0, 8))
    for x in (20.0, length - 20.0):      # end cross members below the first/last roller
        pieces.append(box_between((x - 20.0, -inner, 690.0), (x + 20.0, inner, 730.0)))
    for x in (100.0, 2000.0, 4000.0, 6000.0, 7900.0):   # leg stations
        for s in (-1.0, 1.0):
            y = s * 327.0
            pieces.append(box_at((x, y, 355.0), (50.0, 50.0, 650.0)))             # leg
            pieces.append(cylinder_between((x, y, 10.0), (x, y, 30.0), 12.0, 12))  # levelling screw
            pieces.append(box_at((x, y, 5.0), (120.0, 120.0, 10.0)))               # foot plate
        pieces.append(box_at((x, 0.0, 200.0), (40.0, 604.0, 40.0)))                # cross brace
    # Gear motor hanging under the downstream end: box gearbox + cylindrical motor.
    pieces.append(box_between((6950.0, -inner, 660.0), (7050.0, inner, 680.0)))    # mount
    pieces.append(box_between((6900.0, -125.0, 480.0), (7100.0, 125.0, 660.0)))    # gearbox
    pieces.append(cylinder_between((7100.0, 0.0, 570.0), (7400.0, 0.0, 570.0), 75.0, 16))
    return combine(pieces)


def eur_pallet() -> trimesh.Trimesh:
    """EUR pallet 1.2 x 0.8 x 0.144 m: 5 top boards, 3 cross boards, 9 blocks, 3 bottom boards.

    Long side along x, origin at the centre of the footprint on the floor.
    """
    board, block_h = 0.022, 0.078
    z_block, z_cross, z_top = board, board + block_h, 2 * board + block_h
    pieces = []
    top_widths = (0.145, 0.100, 0.145, 0.100, 0.145)
    gap = (0.8 - sum(top_widths)) / (len(top_widths) - 1)
    y = -0.4
    for w in top_widths:                                   # top deck boards along x
        pieces.append(box_between((-0.6, y, z_top), (0.6, y + w, PALLET_HEIGHT)))
        y += w + gap
    for x in (-0.5275, 0.0, 0.5275):                       # cross boards along y
        pieces.append(box_between((x - 0.0725, -0.4, z_cross), (x + 0.0725, 0.4, z_top)))
        for yc, wy in ((-0.35, 0.100), (0.0, 0.145), (0.35, 0.100)):   # blocks
            pieces.append(box_between((x - 0.0725, yc - wy / 2, z_block), (x + 0.0725, yc + wy / 2, z_cross)))
    for yc, wy in ((-0.35, 0.100), (0.0, 0.145), (0.35, 0.100)):       # bottom boards along x
        pieces.append(box_between((-0.6, yc - wy / 2, 0.0), (0.6, yc + wy / 2, board)))
    return combine(pieces)


def carton_stack(layers, extra, rng) -> trimesh.Trimesh:
    """Cartons 0.38 x 0.38 x 0.28 m stacked 3 x 2 per layer on a EUR pallet deck.

    ``layers`` full layers plus ``extra`` cartons on the next one. Authored in the
    pallet's frame (bottom at the deck, z = 0.144) so it shares the pallet instances'
    transforms. A little jitter, because real stacks are never perfect and uneven
    joints give the occlusion varied gap widths.
    """
    size, height = 0.38, 0.28
    slots = [(x, y) for x in (-0.4, 0.0, 0.4) for y in (-0.2, 0.2)]
    pieces = []
    for level in range(layers + 1):
        count = len(slots) if level < layers else extra
        for x, y in slots[:count]:
            dx, dy = rng.uniform(-0.003, 0.003, size=2)
            angle = np.radians(rng.uniform(-1.0, 1.0))
            z = PALLET_HEIGHT + level * height
            carton = box_between((-size / 2, -size / 2, 0.0), (size / 2, size / 2, height))
            pieces.append(transformed(carton, translation(x + dx, y + dy, z) @ rotation_z(angle)))
    return combine(pieces)


def fence_post(height=2.2) -> trimesh.Trimesh:
    """60 x 60 mm square tube post with cap, on a base plate with two anchor bolts."""
    pieces = [
        box_between((-0.08, -0.08, 0.0), (0.08, 0.08, 0.01)),
        box_between((-0.03, -0.03, 0.01), (0.03, 0.03, height)),
        box_between((-0.035, -0.035, height), (0.035, 0.035, height + 0.006)),
    ]
    pieces += anchor_bolt(-0.055, -0.055, 0.01, size=0.6)
    pieces += anchor_bolt(0.055, 0.055, 0.01, size=0.6)
    return combine(pieces)


def fence_panel(pitch=FENCE_PITCH, z0=0.15, z1=2.05) -> trimesh.Trimesh:
    """Welded-mesh guard panel between two posts ``pitch`` apart, in the x-z plane.

    Tube frame plus a grid of 4 x 5 mm bars (vertical every 50 mm behind, horizontal
    every 100 mm in front, touching at y = 0 like welded wires), and four brackets that
    reach the post faces. Centred on x = 0.
    """
    hw = pitch / 2.0 - 0.04                 # 30 mm post half-width + 10 mm clearance
    t = 0.02                                # frame tube section
    pieces = [
        box_between((-hw, -t / 2, z0), (-hw + t, t / 2, z1)),
        box_between((hw - t, -t / 2, z0), (hw, t / 2, z1)),
        box_between((-hw + t, -t / 2, z0), (hw - t, t / 2, z0 + t)),
        box_between((-hw + t, -t / 2, z1 - t), (hw - t, t / 2, z1)),
    ]
    for x in np.arange(-hw + t + 0.03, hw - t, 0.05):
        pieces.append(box_between((x - 0.002, -0.005, z0 + t), (x + 0.002, 0.0, z1 - t)))
    for z in np.arange(z0 + t + 0.07, z1 - t, 0.1):
        pieces.append(box_between((-hw + t, 0.0, z - 0.002), (hw - t, 0.005, z + 0.002)))
    for s in (-1.0, 1.0):
        for z in (z0 + 0.25, z1 - 0.25):
            inner_x, post_face_x = s * (hw - 0.005), s * (pitch / 2.0 - 0.03)
            pieces.append(box_between((inner_x, -0.01, z - 0.02), (post_face_x, 0.01, z + 0.02)))
    return combine(pieces)


def fence_layout(rect=FENCE_RECT, pitch=FENCE_PITCH, openings=FENCE_OPENINGS):
    """Post positions and panel placements (midpoint, heading in degrees) around ``rect``.

    Panels whose midpoint is listed in ``openings`` are left out (conveyor pass-through,
    door); the posts on both sides of an opening stay.
    """
    x0, y0, x1, y1 = rect
    corners = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    posts, panels = [], []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        n = int(round(np.linalg.norm(b - a) / pitch))
        heading = np.degrees(np.arctan2(*(b - a)[::-1]))
        for k in range(n):
            posts.append(a + (b - a) * k / n)
            mid = a + (b - a) * (k + 0.5) / n
            if not any(np.allclose(mid, o) for o in openings):
                panels.append((mid, heading))
    return posts, panels


def robot_pedestal() -> trimesh.Trimesh:
    """Welded steel pedestal, top plate at PEDESTAL_TOP, with anchor and robot bolts."""
    plate = 0.03
    pieces = [
        box_between((-0.4, -0.4, 0.0), (0.4, 0.4, plate)),
        box_between((-0.25, -0.25, plate), (0.25, 0.25, PEDESTAL_TOP - plate)),
        box_between((-0.3, -0.3, PEDESTAL_TOP - plate), (0.3, 0.3, PEDESTAL_TOP)),
    ]
    for s in (-1.0, 1.0):                  # gussets on all four faces
        pieces.append(box_between((s * 0.25, -0.008, plate), (s * 0.38, 0.008, plate + 0.25)))
        pieces.append(box_between((-0.008, s * 0.25, plate), (0.008, s * 0.38, plate + 0.25)))
    pieces += bolt_pattern(0.33, plate)
    pieces += bolt_pattern(0.24, PEDESTAL_TOP, size=0.7)
    return combine(pieces)


def workbench() -> trimesh.Trimesh:
    """Steel workbench 2.0 x 0.8 m, worktop at 0.9 m, front towards -y.

    Legs, rails, lower shelf, drawer unit, pegboard with a shelf, a vise and a few bins.
    """
    pieces = [box_between((-1.0, -0.4, 0.86), (1.0, 0.4, 0.90))]           # worktop
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            pieces.append(box_at((sx * 0.92, sy * 0.32, 0.43), (0.06, 0.06, 0.86)))
    for sy in (-1.0, 1.0):                                                  # rails
        pieces.append(box_between((-0.89, sy * 0.32 - 0.02, 0.78), (0.89, sy * 0.32 + 0.02, 0.86)))
    pieces.append(box_between((-0.89, -0.29, 0.15), (0.89, 0.29, 0.17)))   # lower shelf
    pieces.append(box_between((0.30, -0.34, 0.20), (0.86, 0.30, 0.78)))    # drawer unit
    for k in range(4):                                                      # drawer fronts
        z = 0.21 + k * 0.1425
        pieces.append(box_between((0.31, -0.355, z), (0.85, -0.34, z + 0.1325)))
        pieces.append(box_between((0.50, -0.375, z + 0.09), (0.66, -0.355, z + 0.11)))
    pieces.append(box_between((-1.0, 0.36, 0.90), (1.0, 0.38, 1.70)))       # pegboard
    pieces.append(box_between((-1.0, 0.18, 1.48), (1.0, 0.36, 1.50)))       # top shelf
    for k, x in enumerate((-0.8, -0.45, -0.1, 0.25)):                       # bins on shelf
        pieces.append(box_between((x, 0.20, 1.50), (x + 0.3, 0.35, 1.50 + 0.10 + 0.02 * k)))
    pieces += [                                                             # bench vise
        box_between((-0.85, -0.42, 0.90), (-0.60, -0.22, 0.96)),
        box_between((-0.80, -0.42, 0.96), (-0.65, -0.38, 1.06)),
        box_between((-0.80, -0.30, 0.96), (-0.65, -0.25, 1.06)),
        cylinder_between((-0.725, -0.55, 1.0), (-0.725, -0.42, 1.0), 0.012, 12),
    ]
    pieces.append(box_between((-0.3, -0.1, 0.90), (0.1, 0.2, 1.15)))       # carton on the top
    pieces.append(box_between((0.15, 0.0, 0.90), (0.45, 0.25, 1.05)))
    return combine(pieces)


def machining_centre() -> trimesh.Trimesh:
    """Enclosed CNC machining centre, 2.6 x 2.0 x 2.2 m body, front towards -y.

    Recessed plinth, sliding door with window frame and handle, chip ledge, operator
    panel on an arm, roof step, signal tower, coolant tank and chip conveyor.
    """
    return combine([
        box_between((-1.25, -0.95, 0.0), (1.25, 0.95, 0.1)),                # recessed plinth
        box_between((-1.3, -1.0, 0.1), (1.3, 1.0, 2.2)),                    # enclosure
        box_between((-1.2, -0.9, 2.2), (1.2, 0.9, 2.35)),                   # roof step
        box_between((-1.0, -1.03, 0.95), (0.5, -1.0, 2.05)),                # door
        box_between((-0.85, -1.05, 1.25), (0.35, -1.03, 1.30)),             # window frame
        box_between((-0.85, -1.05, 1.85), (0.35, -1.03, 1.90)),
        box_between((-0.85, -1.05, 1.30), (-0.80, -1.03, 1.85)),
        box_between((0.30, -1.05, 1.30), (0.35, -1.03, 1.85)),
        box_between((0.40, -1.08, 1.30), (0.44, -1.03, 1.70)),              # door handle
        box_between((-1.3, -1.15, 0.85), (1.3, -1.0, 0.90)),                # chip ledge
        box_between((0.95, -1.1, 1.62), (1.05, -1.0, 1.70)),                # panel arm
        box_between((0.75, -1.25, 1.10), (1.25, -1.10, 1.80)),              # operator panel
        cylinder_between((1.1, 0.7, 2.35), (1.1, 0.7, 2.75), 0.03, 16),     # signal tower
        box_between((-1.1, 1.0, 0.0), (0.2, 1.5, 0.6)),                     # coolant tank
        box_between((1.3, -0.4, 0.0), (1.8, 0.4, 0.9)),                     # chip conveyor
        box_between((1.3, -0.3, 0.9), (1.7, 0.3, 1.3)),
    ])


def control_cabinet() -> trimesh.Trimesh:
    """Two-door electrical cabinet 0.8 x 0.5 x 2.1 m on a recessed plinth, front -y."""
    pieces = [
        box_between((-0.38, -0.23, 0.0), (0.38, 0.23, 0.1)),
        box_between((-0.4, -0.25, 0.1), (0.4, 0.25, 2.1)),
        box_between((-0.42, -0.27, 2.1), (0.42, 0.27, 2.14)),               # roof
    ]
    for s in (-1.0, 1.0):
        pieces.append(box_between((s * 0.0025, -0.26, 0.12), (s * 0.395, -0.25, 2.08)))   # door
        pieces.append(box_at((s * 0.06, -0.27, 1.1), (0.02, 0.02, 0.18)))      # handle
    return combine(pieces)


def bollard() -> trimesh.Trimesh:
    """Steel pipe bollard, 168 mm diameter, 1.2 m tall, bolted base plate."""
    return combine([
        box_between((-0.15, -0.15, 0.0), (0.15, 0.15, 0.015)),
        cylinder_between((0.0, 0.0, 0.015), (0.0, 0.0, 1.2), 0.084, 24),
        cylinder_between((0.0, 0.0, 1.2), (0.0, 0.0, 1.215), 0.088, 24),
        *bolt_pattern(0.11, 0.015, size=0.8),
    ])


# --------------------------------------------------------------------------------------
# Scene description
# --------------------------------------------------------------------------------------

@dataclass
class Part:
    """One ``[[parts]]`` entry: either a generated mesh or an external file (the URDF)."""

    name: str
    color: tuple
    mesh: trimesh.Trimesh | None = None        # generated -> meshes/<name>.glb
    path: str | None = None                    # external file, relative to the manifest
    units: str = "m"
    translate: tuple | None = None
    rotate_deg: tuple | None = None
    joints: dict | None = None
    instances: list = field(default_factory=list)

    @property
    def mesh_path(self) -> str:
        return self.path if self.path else f"meshes/{self.name}.glb"


def place(x, y, z=0.0, yaw_deg=0.0) -> dict:
    """One instance transform: a yaw about the part origin, then a translation."""
    inst = {"translate": [x, y, z]}
    if yaw_deg:
        inst["rotate_deg"] = [0.0, 0.0, yaw_deg]
    return inst


ROBOT_JOINTS = {                   # radians: arm turned towards the conveyor end, elbow up
    "lbr_iiwa_joint_1": 0.25,
    "lbr_iiwa_joint_2": 0.95,
    "lbr_iiwa_joint_3": 0.2,
    "lbr_iiwa_joint_4": -1.25,
    "lbr_iiwa_joint_5": 0.3,
    "lbr_iiwa_joint_6": 1.0,
    "lbr_iiwa_joint_7": 0.6,
}

VIEWPOINTS = [
    {   # from the south-west corner, diagonally across the whole cell
        "name": "overview",
        "eye": [-11.4, -6.2, 1.7], "target": [4.0, -0.5, 0.3], "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 60.0, "width": 1024, "height": 768,
    },
    {   # outside the fence, looking through the open door at the robot on its pedestal
        "name": "robot",
        "eye": [3.4, -6.2, 1.7], "target": [3.0, -2.5, 0.75], "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 35.0, "width": 1024, "height": 768,
    },
    {   # behind the conveyor's upstream end, looking along the rollers into the cell
        "name": "conveyor",
        "eye": [-7.3, -2.8, 1.7], "target": [2.2, -2.5, 0.8], "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 60.0, "width": 1024, "height": 768,
    },
]


def build_parts() -> list[Part]:
    """All parts of the cell with their colours and placements."""
    rng = np.random.default_rng(SEED)
    posts, panels = fence_layout()
    pallets_full = [place(-4.6, -6.1), place(-3.2, -6.1), place(4.0, 6.0), place(5.4, 6.0, yaw_deg=180.0)]
    pallets_partial = [place(3.0, -1.0), place(6.8, 6.0)]
    pallets_empty = [place(-6.0, -6.1)] + [place(-1.6, -5.9, k * PALLET_HEIGHT, 90.0) for k in range(3)]
    cx, cy = CONVEYOR_START
    return [
        Part("floor", (0.55, 0.55, 0.52), floor_slab()),
        Part("back_wall", (0.70, 0.70, 0.68), back_wall(), translate=(0.0, 7.4, 0.0)),
        Part("column", (0.35, 0.42, 0.52), steel_column(),
             instances=[place(x, y) for y in COLUMN_GRID_Y for x in COLUMN_GRID_X]),
        Part("hall_beam", (0.35, 0.42, 0.52), hall_beam(),
             instances=[place(0.0, y, COLUMN_HEIGHT) for y in COLUMN_GRID_Y]),
        Part("conveyor", (0.40, 0.45, 0.50), roller_conveyor(), units="mm", translate=(cx, cy, 0.0)),
        Part("pallet", (0.55, 0.40, 0.25), eur_pallet(),
             instances=pallets_full + pallets_partial + pallets_empty),
        Part("cartons_full", (0.70, 0.52, 0.33), carton_stack(3, 0, rng), instances=pallets_full),
        Part("cartons_partial", (0.70, 0.52, 0.33), carton_stack(1, 4, rng), instances=pallets_partial),
        Part("fence_post", (0.90, 0.75, 0.10), fence_post(),
             instances=[place(float(x), float(y)) for x, y in posts]),
        Part("fence_panel", (0.90, 0.75, 0.10), fence_panel(),
             instances=[place(float(m[0]), float(m[1]), 0.0, float(h)) for m, h in panels]),
        Part("robot_pedestal", (0.30, 0.30, 0.32), robot_pedestal(), translate=(*ROBOT_XY, 0.0)),
        Part("robot", (0.95, 0.45, 0.10), path=f"{ROBOT_DIR}/model.urdf",
             translate=(*ROBOT_XY, PEDESTAL_TOP), rotate_deg=(0.0, 0.0, 180.0), joints=ROBOT_JOINTS),
        Part("workbench", (0.35, 0.45, 0.40), workbench(), translate=(2.2, 6.9, 0.0)),
        Part("machine", (0.75, 0.76, 0.78), machining_centre(), translate=(8.2, -2.5, 0.0),
             rotate_deg=(0.0, 0.0, -90.0)),                  # front towards the cell
        Part("control_cabinet", (0.78, 0.78, 0.75), control_cabinet(), translate=(6.8, 0.6, 0.0),
             rotate_deg=(0.0, 0.0, 180.0)),
        Part("bollard", (0.95, 0.80, 0.05), bollard(), instances=[
            place(0.2, -5.3), place(5.8, -5.3), place(0.2, 0.3), place(5.8, 0.3),
            place(-6.3, -3.2), place(-10.2, -6.4),
        ]),
    ]


# --------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------

def write_glb(mesh: trimesh.Trimesh, path: Path, name: str) -> int:
    """Write ``mesh`` as GLB with crease-angle normals; return its triangle count.

    Boxes need split normals at their edges, else any loader that averages vertex
    normals shades them as blobs; smooth_shade() splits edges sharper than
    CREASE_ANGLE_DEG and keeps cylinder sides smooth. The mesh is rebuilt bare so no
    trimesh metadata (primitive parameters, component lists) leaks into the file.
    """
    shaded = trimesh.graph.smooth_shade(mesh, angle=np.radians(CREASE_ANGLE_DEG))
    bare = trimesh.Trimesh(
        vertices=shaded.vertices, faces=shaded.faces,
        vertex_normals=shaded.vertex_normals, process=False,
    )
    bare.metadata["name"] = name
    path.write_bytes(bare.export(file_type="glb", include_normals=True))
    return len(bare.faces)


def copy_robot(source: Path, dest: Path) -> None:
    """Copy the URDF, its visual meshes (+ their .mtl files) and the licence.

    Collision meshes (.stl) are not copied: the renderer only needs visuals, and
    yourdfpy does not load collision meshes unless asked to.
    """
    urdf = source / "kuka_iiwa" / "model.urdf"
    if dest.exists():
        shutil.rmtree(dest)
    (dest / "meshes").mkdir(parents=True)
    shutil.copyfile(urdf, dest / "model.urdf")
    shutil.copyfile(source / "LICENSE.txt", dest / "LICENSE.txt")
    meshes = ET.parse(urdf).getroot().iterfind("link/visual/geometry/mesh")
    for rel in sorted({m.get("filename") for m in meshes}):
        shutil.copyfile(urdf.parent / rel, dest / rel)
        if rel.endswith(".obj"):
            for line in (urdf.parent / rel).read_text().splitlines():
                if line.startswith("mtllib "):
                    mtl = Path(rel).parent / line.split(maxsplit=1)[1].strip()
                    shutil.copyfile(urdf.parent / mtl, dest / mtl)
    (dest / "SOURCE.md").write_text(ROBOT_SOURCE_MD)


def urdf_triangles(path: Path, joints: dict) -> int:
    """Triangle count of the posed URDF visuals (also proves it loads without .stl files)."""
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_collision_meshes=False)
    unknown = set(joints) - set(urdf.actuated_joint_names)
    if unknown:
        raise ValueError(f"unknown joints in manifest: {sorted(unknown)}")
    urdf.update_cfg(joints)
    return sum(len(urdf.scene.geometry[n].faces) for n in urdf.scene.graph.nodes_geometry)


def toml_value(value) -> str:
    """TOML literal for the few value types the manifest uses."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(round(float(value), 6) + 0.0)      # + 0.0 turns -0.0 into 0.0
    if isinstance(value, str):
        return json.dumps(value)                       # ASCII JSON strings are TOML strings
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def manifest_text(parts: list[Part]) -> str:
    """scene.toml in the manifest format 1 (keys in the documented order)."""
    lines = [
        "# Generated by factory_scenes/build_sample_cell.py -- edit that script, not this file.",
        "format = 1",
        'name = "sample_cell"',
        f"description = {toml_value(DESCRIPTION)}",
    ]
    for part in parts:
        lines += ["", "[[parts]]", f'name = "{part.name}"', f'mesh = "{part.mesh_path}"',
                  f'units = "{part.units}"', f"color = {toml_value(list(part.color))}"]
        for key in ("translate", "rotate_deg", "joints"):
            value = getattr(part, key)
            if value is not None:
                lines.append(f"{key} = {toml_value(value)}")
        if part.instances:
            lines.append("instances = [")
            lines += [f"    {toml_value(inst)}," for inst in part.instances]
            lines.append("]")
    for view in VIEWPOINTS:
        lines += ["", "[[viewpoints]]"] + [f"{k} = {toml_value(v)}" for k, v in view.items()]
    return "\n".join(lines) + "\n"


def readme_text(rows: list[tuple[str, str, int, int]], total: int) -> str:
    """README for the output folder; ``rows`` are (part, units, mesh triangles, copies)."""
    table = "\n".join(f"| {n} | {u} | {t:,} | {c} | {t * c:,} |" for n, u, t, c in rows)
    views = "\n".join(
        f"- `{v['name']}`: eye {v['eye']} -> target {v['target']}, {v['fov_y_deg']} deg vertical FOV"
        for v in VIEWPOINTS
    )
    return README_TEMPLATE.format(table=table, total=f"{total:,}", views=views)


DESCRIPTION = (
    "Factory cell, about 20 m x 14 m on a 24 m x 16 m slab: steel hall frame with bolted "
    "column feet, roller conveyor (authored in mm), EUR pallets with carton stacks, welded-mesh "
    "safety fence around a KUKA LBR iiwa on a pedestal, workbench, machining centre, control "
    "cabinet and bollards. Z up, metres."
)

ROBOT_SOURCE_MD = """\
# KUKA LBR iiwa model: source and licence

- Source: the `pybullet_data/kuka_iiwa/` folder of the **pybullet 3.2.7** wheel
  (Bullet Physics, https://github.com/bulletphysics/bullet3).
- Copied unchanged: `model.urdf`, `meshes/link_0.obj` ... `meshes/link_7.obj` and their
  `.mtl` files, and `LICENSE.txt` (pybullet_data's licence notice).
- Not copied: the collision meshes (`meshes/link_*.stl`) that the URDF's `<collision>`
  elements name. mrcheck renders visuals only; load the model with
  `yourdfpy.URDF.load(path, build_collision_scene_graph=False, load_collision_meshes=False)`
  (yourdfpy's defaults) and the missing `.stl` files are never opened.
- Licence: zlib (see `LICENSE.txt`). `model.urdf` also carries, in its header, the
  BSD-style notice of the original lbr_iiwa description by Robert Krug and Todor Stoyanov
  (AASS Research Center, Orebro University, 2015); it is kept unchanged in the file.
- Copied by `factory_scenes/build_sample_cell.py`.
"""

README_TEMPLATE = """\
# sample_cell: the embedded sample scene

Generated by `factory_scenes/build_sample_cell.py`; do not edit by hand. Rebuild with

    python factory_scenes/build_sample_cell.py

The KUKA model is copied from a pybullet_data folder, by default
`../shared/data/robots/pybullet_data` beside the repository; pass `--pybullet-data DIR` to use another copy.
Without one, the copy already in `robots/kuka_iiwa/` is kept.
The build is deterministic: running it twice gives byte-identical files.

## What is in it

A factory cell of about 20 m x 14 m on a 24 m x 16 m floor slab, built for screen-space
ambient occlusion: many concave creases and small details next to large flat areas.

- floor slab (top at z = 0) and a low ribbed back wall (3 m) as a backdrop;
- hall frame: six HEB 300 columns (6 m) with base plates, stiffeners and four anchor
  bolts each, two HEB 400 roof beams -- one mesh each, placed with `instances`;
- an 8 m roller conveyor (80 rollers, diameter 60 mm, 100 mm pitch) with C-channel
  frames, legs and a gear motor -- authored **in millimetres** (`units = "mm"`);
- EUR pallets (1.2 x 0.8 x 0.144 m, one mesh, 10 instances incl. a stack of three empty
  ones) with carton stacks (full and partial) on six of them;
- a welded-mesh safety fence (posts + panels, both instanced) around the robot, open
  where the conveyor enters and at the door;
- a KUKA LBR iiwa (URDF, posed by `joints`) on a steel pedestal;
- a workbench, a machining centre, a control cabinet and six bollards.

## Units and frames

Z is up, world units are metres, the floor's top face is z = 0 and the cell is centred
on the origin. Every mesh except `meshes/conveyor.glb` (millimetres) is in metres; the
manifest's `units` key says which. Part meshes are GLB with crease-angle normals.

## Parts and triangle counts

| part | units | triangles (mesh) | copies drawn | triangles drawn |
|---|---|---|---|---|
{table}

Total drawn: **{total}** triangles (budget 200,000).

## Viewpoints

{views}

## Licences

Everything except `robots/kuka_iiwa/` is generated by this project's script (MIT, like
mrcheck). The robot comes from the pybullet 3.2.7 wheel's `pybullet_data` under the zlib
licence; see `robots/kuka_iiwa/SOURCE.md` and `robots/kuka_iiwa/LICENSE.txt`.
"""


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pybullet-data", type=Path, default=DEFAULT_PYBULLET_DATA,
                        help="pybullet_data folder to copy the KUKA iiwa from")
    args = parser.parse_args(argv)

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    (OUT_DIR / ".keep").unlink(missing_ok=True)
    robot_dest = OUT_DIR / ROBOT_DIR
    if (args.pybullet_data / "kuka_iiwa" / "model.urdf").is_file():
        copy_robot(args.pybullet_data, robot_dest)
    elif (robot_dest / "model.urdf").is_file():
        print(f"note: {args.pybullet_data} not found; keeping the robot already in {robot_dest}",
              file=sys.stderr)
    else:
        sys.exit(f"error: no kuka_iiwa/model.urdf under {args.pybullet_data} (use --pybullet-data)")

    mesh_dir = OUT_DIR / "meshes"
    if mesh_dir.exists():
        shutil.rmtree(mesh_dir)            # drop meshes of parts that no longer exist
    mesh_dir.mkdir()

    parts = build_parts()
    rows = []
    for part in parts:
        if part.mesh is not None:
            triangles = write_glb(part.mesh, OUT_DIR / part.mesh_path, part.name)
        else:
            triangles = urdf_triangles(OUT_DIR / part.mesh_path, part.joints or {})
        rows.append((part.name, part.units, triangles, max(len(part.instances), 1)))
    total = sum(triangles * copies for _, _, triangles, copies in rows)

    (OUT_DIR / "scene.toml").write_text(manifest_text(parts))
    (OUT_DIR / "README.md").write_text(readme_text(rows, total))

    width = max(len(name) for name, *_ in rows)
    for name, units, triangles, copies in rows:
        print(f"{name:<{width}}  {units:>2}  {triangles:>7,} tri  x{copies:<3} = {triangles * copies:>8,}")
    print(f"{'total':<{width}}  {total:>31,} triangles (incl. instances)")
    if total > MAX_TRIANGLES:
        sys.exit(f"error: {total:,} triangles exceed the budget of {MAX_TRIANGLES:,}")


if __name__ == "__main__":
    main()
