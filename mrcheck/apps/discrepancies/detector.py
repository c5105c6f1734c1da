"""The discrepancy detector: which planned CAD parts does a registered photo disagree with?

Method
------
1. **Object ids in the photo's lens geometry.** For every photo pixel the undistorted (ideal)
   pixel comes from :func:`mrcheck.mr.overlay.distortion_map`; one ray per pixel is cast through
   it with Open3D's ``RaycastingScene`` over the triangle soup of every part at every instance
   (:class:`mrcheck.scene.raycast.SceneCaster`, relative to the camera centre for float32
   precision; :mod:`mrcheck.apps.discrepancies.ids`). The hit's triangle gives the instance
   (``Part.instance_ids``); its ``t_hit`` is the camera-space depth (the ray's z is 1). No
   renderer change is needed and the ids are exactly in the photo's (distorted) frame.
2. **CAD edges** are :func:`mrcheck.mr.overlay.cad_edges` of the planned render's depth (inverse
   depth second differences: silhouettes and creases), resampled into the photo's geometry as
   the overlay does, plus the boundaries between different instance ids (two touching parts at
   the same depth have a real outline that depth alone does not show). Each edge pixel belongs
   to the *nearest* instance in its 3x3 neighbourhood: a silhouette is the occluder's outline.
3. **Photo edges**: Canny on the grey photo after a light Gaussian blur, thresholds set
   automatically from the median gradient magnitude (so a darker or brighter exposure, or
   another light, gives the same edges), then a distance transform of the edge map.
4. **Oriented support** of an instance = share of its visible CAD *outline* pixels
   (instance/background boundaries and depth steps > 5 %, :func:`silhouettes`; creases are
   drawn but not scored, since a crease can lose all contrast under another light) with a photo
   edge within ``tolerance_px`` (default 2 px, scaled with the image's longer side / 1000)
   *whose gradient direction lies within about 34 degrees of the outline's normal*
   (:func:`oriented_support`, :func:`outline_normals`): a fence wire crossing a machine's edge
   is no support for it. The same share is computed for the outline shifted by every offset
   up to 4 tolerances (:func:`shifted_support`, a correlation per orientation bin).
   **Score** = 1 - support^2 / best shifted support: 0 for a part that matches best where
   planned, however faint its edges under the photo's light; high when a displaced copy
   matches better (moved, turned, resized) or nothing matches (missing). Instances with fewer
   than :data:`MIN_EDGE_PIXELS` outline pixels are not scored; *thin* ones (nowhere wider than
   2 (T - 1) px for a tolerance T: fence posts and mesh panels at a distance) are scored but
   never suspects.
   Suspects = the others with score >= :data:`SCORE_THRESHOLD`, ranked by score.
   **Expected outline** (issue 22): only the outline pixels the photo can be expected to show
   are scored (:func:`expected_outline`): the edges of the planned view *relit by the photo's
   own light* (fitted to the photo with the renderer's shading model,
   :mod:`~mrcheck.apps.discrepancies.light`), found at :data:`EXPECTED_CONTRAST` times the photo's
   Canny threshold. An outline without that contrast under that light -- grey on grey, a yellow
   post against a pale wall in the sun, a mesh wire the photo's noise buries -- gives no photo edge
   either, and its absence says nothing. (The headlight render's edges at its own threshold were
   used before: on the unchanged sample cell's robot view and the generated cell's views 10, 6,
   11 and 10 parts were suspects because the sun-lit photo lacked edges the headlight showed;
   with the relit outline 1, 0, 0, 0.)
   Each part also reports ``revealed_support``: the share of the edges the "part removed" view
   shows inside its image that the photo shows (evidence of absence; reported, not yet used).
5. **What the scene without the part would show** (second rule). :func:`behind_ids` re-casts
   every pixel's ray from just behind its first hit until it meets another instance (one or two
   extra passes for the whole view): the planned scene with each part removed. An outline pixel
   of a part is *discriminative* when that "part gone" buffer has no CAD edge (silhouettes and
   creases of its depth) of the same orientation within ``tolerance_px``
   (:func:`discriminative_outlines`): a bollard's sides in front of a fence post's parallel sides
   or a neighbour's edge are dropped -- they would be supported whether or not the part is
   there. The same score on the discriminative outline alone (at least :data:`MIN_EDGE_PIXELS`
   pixels) is ``discriminative_score``; a part is also a suspect when it is >=
   :data:`DISCRIMINATIVE_THRESHOLD` (0.85) and the whole-outline score >=
   :data:`DISCRIMINATIVE_FLOOR` (0.2). All thresholds were chosen on seeds 0-9 only (640x480),
   by a sweep of score threshold, discriminative threshold, floor and the discriminative
   outline's minimum size. Nothing there finds more moves >= 0.2 m up to 20 m than 33/42 while
   keeping precision >= 0.70 and no more false suspects on the unchanged scene. At a score
   threshold of 0.55, 33/42 holds for a discriminative threshold of 0.8-0.95, a floor of 0-0.4
   and a minimum of 17-21 px. The score threshold stays at 0.55: 33/42 holds up to 0.65, but a
   higher threshold loses other kinds of change, and a lower one breaks the false-suspect
   limit. The floor sits in the middle of its range rather than at the edge: one of the rule's
   two moves there scores 0.41. On seeds 0-9 the rule adds 2 moves and 4 missing parts for 1
   false suspect.
   **The photo's own null** (:mod:`~mrcheck.apps.discrepancies.consensus`): each part is then
   judged again with "as planned" widened to the shift its nearest other parts match best at
   (within :data:`CONSENSUS_REACH_PX`): a pose a few px off shifts every outline alike, which is
   no move. Measured (sample cell, 640x480, the camera turned 2 / 4 px): conveyor, overview and
   robot views 3, 5, 3 / about 20 false suspects each before, 0, 0, 0 / 1, 2, 0 after.
6. **Unexplained structure** (:mod:`~mrcheck.apps.discrepancies.structure`): photo edge pixels
   farther than ``3 * tolerance`` from every CAD edge, not a contact line along a resting part's
   foot (its contact shadow or reflection, :mod:`~mrcheck.apps.discrepancies.contact`), not
   weaker than the texture of the plain floor (:func:`~mrcheck.apps.discrepancies.edges.texture_edges`:
   Canny's noise rule with the floor's texture as the noise) and not on the edge of a cast shadow
   of the planned scene under the sun its shadows show (:mod:`~mrcheck.apps.discrepancies.shadows`),
   closed morphologically and grouped into connected regions; a region with at least
   :data:`MIN_REGION_PIXELS` edge pixels is an "extra" suggestion (an added object, clutter).
   A group wholly inside CAD faces above floor level (``PlannedView.ground``,
   :func:`~mrcheck.apps.discrepancies.planned.ground_pixels`) is texture -- print, labels --
   and dropped: an added object stands on the floor, so its edges reach down to floor pixels.
7. **Neighbours** (:mod:`~mrcheck.apps.discrepancies.neighbours`, issue 41): a part next to a
   changed one is judged on the pixels only it explains. The suspects, strongest first, claim
   their planned image and their image at the best shift (grown by the shift search's reach);
   a weaker suspect is scored again outside what is claimed,
   and unflagged (``explained_by`` the neighbour) when that does not hold on its own while the
   neighbour's flag does without its pixels (figures: docs/discrepancy-evaluation.md). The
   unexplained regions do not claim their boxes: on LM-O's cluttered desk (23-26 regions a
   photo) they took every flag, 14 of 16 moved objects found -> 6, the held-out photo's 15 -> 0.
8. **Markers** (:mod:`~mrcheck.apps.discrepancies.markers`) of suspects lie on a pixel of the
   part's own planned image (the nearest to its unsupported outline's centre) and carry its
   instance id as their part.

The functions named above are in the package's modules ``ids`` (id buffers), ``edges`` and
``planned``; the constants in :mod:`mrcheck.apps.discrepancies.thresholds`. The heat map, the report
and the evaluation harness (protocol, and what the method still misses) are the modules
:mod:`~mrcheck.apps.discrepancies.heatmap`, :mod:`~mrcheck.apps.discrepancies.report` and
:mod:`~mrcheck.eval.discrepancy_eval`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import cv2
import numpy as np

from mrcheck.apps.discrepancies.consensus import expected_shifts
from mrcheck.apps.discrepancies.contact import contact_lines, object_sized
from mrcheck.apps.discrepancies.edges import (
    edge_threshold,
    orientation_bin,
    oriented_support,
    outline_normals,
    photo_edges,
    shifted_support,
    texture_edges,
)
from mrcheck.apps.discrepancies.light import estimate_light, relit
from mrcheck.apps.discrepancies.markers import Marker, suggested_markers
from mrcheck.apps.discrepancies.neighbours import separate_neighbours
from mrcheck.apps.discrepancies.planned import PlannedView, planned_view
from mrcheck.apps.discrepancies.shadows import fit_sun, shadow_edges
from mrcheck.apps.discrepancies.structure import Region, far_from_cad, plain_ground, unexplained_regions
from mrcheck.apps.discrepancies.thresholds import (
    CONSENSUS_REACH_PX,
    DISCRIMINATIVE_FLOOR,
    DISCRIMINATIVE_THRESHOLD,
    EXPECTED_CONTRAST,
    MIN_EDGE_PIXELS,
    SCORE_THRESHOLD,
    default_tolerance,
    shift_radius,
)
from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.scene.model import Scene


@dataclass
class Suspect:
    """One scored part instance (every instance with enough outline, suspect or not)."""

    id: str  # the instance id (Part.instance_ids)
    part: str  # the part's name
    name: str  # the instance id again, as the review's markers name it
    score: float  # 1 - support^2 / best shifted support (module docstring)
    support: float  # share of the outline with an oriented photo edge, as planned
    best_shift_support: float  # the same at the best shift
    best_shift: list[int]  # [dx, dy] px of that shift
    edge_pixels: int  # outline pixels scored
    thin: bool  # nowhere wider than 2 (T - 1) px: scored, never a suspect
    discriminative_score: float | None  # the score on the discriminative outline (None: too few pixels)
    discriminative_pixels: int
    bbox: list[int]  # [x0, y0, x1, y1] of the instance's visible pixels
    centre: list[float]  # [x, y] of its unsupported outline (else of its pixels)
    # edge_pixels, support, score: over the *expected* outline (shown as an edge by the planned render)
    suspect: bool
    # what the scene without the part shows inside its image (the edges of what it hides):
    # their pixels, and the share of them with an oriented photo edge (None: too few to judge)
    revealed_pixels: int = 0
    revealed_support: float | None = None
    # an imported (IFC/STEP) element's {"name", "ifc_class", "storey"}; None for other scenes
    element: dict | None = None
    # flagged on its whole outline, but not on the pixels only it explains: the id of the
    # stronger suspect next to it whose change explains the flag (.neighbours)
    explained_by: str | None = None

    @property
    def element_label(self) -> str:
        """ " (IfcColumn column-A01, Ground floor)" for an imported element, else ""."""
        if not self.element:
            return ""
        what = " ".join(v for v in (self.element["ifc_class"], self.element["name"]) if v)
        text = ", ".join(v for v in (what, self.element["storey"]) if v)
        return f" ({text})" if text else ""


@dataclass
class Detection:
    """What :func:`detect` found: the JSON-able findings and the arrays behind them."""

    tolerance_px: float
    threshold: float
    suspects: list[Suspect]  # every scored instance, ranked by score (suspect True or not)
    regions: list[Region]  # unexplained photo structure, largest first
    suggested_markers: list[Marker]
    planned: PlannedView  # the planned view it was compared with (render, cad, ids, depth, labels)
    supported: np.ndarray  # (H, W) bool CAD edge pixels with an oriented photo edge near
    unexplained: np.ndarray  # (H, W) bool photo edge pixels far from every CAD edge
    warnings: list[str] = field(default_factory=list)  # for the report (the command adds them)
    pose_sigma_px: float = 0.0  # the pose's 1-sigma overlay error the scores allowed for (detect)

    @property
    def flagged(self) -> list[Suspect]:
        """The suspects proper (``suspect`` True), ranked."""
        return [s for s in self.suspects if s.suspect]

    def to_dict(self) -> dict:
        """The JSON part, keys in the order of ``suspects.json``."""
        return {
            "tolerance_px": self.tolerance_px,
            "threshold": self.threshold,
            "pose_sigma_px": self.pose_sigma_px,
            "warnings": list(self.warnings),
            "suspects": [asdict(s) for s in self.suspects],
            "regions": [asdict(r) for r in self.regions],
            "suggested_markers": [asdict(m) for m in self.suggested_markers],
        }


@dataclass(frozen=True)
class _Support:
    """The photo's oriented edges against the planned CAD edges, shared by every instance."""

    edges: np.ndarray  # (H, W) bool photo edges
    cad_bins: np.ndarray  # (H, W) orientation bin of the CAD edges' normals
    supported: np.ndarray  # (H, W) bool CAD edges with an oriented photo edge within the tolerance
    padded: np.ndarray  # the oriented support maps padded by radius
    radius: int  # px the shifted outlines reach
    angle: np.ndarray  # (H, W) the photo edges' normal direction, radians mod pi
    expected: np.ndarray | None = None  # (H, W) bool outline pixels the planned render itself shows as an edge


