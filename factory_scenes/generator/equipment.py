"""Production equipment: roller conveyor, machining centre, control cabinet, workbench,
robot pedestal, safety fence, bollard.

Units and frames: metres, Z up, floor at z = 0, origin at the centre of the footprint unless a
builder says otherwise; "front" is the side an operator faces. The roller conveyor alone is
authored in millimetres, as the hand-built sample cell declares it (``units = "mm"``).
Defaults reproduce the sample cell's parts exactly (``SAMPLE_DETAIL``), which its golden
images depend on.
"""

from __future__ import annotations

import numpy as np
import trimesh

from .detail import SAMPLE_DETAIL, Detail
from .geometry import (
    anchor_bolt,
    bolt_pattern,
    box_at,
    box_between,
    combine,
    cylinder_between,
)

FENCE_HEIGHT = 2.2  # m, post height of the guard fence (ISO 14120 asks >= 1.4 m; 2.2 is common)
PEDESTAL_TOP = 0.70  # m, top of the sample cell's robot pedestal


def roller_conveyor(length=8000.0, detail: Detail = SAMPLE_DETAIL, motor=True) -> trimesh.Trimesh:
    """Roller conveyor of ``length`` mm, authored in MILLIMETRES.

    Local frame: flow along +x from x = 0 to ``length``, centreline y = 0, floor z = 0.
    Rollers of diameter 60 at ``detail.roller_pitch`` (100 in the sample: 80 rollers on 8 m),
    top of rollers at 800; C-channel side frames with outward flanges, leg stations every
    2 m with cross braces and levelling feet, and (``motor``) a gear motor under the
    downstream end. Segments of a longer line are this mesh repeated end to end.
    """
    pitch, roller_r, axis_z = detail.roller_pitch, 30.0, 770.0
    inner = 300.0  # inner face of the side frame webs
    pieces = []
    for s in (-1.0, 1.0):  # side frames: web + top and bottom flange
        web, lip = s * (inner + 4.0), s * (inner + 50.0)
        pieces.append(box_between((0.0, s * inner, 680.0), (length, web, 790.0)))
        pieces.append(box_between((0.0, web, 786.0), (length, lip, 790.0)))
        pieces.append(box_between((0.0, web, 680.0), (length, lip, 684.0)))
    for x in np.arange(pitch / 2.0, length, pitch):
        pieces.append(cylinder_between((x, -295.0, axis_z), (x, 295.0, axis_z), roller_r, detail.sections))
        if detail.bolts:  # axle stubs through the side frames
            pieces.append(
                cylinder_between((x, -inner - 6.0, axis_z), (x, inner + 6.0, axis_z), 6.0, detail.sections // 2)
            )
    for x in (20.0, length - 20.0):  # end cross members below the first/last roller
        pieces.append(box_between((x - 20.0, -inner, 690.0), (x + 20.0, inner, 730.0)))
    legs = [100.0, *np.arange(2000.0, length - 100.0, 2000.0), length - 100.0]
    for x in legs:  # leg stations
        for s in (-1.0, 1.0):
            y = s * 327.0
            pieces.append(box_at((x, y, 355.0), (50.0, 50.0, 650.0)))  # leg
            pieces.append(
                cylinder_between((x, y, 10.0), (x, y, 30.0), 12.0, detail.sections * 3 // 4)
            )  # levelling screw
            pieces.append(box_at((x, y, 5.0), (120.0, 120.0, 10.0)))  # foot plate
        pieces.append(box_at((x, 0.0, 200.0), (40.0, 604.0, 40.0)))  # cross brace
    if motor:  # gear motor under the downstream end: gearbox + motor
        x = length - 1050.0
        pieces.append(box_between((x, -inner, 660.0), (x + 100.0, inner, 680.0)))  # mount
        pieces.append(box_between((x - 50.0, -125.0, 480.0), (x + 150.0, 125.0, 660.0)))  # gearbox
        pieces.append(cylinder_between((x + 150.0, 0.0, 570.0), (x + 450.0, 0.0, 570.0), 75.0, detail.sections))
    return combine(pieces)


def fence_post(height=FENCE_HEIGHT, detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """60 x 60 mm square tube post with cap, on a base plate with two anchor bolts."""
    pieces = [
        box_between((-0.08, -0.08, 0.0), (0.08, 0.08, 0.01)),
        box_between((-0.03, -0.03, 0.01), (0.03, 0.03, height)),
        box_between((-0.035, -0.035, height), (0.035, 0.035, height + 0.006)),
    ]
    if detail.bolts:
        pieces += anchor_bolt(-0.055, -0.055, 0.01, 0.6, detail.sections)
        pieces += anchor_bolt(0.055, 0.055, 0.01, 0.6, detail.sections)
    return combine(pieces)


def fence_panel(pitch=1.0, z0=0.15, z1=2.05, detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """Welded-mesh guard panel between two posts ``pitch`` m apart, in the x-z plane.

    Tube frame plus a grid of 4 x 5 mm bars (vertical every ``detail.wire_pitch`` behind,
    horizontal every two pitches in front, touching at y = 0 like welded wires), and four
    brackets that reach the post faces. Centred on x = 0. Without a wire pitch (coarsest
    level) the frame holds a plain sheet.
    """
    hw = pitch / 2.0 - 0.04  # 30 mm post half-width + 10 mm clearance
    t = 0.02  # frame tube section
    pieces = [
        box_between((-hw, -t / 2, z0), (-hw + t, t / 2, z1)),
        box_between((hw - t, -t / 2, z0), (hw, t / 2, z1)),
        box_between((-hw + t, -t / 2, z0), (hw - t, t / 2, z0 + t)),
        box_between((-hw + t, -t / 2, z1 - t), (hw - t, t / 2, z1)),
    ]
    wire = detail.wire_pitch
    if wire is None:
        pieces.append(box_between((-hw + t, -0.001, z0 + t), (hw - t, 0.001, z1 - t)))
    else:
        for x in np.arange(-hw + t + 0.03, hw - t, wire):
            pieces.append(box_between((x - 0.002, -0.005, z0 + t), (x + 0.002, 0.0, z1 - t)))
        for z in np.arange(z0 + t + 0.07, z1 - t, 2 * wire):
            pieces.append(box_between((-hw + t, 0.0, z - 0.002), (hw - t, 0.005, z + 0.002)))
    for s in (-1.0, 1.0):
        for z in (z0 + 0.25, z1 - 0.25):
            inner_x, post_face_x = s * (hw - 0.005), s * (pitch / 2.0 - 0.03)
            pieces.append(box_between((inner_x, -0.01, z - 0.02), (post_face_x, 0.01, z + 0.02)))
    return combine(pieces)


def fence_layout(rect, pitch=1.0, openings=()):
    """Post positions and panel placements (midpoint, heading in degrees) around ``rect``.

    ``rect`` is (x0, y0, x1, y1) in metres. Panels whose midpoint is listed in ``openings``
    are left out (conveyor pass-through, door); the posts on both sides of an opening stay.
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


def robot_pedestal(top=PEDESTAL_TOP, detail: Detail = SAMPLE_DETAIL, scale=1.0) -> trimesh.Trimesh:
    """Welded steel pedestal, top plate at ``top`` m, with anchor and robot bolts.

    The sample's plates (0.8 m base, 0.6 m top) grow with ``scale`` in plan, for robots with a
    larger base footprint; the height stays ``top``.
    """
    plate, s = 0.03, scale
    pieces = [
        box_between((-0.4 * s, -0.4 * s, 0.0), (0.4 * s, 0.4 * s, plate)),
        box_between((-0.25 * s, -0.25 * s, plate), (0.25 * s, 0.25 * s, top - plate)),
        box_between((-0.3 * s, -0.3 * s, top - plate), (0.3 * s, 0.3 * s, top)),
    ]
    for sign in (-1.0, 1.0):  # gussets on all four faces
        pieces.append(box_between((sign * 0.25 * s, -0.008, plate), (sign * 0.38 * s, 0.008, plate + 0.25)))
        pieces.append(box_between((-0.008, sign * 0.25 * s, plate), (0.008, sign * 0.38 * s, plate + 0.25)))
    if detail.bolts:
        pieces += bolt_pattern(0.33 * s, plate, sections=detail.sections)
        pieces += bolt_pattern(0.24 * s, top, size=0.7, sections=detail.sections)
    return combine(pieces)


def workbench(detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """Steel workbench 2.0 x 0.8 m, worktop at 0.9 m, front towards -y.

    Legs, rails, lower shelf, drawer unit, pegboard with a shelf, a vise and a few bins.
    """
    pieces = [box_between((-1.0, -0.4, 0.86), (1.0, 0.4, 0.90))]  # worktop
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            pieces.append(box_at((sx * 0.92, sy * 0.32, 0.43), (0.06, 0.06, 0.86)))
    for sy in (-1.0, 1.0):  # rails
        pieces.append(box_between((-0.89, sy * 0.32 - 0.02, 0.78), (0.89, sy * 0.32 + 0.02, 0.86)))
    pieces.append(box_between((-0.89, -0.29, 0.15), (0.89, 0.29, 0.17)))  # lower shelf
    pieces.append(box_between((0.30, -0.34, 0.20), (0.86, 0.30, 0.78)))  # drawer unit
    for k in range(4):  # drawer fronts
        z = 0.21 + k * 0.1425
        pieces.append(box_between((0.31, -0.355, z), (0.85, -0.34, z + 0.1325)))
        pieces.append(box_between((0.50, -0.375, z + 0.09), (0.66, -0.355, z + 0.11)))
    pieces.append(box_between((-1.0, 0.36, 0.90), (1.0, 0.38, 1.70)))  # pegboard
    pieces.append(box_between((-1.0, 0.18, 1.48), (1.0, 0.36, 1.50)))  # top shelf
    for k, x in enumerate((-0.8, -0.45, -0.1, 0.25)):  # bins on shelf
        pieces.append(box_between((x, 0.20, 1.50), (x + 0.3, 0.35, 1.50 + 0.10 + 0.02 * k)))
    pieces += [  # bench vise
        box_between((-0.85, -0.42, 0.90), (-0.60, -0.22, 0.96)),
        box_between((-0.80, -0.42, 0.96), (-0.65, -0.38, 1.06)),
        box_between((-0.80, -0.30, 0.96), (-0.65, -0.25, 1.06)),
        cylinder_between((-0.725, -0.55, 1.0), (-0.725, -0.42, 1.0), 0.012, detail.sections * 3 // 4),
    ]
    pieces.append(box_between((-0.3, -0.1, 0.90), (0.1, 0.2, 1.15)))  # carton on the top
    pieces.append(box_between((0.15, 0.0, 0.90), (0.45, 0.25, 1.05)))
    return combine(pieces)


def machining_centre(detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """Enclosed CNC machining centre, 2.6 x 2.0 x 2.2 m body, front towards -y.

    Recessed plinth, sliding door with window frame and handle, chip ledge, operator
    panel on an arm, roof step, signal tower, coolant tank and chip conveyor.
    """
    return combine(
        [
            box_between((-1.25, -0.95, 0.0), (1.25, 0.95, 0.1)),  # recessed plinth
            box_between((-1.3, -1.0, 0.1), (1.3, 1.0, 2.2)),  # enclosure
            box_between((-1.2, -0.9, 2.2), (1.2, 0.9, 2.35)),  # roof step
            box_between((-1.0, -1.03, 0.95), (0.5, -1.0, 2.05)),  # door
            box_between((-0.85, -1.05, 1.25), (0.35, -1.03, 1.30)),  # window frame
            box_between((-0.85, -1.05, 1.85), (0.35, -1.03, 1.90)),
            box_between((-0.85, -1.05, 1.30), (-0.80, -1.03, 1.85)),
            box_between((0.30, -1.05, 1.30), (0.35, -1.03, 1.85)),
            box_between((0.40, -1.08, 1.30), (0.44, -1.03, 1.70)),  # door handle
            box_between((-1.3, -1.15, 0.85), (1.3, -1.0, 0.90)),  # chip ledge
            box_between((0.95, -1.1, 1.62), (1.05, -1.0, 1.70)),  # panel arm
            box_between((0.75, -1.25, 1.10), (1.25, -1.10, 1.80)),  # operator panel
            cylinder_between((1.1, 0.7, 2.35), (1.1, 0.7, 2.75), 0.03, detail.sections),  # signal tower
            box_between((-1.1, 1.0, 0.0), (0.2, 1.5, 0.6)),  # coolant tank
            box_between((1.3, -0.4, 0.0), (1.8, 0.4, 0.9)),  # chip conveyor
            box_between((1.3, -0.3, 0.9), (1.7, 0.3, 1.3)),
        ]
    )


def assembly_press(detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """C-frame hydraulic press with guarding, 1.6 x 1.4 m footprint, 2.6 m tall, front -y.

    Base, throat and upper arm of the C-frame, cylinder and ram above the bolster, light
    curtain posts, hydraulic unit at the back and a two-hand control stand in front.
    """
    r = detail.sections
    return combine(
        [
            box_between((-0.8, -0.7, 0.0), (0.8, 0.7, 0.8)),  # base with bolster
            box_between((-0.45, -0.45, 0.8), (0.45, 0.1, 0.9)),  # bolster plate
            box_between((-0.7, 0.2, 0.8), (0.7, 0.7, 2.3)),  # C-frame back
            box_between((-0.6, -0.6, 2.0), (0.6, 0.7, 2.5)),  # upper arm
            cylinder_between((0.0, -0.2, 2.5), (0.0, -0.2, 2.75), 0.22, r),  # hydraulic cylinder
            cylinder_between((0.0, -0.2, 1.5), (0.0, -0.2, 2.0), 0.08, r),  # ram
            box_between((-0.35, -0.5, 1.35), (0.35, 0.05, 1.5)),  # upper die
            box_between((-0.7, -0.75, 0.8), (-0.65, -0.7, 2.0)),  # light curtain posts
            box_between((0.65, -0.75, 0.8), (0.7, -0.7, 2.0)),
            box_between((-0.6, 0.7, 0.0), (0.6, 1.2, 1.1)),  # hydraulic unit
            cylinder_between((0.3, 0.95, 1.1), (0.3, 0.95, 1.4), 0.08, r),  # motor on the unit
            box_between((-0.1, -1.35, 0.0), (0.1, -1.15, 0.95)),  # two-hand control stand
            box_between((-0.35, -1.45, 0.95), (0.35, -1.05, 1.1)),
        ]
    )


def control_cabinet() -> trimesh.Trimesh:
    """Two-door electrical cabinet 0.8 x 0.5 x 2.1 m on a recessed plinth, front -y."""
    pieces = [
        box_between((-0.38, -0.23, 0.0), (0.38, 0.23, 0.1)),
        box_between((-0.4, -0.25, 0.1), (0.4, 0.25, 2.1)),
        box_between((-0.42, -0.27, 2.1), (0.42, 0.27, 2.14)),  # roof
    ]
    for s in (-1.0, 1.0):
        pieces.append(box_between((s * 0.0025, -0.26, 0.12), (s * 0.395, -0.25, 2.08)))  # door
        pieces.append(box_at((s * 0.06, -0.27, 1.1), (0.02, 0.02, 0.18)))  # handle
    return combine(pieces)


def bollard(detail: Detail = SAMPLE_DETAIL) -> trimesh.Trimesh:
    """Steel pipe bollard, 168 mm diameter, 1.2 m tall, bolted base plate."""
    sections = detail.sections * 3 // 2
    pieces = [
        box_between((-0.15, -0.15, 0.0), (0.15, 0.15, 0.015)),
        cylinder_between((0.0, 0.0, 0.015), (0.0, 0.0, 1.2), 0.084, sections),
        cylinder_between((0.0, 0.0, 1.2), (0.0, 0.0, 1.215), 0.088, sections),
    ]
    if detail.bolts:
        pieces += bolt_pattern(0.11, 0.015, size=0.8, sections=detail.sections)
    return combine(pieces)


__all__ = [
    "FENCE_HEIGHT",
    "PEDESTAL_TOP",
    "roller_conveyor",
    "fence_post",
    "fence_panel",
    "fence_layout",
    "robot_pedestal",
    "workbench",
    "machining_centre",
    "assembly_press",
    "control_cabinet",
    "bollard",
]
