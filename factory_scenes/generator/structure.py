"""The building: floor slab and pits, steel columns, roof trusses, purlins and deck, wall
modules with window bands and sectional doors, crane runway and bridge crane, mezzanine.

Units and frames: metres, Z up, the floor's top face at z = 0. Each builder's docstring says
where its origin is; the layout places the result with instance transforms. ``scale`` grows
steel sections with the hall (1 = HEB 300 columns of a 6 m cell).
"""

from __future__ import annotations

import numpy as np
import trimesh

from .detail import SAMPLE_DETAIL, Detail
from .geometry import (
    Z_TO_X,
    Z_TO_Y,
    bar_between,
    bolt_pattern,
    box_between,
    combine,
    cylinder_between,
    i_profile,
    rect_minus,
    transformed,
    translation,
)

SLAB_THICKNESS = 0.3  # m, industrial floor slab
WALL_THICKNESS = 0.12  # m, sandwich panel cladding (outside of the interior face y = 0)
PURLIN_DEPTH = 0.2  # m, C-purlins on the truss top chords
DECK_DEPTH = 0.1  # m, trapezoidal roof deck
RUNWAY_DEPTH = 0.5  # m, crane runway beam (I-section) on the column brackets
RAIL_HEIGHT = 0.06  # m, crane rail on the runway beam
SECTION_HEIGHT = 0.5  # m, panel height of a sectional door leaf
STAIR_GOING = 0.25  # m, tread depth of the mezzanine stair


def floor_slab(outer, pits=()) -> trimesh.Trimesh:
    """Concrete slab over ``outer`` = (x0, y0, x1, y1), top face at z = 0, with rectangular
    holes where ``pits`` (x0, y0, x1, y1) are; each pit is its own part (see :func:`pit`)."""
    return combine(box_between((a, b, -SLAB_THICKNESS), (c, d, 0.0)) for a, b, c, d in rect_minus(outer, pits))