def _support(photo: np.ndarray, cad: np.ndarray, tol: float, high: float | None = None) -> _Support:
    edges, angle = photo_edges(photo, high)
    support_maps = oriented_support(edges, angle, tol)
    cad_bins = orientation_bin(outline_normals(cad))
    supported = cad & np.take_along_axis(support_maps, cad_bins[None], 0)[0]
    radius = shift_radius(tol)
    padded = np.pad(support_maps, ((0, 0), (radius, radius), (radius, radius)))
    return _Support(edges, cad_bins, supported, padded, radius, angle)


def _shift_score(mask: np.ndarray, sup: _Support, expected=(0, 0), pose_reach: float = 0.0):
    """(score, support as planned, best shifted support, (dy, dx) index of the best) of an
    outline; "as planned" is the unshifted support or, when larger, the best within
    :data:`CONSENSUS_REACH_PX` of the ``expected`` (dx, dy) shift
    (:func:`~mrcheck.apps.discrepancies.consensus.expected_shifts`): the
    shift the parts around it show explains a shift, it never counts against a part in place;
    nor does a shift within ``pose_reach`` px (the pose's own 2-sigma, ``detect``'s
    ``pose_sigma_px``)."""
    shifts = shifted_support(mask, sup.cad_bins, sup.padded, sup.radius)
    best = float(shifts.max())
    dy, dx = np.mgrid[-sup.radius : sup.radius + 1, -sup.radius : sup.radius + 1]
    near = np.hypot(dx, dy) <= pose_reach
    if expected != (0, 0):
        near |= np.hypot(dx - expected[0], dy - expected[1]) <= CONSENSUS_REACH_PX
    support = max(float(shifts[sup.radius, sup.radius]), float(shifts[near].max()) if near.any() else 0.0)
    # a part where it was planned matches best unshifted, however faint its edges are; a
    # displaced copy matching better is a move, and a poor match everywhere is a missing part
    # (clipped at 0: float sums put a fully supported outline's support a hair above 1)
    score = max(0.0, 1.0 - support * support / best) if best > 0 else 1.0
    return score, support, best, np.unravel_index(int(np.argmax(shifts)), shifts.shape)


