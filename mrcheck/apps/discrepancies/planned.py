"""What the planned scene looks like through a camera, lens included: the render, its CAD edges,
the id buffer, the scored outlines and the *discriminative* outlines (what the scene without
each part would not show). It depends only on scene and camera, so an evaluation over many
photos of one view computes it once (:func:`planned_view`).

CAD edges are :func:`mrcheck.mr.overlay.cad_edges` of the planned render's depth (inverse depth
second differences: silhouettes and creases), resampled into the photo's geometry as the overlay
does, plus the boundaries between different instance ids (two touching parts at the same depth
have a real outline that depth alone does not show).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from mrcheck.apps.discrepancies.edges import (
    cad_edge_owner,
    orientation_bin,
    oriented_support,
    outline_normals,
    silhouettes,
)
from mrcheck.apps.discrepancies.ids import behind_ids, object_ids, world_points
from mrcheck.apps.discrepancies.light import Light
from mrcheck.apps.discrepancies.thresholds import (
    FLOOR_BAND,
    GROUND_HEIGHT,
    GROUND_SHARE,
    MIN_EDGE_PIXELS,
    default_tolerance,
    shift_radius,
)
from mrcheck.core.camera import Camera
from mrcheck.mr.lens import distort_to_photo, distortion_map
from mrcheck.mr.shot import cad_edges, photo_frame
from mrcheck.render.composite import BACKGROUND as RENDER_BACKGROUND
from mrcheck.render.composite import SHADING, light_direction
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene
from mrcheck.scene.raycast import build_caster


@dataclass(frozen=True)
class BoxMask:
    """A mask given only inside a box of the image (most of an outline's image is empty)."""

    box: tuple[int, int, int, int]  # y0, y1, x0, x1
    mask: np.ndarray  # (y1 - y0, x1 - x0) bool

    def full(self, shape) -> np.ndarray:
        """The mask in the whole image of ``shape`` (False outside the box)."""
        y0, y1, x0, x1 = self.box
        out = np.zeros(shape, bool)
        out[y0:y1, x0:x1] = self.mask
        return out


@dataclass(frozen=True)
class Revealed:
    """The CAD edges the planned scene *without* one part shows inside that part's image (the
    edges of what it hides), with their orientation bins: seen in the photo, they are positive
    evidence that the part is not there."""

    mask: BoxMask
    bins: np.ndarray  # orientation bin of every pixel of the mask's box


@dataclass(frozen=True)
class Shaded:
    """The planned render before its resampling into the photo's lens geometry, with its G-buffer
    normals and fitted light: relighting re-shades the render's own pixels there and resamples
    the result as the render was (a thin wire's pixels stay the rasteriser's, not the ray cast's)."""

    render: np.ndarray  # (h, w, 3) uint8 the ideal (padded) Phong render
    normals: np.ndarray  # (h, w, 3) float32 its unit camera-space normals (0: background)
    light: Light  # the render's own light (the renderer's headlight and Phong weights)
    maps: tuple | None  # the lens resampling (mrcheck.mr.lens.distort_to_photo)
    offset: tuple
    shape: tuple

    def to_photo(self, image: np.ndarray) -> np.ndarray:
        """An image of the ideal render's frame in the photo's pixels."""
        return distort_to_photo(image, self.maps, self.offset, self.shape)


@dataclass
class PlannedView:
    """The planned scene through one camera, in the photo's (distorted) pixels."""

    render: np.ndarray  # (H, W, 3) uint8 Phong render, for the heat map's overlay
    cad: np.ndarray  # (H, W) bool CAD edges: silhouettes, creases and instance boundaries
    ids: np.ndarray  # (H, W) int32 visible instance (ids.BACKGROUND = none)
    depth: np.ndarray  # (H, W) float32 camera depth of the visible instance (0 = none)
    labels: list  # (part name, instance id) of every instance index
    outline: np.ndarray  # (H, W) bool the scored outline pixels (silhouettes)
    owner: np.ndarray  # (H, W) int32 the instance each outline pixel belongs to (-1 elsewhere)
    discriminative: dict  # instance index -> BoxMask of its discriminative outline pixels
    revealed: dict = field(default_factory=dict)  # instance index -> Revealed (what its removal uncovers)
    ground: np.ndarray | None = None  # (H, W) bool planned surface at floor level (:func:`ground_pixels`)
    # for fitting the photo's light (:mod:`~mrcheck.apps.discrepancies.light`) and relighting the view by it
    albedo: np.ndarray | None = None  # (H, W, 3) float32 linear part colour (the render's background elsewhere)
    normals: np.ndarray | None = None  # (H, W, 3) float32 unit camera-space normals (OpenCV axes; 0: none)
    shaded: Shaded | None = None  # the render before the lens resampling, to relight
    caster: object = None  # the scene's SceneCaster around the camera (mrcheck.scene.raycast): cast shadows


def discriminative_outlines(
    ids: np.ndarray,
    depth: np.ndarray,
    cad: np.ndarray,
    owner: np.ndarray,
    behind: tuple[np.ndarray, np.ndarray],
    fx: float,
    tol: float,
    revealed: dict | None = None,
) -> dict:
    """Per scored instance, the outline pixels that tell "part there" from "part gone": its
    :func:`~mrcheck.apps.discrepancies.edges.silhouettes` pixels (``owner``) with no CAD edge of
    the same orientation (within ``tol``) in the planned scene *without* it -- the id / depth
    buffer with its pixels replaced by ``behind`` (:func:`~mrcheck.apps.discrepancies.ids.behind_ids`):
    what the photo shows if the part is not there. A bollard's sides in front of a fence post's
    parallel sides are dropped, its top against the floor is kept. Returns ``{index: BoxMask}``;
    fills ``revealed`` (when given) with ``{index: Revealed}``: the edges of that "part gone"
    view strictly inside the part's image."""
    bids, bdepth = behind
    cad_bins = orientation_bin(outline_normals(cad))
    pad = shift_radius(tol) + 6
    h, w = ids.shape
    out = {}
    for index in np.unique(owner[owner >= 0]):
        mask = owner == index
        if np.count_nonzero(mask) < MIN_EDGE_PIXELS:
            continue
        ys, xs = np.nonzero(mask | (ids == index))
        y0, y1, x0, x1 = (
            max(0, ys.min() - pad),
            min(h, ys.max() + 1 + pad),
            max(0, xs.min() - pad),
            min(w, xs.max() + 1 + pad),
        )
        wid, wdepth = ids[y0:y1, x0:x1].copy(), depth[y0:y1, x0:x1].copy()
        gone = wid == index
        wid[gone], wdepth[gone] = bids[y0:y1, x0:x1][gone], bdepth[y0:y1, x0:x1][gone]
        without = silhouettes(wid, wdepth) | cad_edges(wdepth, fx)
        _clear_border(without)
        without_normals = outline_normals(without)
        explained = oriented_support(without, without_normals, tol)
        keep = mask[y0:y1, x0:x1] & ~np.take_along_axis(explained, cad_bins[y0:y1, x0:x1][None], 0)[0]
        out[int(index)] = BoxMask((y0, y1, x0, x1), keep)
        if revealed is not None:
            revealed[int(index)] = Revealed(
                BoxMask((y0, y1, x0, x1), _inside_only(without, gone, tol)), orientation_bin(without_normals)
            )
    return out


def _inside_only(without: np.ndarray, gone: np.ndarray, tol: float) -> np.ndarray:
    """The edges of ``without`` strictly inside the part's region ``gone`` (eroded by the
    tolerance + 1 px, so that the part's own outline, where the photo has an edge whether the
    part is there or not, does not count)."""
    k = 2 * int(np.ceil(tol)) + 3
    inner = cv2.erode(gone.astype(np.uint8), np.ones((k, k), np.uint8)) > 0
    return without & inner


def ground_pixels(scene: Scene, camera: Camera, depth: np.ndarray, maps) -> np.ndarray:
    """(H, W) bool: the pixels whose planned surface lies at floor level -- within
    :data:`GROUND_HEIGHT` (or :data:`GROUND_SHARE` of the scene's height, if less) above the
    lowest upward face the camera sees, and facing up -- when that face lies in the bottom
    :data:`FLOOR_BAND` of the scene's height (else the scene has no floor in view: a box alone,
    whose top is its lowest upward face). An added object stands on the floor, so the photo structure
    it makes reaches down to such pixels; structure wholly inside other CAD faces (the printed
    artwork of a box, a label on a machine) cannot be one (:func:`~.detector.detect`)."""
    seen = depth > 0
    if not seen.any():
        return seen
    world = world_points(camera, depth, maps)
    # the surface normal from neighbouring pixels' points: only upward faces are a floor
    normal = np.cross(np.gradient(world, axis=1), np.gradient(world, axis=0))
    up = np.abs(normal[..., 2]) > 0.9 * np.maximum(np.linalg.norm(normal, axis=-1), 1e-12)
    floor = seen & up
    lo, hi = scene.bounds()[:, 2]
    if not floor.any():
        return floor
    z = np.where(floor, world[..., 2], np.inf)
    level = np.percentile(z[floor], 1.0)  # the lowest upward face the camera sees (a slab's side is no floor)
    if level - lo > FLOOR_BAND * (hi - lo):
        return np.zeros_like(seen)  # no floor in view or in the scene (a box on its own)
    return floor & (z <= level + min(GROUND_HEIGHT, GROUND_SHARE * (hi - lo)))


def _clear_border(mask: np.ndarray) -> None:
    """The frame border is no edge of the scene."""
    mask[[0, -1], :] = False
    mask[:, [0, -1]] = False


def planned_view(scene: Scene, camera: Camera, renderer=None) -> PlannedView:
    """What the planned ``scene`` looks like through ``camera`` (lens included); ``renderer``: a
    :class:`~mrcheck.render.renderer.Renderer` of ``scene`` to reuse (else one is made)."""
    maps = distortion_map(camera)
    own = renderer is None
    renderer = Renderer(scene) if own else renderer
    try:
        # full detail (lod_px=0): the outlines are measured to the pixel, and it is one render; the
        # look the detector's thresholds were measured on (no anti-aliasing, clipped tone)
        settings = RenderSettings(lod_px=0.0, antialias=False, tone="clip")
        frame, render_camera, offset, maps = photo_frame(renderer, camera, ["phong"], settings, maps, want_normals=True)
    finally:
        if own:
            renderer.release()
    shape = (camera.height, camera.width)
    render = distort_to_photo(frame["phong"].image, maps, offset, shape)
    edges = cad_edges(frame.depth, render_camera.fx)
    cad = distort_to_photo(edges.astype(np.float32), maps, offset, shape) > 0.25
    caster = build_caster(scene, camera.center)  # one BVH for the visible and the behind pass
    ids, depth, labels = object_ids(scene, camera, maps, caster)
    outline = silhouettes(ids, depth)
    cad |= outline  # touching parts at one depth: the outline is real too
    for m in (cad, outline):
        _clear_border(m)
    # support is judged on outlines only: a crease between two faces may show no contrast
    # under another light (a corrugated wall in the sun), an outline against what lies behind
    # almost always does
    owner = cad_edge_owner(ids, depth, outline)
    behind = behind_ids(scene, camera, ids, depth, maps, caster=caster)
    revealed = {}
    discriminative = discriminative_outlines(
        ids, depth, cad, owner, behind, camera.fx, default_tolerance(camera), revealed
    )
    # the render's light is known: fitting it as a photo's confuses ambient with diffuse light (a
    # headlight lights every face it sees about equally), and the relit fence posts' sides came out wrong
    light = Light(
        light_direction(render_camera, settings.light), SHADING["AMBIENT_VALUE"], SHADING["DIFFUSE_VALUE"], 0.0
    )
    shaded = Shaded(frame["phong"].image, frame.normals, light, maps, offset, shape)
    return PlannedView(
        render,
        cad,
        ids,
        depth,
        labels,
        outline,
        owner,
        discriminative,
        revealed,
        ground_pixels(scene, camera, depth, maps),
        _albedo(scene, ids, labels),
        _unit(distort_to_photo(frame.normals, maps, offset, shape)),
        shaded,
        caster,
    )


def _albedo(scene: Scene, ids: np.ndarray, labels: list) -> np.ndarray:
    """(H, W, 3) float32 linear colour of the part each pixel sees (the render's background elsewhere)."""
    colour = {part.name: part.color[:3] for part in scene.parts}
    table = np.array([colour[part] for part, _ in labels] + [RENDER_BACKGROUND], np.float32)
    return table[ids]  # ids.BACKGROUND (-1) picks the last row


def _unit(normals: np.ndarray) -> np.ndarray:
    """Resampled normals made unit again (zero where there is none)."""
    norm = np.linalg.norm(normals, axis=-1, keepdims=True)
    return np.where(norm > 0.5, normals / np.maximum(norm, 1e-6), 0.0).astype(np.float32)


__all__ = ["PlannedView", "Shaded", "BoxMask", "Revealed", "planned_view", "discriminative_outlines", "ground_pixels"]