def pit(length, width, depth, detail: Detail) -> trimesh.Trimesh:
    """Open machine pit ``length`` (x) by ``width`` (y), ``depth`` deep, centred on the origin.

    Concrete walls and floor, a steel edge angle round the top, a guard rail on three sides
    (the fourth, -x, is where machines are lowered in) and a ladder on the +y wall.
    """
    hl, hw, t = length / 2.0, width / 2.0, 0.2
    pieces = [box_between((-hl - t, -hw - t, -depth - t), (hl + t, hw + t, -depth))]  # pit floor
    for s in (-1.0, 1.0):  # walls
        pieces.append(box_between((-hl - t, s * hw, -depth), (hl + t, s * (hw + t), 0.0)))
        pieces.append(box_between((s * hl, -hw, -depth), (s * (hl + t), hw, 0.0)))
    for s in (-1.0, 1.0):  # edge angles
        pieces.append(box_between((-hl, s * hw, -0.06), (hl, s * (hw - 0.006), 0.004)))
        pieces.append(box_between((s * hl, -hw, -0.06), (s * (hl - 0.006), hw, 0.004)))
    rail = 0.3  # rail set back
    posts = [
        (x, s * (hw + rail)) for s in (-1.0, 1.0) for x in np.linspace(-hl, hl + rail, max(2, int(length / 1.5) + 1))
    ]
    posts += [(hl + rail, y) for y in np.linspace(-hw, hw, max(2, int(width / 1.5) + 1))[1:-1]]
    for x, y in posts:
        pieces.append(box_between((x - 0.025, y - 0.025, 0.0), (x + 0.025, y + 0.025, 1.1)))
    for z in (0.5, 1.05):
        for s in (-1.0, 1.0):
            pieces.append(
                box_between(
                    (-hl - 0.025, s * (hw + rail) - 0.02, z), (hl + rail + 0.025, s * (hw + rail) + 0.02, z + 0.05)
                )
            )
        pieces.append(box_between((hl + rail - 0.02, -hw - rail, z), (hl + rail + 0.02, hw + rail, z + 0.05)))
    for x in (-0.25, 0.25):  # ladder stiles
        pieces.append(box_between((x - 0.03, hw - 0.2, -depth), (x + 0.03, hw - 0.15, 0.9)))
    for z in np.arange(-depth + 0.3, 0.0, 0.3):  # rungs
        pieces.append(
            cylinder_between((-0.25, hw - 0.175, z), (0.25, hw - 0.175, z), 0.012, max(6, detail.sections // 2))
        )
    return combine(pieces)


def steel_column(height=6.0, detail: Detail = SAMPLE_DETAIL, scale=1.0, bracket_z=None) -> trimesh.Trimesh:
    """HEB column (HEB 300 at ``scale`` 1) on a base plate with 4 anchor bolts and base stiffeners.

    Origin at the foot, web in the y-z plane (the frame plane of the roof trusses), cap plate
    at ``height``. ``bracket_z``: a crane runway corbel on the +y side whose top is there.
    """
    k = scale
    plate, cap = 0.03 * k, 0.02 * k
    web = 0.011 * k
    pieces = [
        box_between((-0.25 * k, -0.25 * k, 0.0), (0.25 * k, 0.25 * k, plate)),  # base plate
        transformed(i_profile(height - plate - cap, 0.3 * k, 0.3 * k, web, 0.019 * k), translation(0, 0, plate)),
        box_between((-0.17 * k, -0.17 * k, height - cap), (0.17 * k, 0.17 * k, height)),  # cap plate
    ]
    # Stiffeners (drawn with the bolts): in both channels of the I (perpendicular to
    # the web) and outside both flanges (in line with the web) -- the classic welded column foot.
    if detail.bolts:
        for s in (-1.0, 1.0):
            pieces.append(box_between((s * web / 2.0, -0.006 * k, plate), (s * 0.15 * k, 0.006 * k, plate + 0.2 * k)))
            pieces.append(box_between((-0.006 * k, s * 0.15 * k, plate), (0.006 * k, s * 0.24 * k, plate + 0.15 * k)))
        pieces += bolt_pattern(0.2 * k, plate, size=k, sections=detail.sections)
    if bracket_z is not None:  # corbel: top plate, web, diagonal strut
        y0, y1 = 0.15 * k, 0.15 * k + 0.7
        pieces.append(box_between((-0.15 * k, y0, bracket_z - 0.025), (0.15 * k, y1, bracket_z)))
        pieces.append(box_between((-0.01 * k, y0, bracket_z - 0.45), (0.01 * k, y1, bracket_z - 0.025)))
        pieces.append(box_between((-0.15 * k, y0, bracket_z - 0.47), (0.15 * k, y1 - 0.2, bracket_z - 0.45)))
        pieces.append(bar_between((0.0, y0, bracket_z - 1.2), (0.0, y1 - 0.25, bracket_z - 0.47), 0.12 * k, 0.04))
    return combine(pieces)


def roof_truss(span, depth, detail: Detail, scale=1.0) -> trimesh.Trimesh:
    """Parallel-chord Warren truss with verticals in the y-z plane, from y = -span/2 to span/2.

    Bottom chord underside at z = 0 (it bears on the column caps), top chord top at ``depth``.
    Coarse levels draw a plain I-girder of the same depth instead.
    """
    hs, k = span / 2.0, scale
    if not detail.truss_bays:
        girder = transformed(i_profile(span, depth, 0.3 * k, 0.015 * k, 0.03 * k), Z_TO_Y)
        return transformed(girder, translation(0.0, -hs, depth / 2.0))
    c = 0.16 * k  # chord: double angle, drawn as a box
    pieces = [
        box_between((-c / 2, -hs, 0.0), (c / 2, hs, c)),
        box_between((-c / 2, -hs, depth - c), (c / 2, hs, depth)),
    ]
    panels = max(4, 2 * round(span / 5.0))  # about 2.5 m panels, even count
    ys = np.linspace(-hs, hs, panels + 1)
    for i, (ya, yb) in enumerate(zip(ys, ys[1:])):
        lo, hi = (ya, yb) if i % 2 == 0 else (yb, ya)
        pieces.append(bar_between((0.0, lo, c / 2), (0.0, hi, depth - c / 2), 0.08 * k, 0.08 * k))
    for y in ys:  # verticals, and gusset plates at the nodes
        pieces.append(box_between((-0.04 * k, y - 0.04 * k, c), (0.04 * k, y + 0.04 * k, depth - c)))
        if detail.bolts:
            for z0, z1 in ((c, c + 0.22), (depth - c - 0.22, depth - c)):
                pieces.append(box_between((-c / 2 - 0.012, y - 0.25, z0), (c / 2 + 0.012, y + 0.25, z1)))
    for s in (-1.0, 1.0):  # end bearing plates on the column caps
        pieces.append(box_between((-0.15 * k, s * hs - 0.15 * k, -0.02), (0.15 * k, s * hs + 0.15 * k, 0.0)))
    return combine(pieces)


def purlins(length, width, detail: Detail) -> trimesh.Trimesh:
    """The C-purlins of one roof field: along x from 0 to ``length``, spread over ``width``
    (y, centred) about every 2.5 m (5 m at the coarsest level), PURLIN_DEPTH tall, bottom at
    z = 0 (on the truss top chords)."""
    spacing = 2.5 if detail.truss_bays else 5.0
    ys = np.linspace(-width / 2 + 0.2, width / 2 - 0.2, max(2, round(width / spacing) + 1))
    t, f = 0.003, 0.07
    pieces = []
    for y in ys:
        if detail.rib_pitch is None:
            pieces.append(box_between((0.0, y - 0.035, 0.0), (length, y + 0.035, PURLIN_DEPTH)))
            continue
        pieces += [
            box_between((0.0, y - t / 2, 0.0), (length, y + t / 2, PURLIN_DEPTH)),  # web
            box_between((0.0, y - t / 2, 0.0), (length, y + f, t)),  # flanges
            box_between((0.0, y - t / 2, PURLIN_DEPTH - t), (length, y + f, PURLIN_DEPTH)),
            box_between((0.0, y + f - t, t), (length, y + f, 0.025)),  # lips
            box_between((0.0, y + f - t, PURLIN_DEPTH - 0.025), (length, y + f, PURLIN_DEPTH - t)),
        ]
    return combine(pieces)


def roof_deck(length, width, detail: Detail) -> trimesh.Trimesh:
    """Trapezoidal steel deck panel ``length`` (x) by ``width`` (y), centred, ribs along y
    (spanning between the purlins), rib bottoms at z = 0, top at DECK_DEPTH."""
    hl, hw, sheet = length / 2.0, width / 2.0, 0.012
    pieces = [box_between((-hl, -hw, DECK_DEPTH - sheet), (hl, hw, DECK_DEPTH))]
    if detail.rib_pitch is not None:
        p = detail.rib_pitch
        for x in np.arange(-hl + p / 2.0, hl, p):
            pieces.append(box_between((x - p / 4.0, -hw, 0.0), (x + p / 4.0, hw, DECK_DEPTH - sheet)))
    return combine(pieces)


def wall_module(width, height, detail: Detail, window=None, door=None) -> trimesh.Trimesh:
    """One wall field between two columns: ``width`` along x (centred), floor to ``height``.

    Interior face at y = 0, the cladding outside it (-y). ``window`` = (z0, z1): a window
    band across the field (glass set back, mullions every ~1.25 m, sill and head);
    ``door`` = (w, h): a sectional door centred at the bottom (leaf panels SECTION_HEIGHT
    tall set back in the opening, trims, guide rails up the inside, torsion shaft and motor).
    Concrete plinth inside along the foot, inner liner ribs at ``detail.rib_pitch``.
    """
    hw = width / 2.0
    door_hole = [(-door[0] / 2.0, 0.0, door[0] / 2.0, door[1])] if door is not None else []
    openings = list(door_hole)
    if window is not None:
        openings.append((-hw + 0.3, window[0], hw - 0.3, window[1]))
    pieces = []
    for x0, z0, x1, z1 in rect_minus((-hw, 0.0, hw, height), openings):
        pieces.append(box_between((x0, -WALL_THICKNESS, z0), (x1, 0.0, z1)))
        if detail.rib_pitch is not None and z1 - z0 > 0.4:
            for x in np.arange(x0 + detail.rib_pitch / 2.0, x1 - 0.05, detail.rib_pitch):
                pieces.append(box_between((x - 0.025, 0.0, z0 + 0.05), (x + 0.025, 0.02, z1 - 0.05)))
    for x0, _, x1, _ in rect_minus((-hw, 0.0, hw, 1.0), door_hole):
        pieces.append(box_between((x0, -0.05, 0.0), (x1, 0.06, 0.5)))  # plinth
    if window is not None:
        z0, z1 = window
        pieces.append(box_between((-hw + 0.3, -0.09, z0), (hw - 0.3, -0.07, z1)))  # glass
        pieces.append(box_between((-hw + 0.3, -0.02, z0 - 0.04), (hw - 0.3, 0.18, z0)))  # sill
        pieces.append(box_between((-hw + 0.3, -0.12, z1), (hw - 0.3, 0.03, z1 + 0.06)))  # head
        n = max(1, round((width - 0.6) / 1.25)) if detail.rib_pitch is not None else 1
        for x in np.linspace(-hw + 0.3, hw - 0.3, n + 1):
            pieces.append(box_between((x - 0.03, -0.12, z0), (x + 0.03, 0.0, z1)))  # mullions
    if door is not None:
        dw, dh = door
        hd = dw / 2.0
        for z in np.arange(0.0, dh - 0.01, SECTION_HEIGHT):  # leaf sections
            pieces.append(box_between((-hd, -0.1, z + 0.006), (hd, -0.05, min(z + SECTION_HEIGHT, dh) - 0.006)))
        for s in (-1.0, 1.0):
            pieces.append(box_between((s * hd, -0.02, 0.0), (s * (hd + 0.1), 0.04, dh + 0.1)))  # side trims
            pieces.append(box_between((s * (hd - 0.02), 0.02, 0.0), (s * (hd + 0.08), 0.12, dh + 0.6)))  # guide rails
        pieces.append(box_between((-hd - 0.1, -0.02, dh), (hd + 0.1, 0.04, dh + 0.1)))  # head trim
        pieces.append(cylinder_between((-hd, 0.2, dh + 0.35), (hd, 0.2, dh + 0.35), 0.05, detail.sections))  # shaft
        pieces.append(box_between((hd + 0.1, 0.05, dh + 0.1), (hd + 0.45, 0.35, dh + 0.6)))  # motor
        pieces.append(box_between((hd + 0.15, 0.0, 1.2), (hd + 0.35, 0.08, 1.5)))  # push buttons
    return combine(pieces)


def crane_runway(length, detail: Detail, scale=1.0) -> trimesh.Trimesh:
    """Runway beam segment along x from 0 to ``length``: I-section RUNWAY_DEPTH deep with a
    rail on top (rail top at RUNWAY_DEPTH + RAIL_HEIGHT), bottom at z = 0, centred on y = 0;
    rail clips every 0.6 m."""
    beam = transformed(i_profile(length, RUNWAY_DEPTH, 0.3 * scale, 0.014, 0.025), Z_TO_X)
    pieces = [
        transformed(beam, translation(0.0, 0.0, RUNWAY_DEPTH / 2.0)),
        box_between((0.0, -0.03, RUNWAY_DEPTH), (length, 0.03, RUNWAY_DEPTH + RAIL_HEIGHT)),
    ]
    if detail.bolts:
        for x in np.arange(0.3, length, 0.6):
            for s in (-1.0, 1.0):
                pieces.append(
                    box_between((x - 0.04, s * 0.03, RUNWAY_DEPTH), (x + 0.04, s * 0.09, RUNWAY_DEPTH + 0.02))
                )
    return combine(pieces)


def bridge_crane(span, hook_drop, pendant_drop, detail: Detail) -> trimesh.Trimesh:
    """Double-girder overhead travelling crane, ``span`` between rail centres (along y).

    Origin at mid-span on the rail tops (z = 0), travel along x. End carriages with wheels and
    buffers, two box girders, a trolley with hoist drum and motor a third of the span off
    centre, ropes down to a hook block ``hook_drop`` below the rails, a walkway with handrail
    along one girder, and a pendant control hanging ``pendant_drop`` below the rails.
    """
    hs, r = span / 2.0, detail.sections
    pieces = []
    for s in (-1.0, 1.0):  # end carriages
        pieces.append(box_between((-1.6, s * hs - 0.2, 0.25), (1.6, s * hs + 0.2, 0.75)))
        for x in (-1.2, 1.2):
            pieces.append(cylinder_between((x, s * hs - 0.06, 0.2), (x, s * hs + 0.06, 0.2), 0.2, r))
        for x in (-1.6, 1.6):  # buffers
            pieces.append(cylinder_between((x, s * hs, 0.5), (x + np.sign(x) * 0.25, s * hs, 0.5), 0.08, r))
    for x in (-0.7, 0.7):  # box girders
        pieces.append(box_between((x - 0.25, -hs, 0.45), (x + 0.25, hs, 1.45)))
    yt = hs / 3.0  # trolley position
    pieces.append(box_between((-1.1, yt - 1.0, 1.45), (1.1, yt + 1.0, 1.65)))  # trolley frame
    pieces.append(cylinder_between((-0.3, yt - 0.7, 2.0), (-0.3, yt + 0.7, 2.0), 0.32, r))  # hoist drum
    pieces.append(box_between((-1.0, yt + 0.3, 1.65), (-0.5, yt + 0.9, 2.15)))  # gearbox
    pieces.append(cylinder_between((0.2, yt + 0.6, 1.95), (0.9, yt + 0.6, 1.95), 0.18, r))  # hoist motor
    hook_top = -hook_drop
    for dy in (-0.12, 0.12):  # ropes between the girders
        pieces.append(cylinder_between((-0.3, yt + dy, 1.65), (-0.3, yt + dy, hook_top), 0.012, max(6, r // 2)))
    pieces.append(box_between((-0.45, yt - 0.2, hook_top - 0.55), (-0.15, yt + 0.2, hook_top)))  # hook block
    pieces.append(cylinder_between((-0.3, yt, hook_top - 0.55), (-0.3, yt, hook_top - 0.8), 0.05, r))
    pieces.append(box_between((-0.35, yt - 0.25, hook_top - 0.9), (-0.25, yt + 0.05, hook_top - 0.8)))  # hook
    pieces.append(box_between((-0.35, yt - 0.25, hook_top - 0.8), (-0.25, yt - 0.15, hook_top - 0.65)))
    pieces.append(box_between((0.95, -hs + 0.3, 1.25), (1.6, hs - 0.3, 1.3)))  # walkway
    for y in np.linspace(-hs + 0.3, hs - 0.3, max(2, int(span / 2.0))):
        pieces.append(box_between((1.55, y - 0.025, 1.3), (1.6, y + 0.025, 2.4)))  # handrail posts
    pieces.append(box_between((1.55, -hs + 0.3, 2.35), (1.6, hs - 0.3, 2.4)))
    pieces.append(cylinder_between((0.9, yt, 1.45), (0.9, yt, -pendant_drop), 0.01, 6))  # pendant cable
    pieces.append(box_between((0.82, yt - 0.06, -pendant_drop - 0.35), (0.98, yt + 0.06, -pendant_drop)))
    return combine(pieces)


def mezzanine(length, width, deck_z, detail: Detail) -> trimesh.Trimesh:
    """Steel platform ``length`` (x) by ``width`` (y) with its deck top at ``deck_z``.

    Origin at the front-left corner on the floor; the back (y = ``width``) stands at a wall,
    the other three sides carry toe boards and a 1.1 m handrail. A straight stair leaves the
    front edge near x = ``length`` and runs down towards -y (its foot at y = -run, see
    :func:`stair_run`). Posts on base plates, I-beams, joists, grating deck.
    """
    pieces = []
    beam = 0.3
    xs = np.linspace(0.15, length - 0.15, max(2, int(np.ceil(length / 5.0)) + 1))
    ys = np.linspace(0.15, width - 0.15, max(2, int(np.ceil(width / 5.0)) + 1))
    for x in xs:
        for y in ys:
            pieces.append(box_between((x - 0.075, y - 0.075, 0.0), (x + 0.075, y + 0.075, deck_z - beam - 0.05)))
            pieces.append(box_between((x - 0.15, y - 0.15, 0.0), (x + 0.15, y + 0.15, 0.02)))
            if detail.bolts:
                pieces += [
                    transformed(b, translation(x, y, 0.0)) for b in bolt_pattern(0.11, 0.02, 0.8, detail.sections)
                ]
    beam_x = transformed(i_profile(length, beam, 0.15, 0.008, 0.012), Z_TO_X)
    for y in ys:  # main beams along x
        pieces.append(transformed(beam_x, translation(0.0, y, deck_z - 0.05 - beam / 2.0)))
    for x in np.arange(0.0, length + 0.01, 1.25):  # joists along y
        pieces.append(box_between((x - 0.04, 0.0, deck_z - 0.21), (x + 0.04, width, deck_z - 0.05)))
    pieces.append(box_between((0.0, 0.0, deck_z - 0.05), (length, width, deck_z)))  # grating
    gap = (length - 1.2, length - 0.2)  # stair opening in the front rail
    rails = [
        ((0.0, 0.0), (gap[0], 0.0)),
        ((gap[1], 0.0), (length, 0.0)),
        ((0.0, 0.0), (0.0, width)),
        ((length, 0.0), (length, width)),
    ]
    for (xa, ya), (xb, yb) in rails:
        n = max(1, int(np.ceil(max(abs(xb - xa), abs(yb - ya)) / 1.5)))
        for t in np.linspace(0.0, 1.0, n + 1):
            px, py = xa + t * (xb - xa), ya + t * (yb - ya)
            pieces.append(box_between((px - 0.025, py - 0.025, deck_z), (px + 0.025, py + 0.025, deck_z + 1.1)))
        for z0, z1 in ((deck_z, deck_z + 0.15), (deck_z + 0.5, deck_z + 0.54), (deck_z + 1.06, deck_z + 1.1)):
            pieces.append(box_between((xa - 0.02, ya - 0.02, z0), (xb + 0.02, yb + 0.02, z1)))
    steps, run = stair_steps(deck_z), stair_run(deck_z)
    for x in gap:  # stringers, handrails, newels
        pieces.append(bar_between((x, -run, 0.1), (x, 0.0, deck_z - 0.1), 0.03, 0.25))
        pieces.append(bar_between((x, -run, 1.0), (x, 0.0, deck_z + 1.0), 0.04, 0.04))
        pieces.append(box_between((x - 0.025, -run - 0.025, 0.0), (x + 0.025, -run + 0.025, 1.0)))
    for i in range(1, steps):  # treads
        y, z = -run + i * STAIR_GOING, i * deck_z / steps
        pieces.append(box_between((gap[0], y - 0.13, z - 0.03), (gap[1], y + 0.13, z)))
    return combine(pieces)


def stair_steps(height) -> int:
    """Number of risers of a stair up ``height`` m (risers of about 0.2 m)."""
    return max(2, int(round(height / 0.2)))


def stair_run(height) -> float:
    """Horizontal length (m) of the mezzanine stair up ``height`` m."""
    return stair_steps(height) * STAIR_GOING


def floor_marking(length, width=0.1) -> trimesh.Trimesh:
    """Painted floor line along x from 0 to ``length``, ``width`` wide, 3 mm proud of the floor."""
    return box_between((0.0, -width / 2.0, 0.0), (length, width / 2.0, 0.003))


__all__ = [
    "SLAB_THICKNESS",
    "WALL_THICKNESS",
    "PURLIN_DEPTH",
    "DECK_DEPTH",
    "RUNWAY_DEPTH",
    "RAIL_HEIGHT",
    "floor_slab",
    "pit",
    "steel_column",
    "roof_truss",
    "purlins",
    "roof_deck",
    "wall_module",
    "crane_runway",
    "bridge_crane",
    "mezzanine",
    "stair_steps",
    "stair_run",
    "floor_marking",
]