def _discriminative_score(
    planned: PlannedView, index: int, sup: _Support, expected=(0, 0), pose_reach: float = 0.0, exclude=None
):
    """(score or None, pixels) on the discriminative outline only (what the scene without the
    part would not show): neighbours' parallel edges at the planned place no longer count."""
    if index not in planned.discriminative:
        return None, 0
    mask = planned.discriminative[index].full(planned.owner.shape)
    if sup.expected is not None:
        mask &= sup.expected
    if exclude is not None:
        mask &= ~exclude
    pixels = int(np.count_nonzero(mask))
    if pixels < MIN_EDGE_PIXELS:
        return None, pixels
    return _shift_score(mask, sup, expected, pose_reach)[0], pixels


def _revealed_support(planned: PlannedView, index: int, sup: _Support):
    """(share with an oriented photo edge or None, pixels) of the edges the part hides: seen in
    the photo, the part is not (all) there; hidden, it is."""
    if index not in planned.revealed:
        return None, 0
    rev = planned.revealed[index]
    y0, y1, x0, x1 = rev.mask.box
    ys, xs = np.nonzero(rev.mask.mask)
    if len(ys) < MIN_EDGE_PIXELS:
        return None, len(ys)
    r = sup.radius
    seen = sup.padded[rev.bins[ys, xs], ys + y0 + r, xs + x0 + r]
    return float(seen.mean()), len(ys)


def _is_thin(inside: np.ndarray, tol: float) -> bool:
    """A part a few px wide (a fence post, the wires of a mesh panel at a distance) has both
    sides of its outline within one tolerance: any thin neighbour "supports" it and a faint one
    does not, so its score is reported but never a suspect. A band w px wide has a largest
    distance-to-outside d = ceil(w / 2); d < T means w <= 2 (T - 1) for a whole T. d <= T
    (w <= 2 T) was measured too: recall on moved parts 12/13 -> 10/13 (docs/discrepancy-evaluation.md)."""
    return bool(cv2.distanceTransform(np.pad(inside, 1).astype(np.uint8), cv2.DIST_L2, 5).max() < tol)


def _suspect(
    planned: PlannedView,
    index: int,
    sup: _Support,
    tol: float,
    threshold: float,
    expected=(0, 0),
    pose_reach: float = 0.0,
    exclude: np.ndarray | None = None,
) -> Suspect | None:
    """The scored instance ``index``, or None when its outline is too small to judge;
    ``expected``: the (dx, dy) shift the parts around it show
    (:func:`~mrcheck.apps.discrepancies.consensus.expected_shifts`); ``exclude``: outline
    pixels not scored (those a stronger neighbour's change claims, :mod:`.neighbours`)."""
    mask = planned.owner == index
    if sup.expected is not None:
        mask &= sup.expected
    if exclude is not None:
        mask &= ~exclude
    n = int(mask.sum())
    if n < MIN_EDGE_PIXELS:
        return None
    inside = planned.ids == index
    thin = _is_thin(inside, tol)
    score, support, best, (dy, dx) = _shift_score(mask, sup, expected, pose_reach)
    disc_score, disc_n = _discriminative_score(planned, index, sup, expected, pose_reach, exclude)
    rev_support, rev_n = _revealed_support(planned, index, sup)
    flagged = score >= threshold or (
        disc_score is not None and disc_score >= DISCRIMINATIVE_THRESHOLD and score >= DISCRIMINATIVE_FLOOR
    )
    ys, xs = np.nonzero(inside)
    bad_y, bad_x = np.nonzero(mask & ~sup.supported)
    cy, cx = (bad_y.mean(), bad_x.mean()) if len(bad_y) else (ys.mean(), xs.mean())
    part, name = planned.labels[index]
    r = sup.radius
    return Suspect(
        id=name,
        part=part,
        name=name,
        score=round(score, 4),
        support=round(support, 4),
        best_shift_support=round(best, 4),
        best_shift=[int(dx) - r, int(dy) - r],
        edge_pixels=n,
        thin=thin,
        discriminative_score=None if disc_score is None else round(disc_score, 4),
        discriminative_pixels=disc_n,
        bbox=[int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())],
        centre=[round(float(cx), 1), round(float(cy), 1)],
        suspect=bool(flagged and not thin),
        revealed_pixels=rev_n,
        revealed_support=None if rev_support is None else round(rev_support, 4),
    )


def detect(
    scene: Scene,
    camera: Camera,
    photo: np.ndarray,
    tolerance_px: float | None = None,
    renderer=None,
    threshold: float = None,
    planned: PlannedView | None = None,
    pose_sigma_px: float = 0.0,
) -> Detection:
    """Compare the planned ``scene`` seen by ``camera`` with ``photo``; the reusable core.

    ``pose_sigma_px``: the pose's 1-sigma overlay error (SHOT.json's ``expected_overlay_error_px``):
    an outline matching best within 2 sigma of its plan is not moved (the pose cannot tell).

    ``planned`` is :func:`planned_view` of scene and camera
    when already computed (``renderer`` is used to make it otherwise). Returns the
    :class:`Detection`: every scored instance ranked, with ``suspect`` True for the suspects;
    unexplained regions; suggested review markers; the arrays for the heat map and the evaluation.
    """
    if photo.shape[:2] != (camera.height, camera.width):
        raise MrcheckError(f"photo is {photo.shape[1]}x{photo.shape[0]}, the camera {camera.width}x{camera.height}")
    tol = default_tolerance(camera) if tolerance_px is None else float(tolerance_px)
    threshold = SCORE_THRESHOLD if threshold is None else float(threshold)
    planned = planned_view(scene, camera, renderer) if planned is None else planned
    high = edge_threshold(photo)  # Canny's threshold of the photo, for its edges and the expected outline's
    light = photo_light(planned, photo)
    sup = replace(_support(photo, planned.cad, tol, high), expected=expected_outline(planned, photo, tol, high, light))
    owner = planned.owner
    first = [
        s
        for index in np.unique(owner[owner >= 0])
        if (s := _suspect(planned, int(index), sup, tol, threshold, pose_reach=2.0 * pose_sigma_px)) is not None
    ]
    # judged again against the shift the parts around each one show (a registration a few px off
    # shifts them all alike: not a move)
    index_of = {name: i for i, (_, name) in enumerate(planned.labels)}
    expected = expected_shifts([s.bbox for s in first], [s.best_shift for s in first])
    shift_of = {s.id: e for s, e in zip(first, expected)}
    suspects = [
        s if e == (0, 0) else _suspect(planned, index_of[s.id], sup, tol, threshold, e, 2.0 * pose_sigma_px) or s
        for s, e in zip(first, expected)
    ]
    suspects.sort(key=lambda s: (-s.score, s.id))

    def rescore(index: int, claimed: np.ndarray, s: Suspect) -> Suspect | None:
        return _suspect(planned, index, sup, tol, threshold, shift_of[s.id], 2.0 * pose_sigma_px, claimed)

    contact, support = contact_lines(scene, camera, planned, sup.edges, sup.angle, tol)
    far = far_from_cad(planned, tol)
    texture = texture_edges(photo, sup.edges, plain_ground(planned, far))
    sun = fit_sun(planned.caster, camera, planned, photo)
    shadow = shadow_edges(planned.caster, camera, planned.depth, planned.normals, sun)
    regions, unexplained = unexplained_regions(sup.edges & ~contact & ~texture & ~shadow, planned, tol, far)
    regions = [r for r in regions if object_sized(r.bbox, camera, support)]
    suspects = separate_neighbours(suspects, index_of, planned.ids, rescore, shift_radius(tol))
    _add_elements(scene, suspects)
    markers, arrays = suggested_markers(suspects, regions, planned), (planned, sup.supported, unexplained)
    return Detection(tol, threshold, suspects, regions, markers, *arrays, pose_sigma_px=pose_sigma_px)


NOT_FITTED = object()  # expected_outline's light: fit it from the photo


def photo_light(planned: PlannedView, photo: np.ndarray):
    """The photo's light fitted over the planned surfaces (:func:`.light.estimate_light`), None
    when it cannot be fitted (no shaded planned view, too few surface pixels)."""
    if planned.shaded is None or planned.normals is None:
        return None
    return estimate_light(photo, planned.albedo, planned.normals, planned.ids, planned.cad)


def expected_outline(
    planned: PlannedView, photo: np.ndarray, tol: float, high: float | None = None, light=NOT_FITTED
) -> np.ndarray:
    """(H, W) bool: the CAD outline pixels the photo can be expected to show (issue 22) -- the
    edges of the planned view relit by the photo's own light (:mod:`~mrcheck.apps.discrepancies.light`;
    the headlight render when no light can be fitted), found at :data:`EXPECTED_CONTRAST` times
    the photo's Canny threshold (``high``; :func:`edge_threshold` of the photo when not given).
    An outline without that contrast under that light (grey on grey, a yellow post against a
    pale wall in the sun, a faint edge the photo's noise buries) says nothing when the photo
    lacks it."""
    predicted = planned.render
    shaded = planned.shaded
    light = photo_light(planned, photo) if light is NOT_FITTED else light
    if light is not None and shaded is not None:
        predicted = shaded.to_photo(relit(shaded.render, shaded.normals, shaded.light, light))
    high = edge_threshold(photo) if high is None else high
    return _support(predicted, planned.cad, tol, EXPECTED_CONTRAST * high).supported


def _add_elements(scene: Scene, suspects: list[Suspect]) -> None:
    """Each suspect's imported element (name, IFC class, storey), where the scene knows one."""
    known = {
        iid: info
        for part in scene.parts
        for iid, info in zip(part.instance_ids, part.instance_info)
        if info.name or info.ifc_class or info.storey
    }
    for suspect in suspects:
        info = known.get(suspect.id)
        if info is not None:
            suspect.element = {"name": info.name, "ifc_class": info.ifc_class, "storey": info.storey}


__all__ = ["detect", "Detection", "Suspect", "Region", "Marker"]
