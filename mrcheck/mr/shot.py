"""What one registered shot makes: the CAD rendered for its photo, its edges, its overlay.

:func:`render_for_photo` renders the ideal pinhole image over the photo's whole distorted frame
(:func:`mrcheck.mr.lens.padded_camera`), :func:`cad_edges` finds the CAD's edges in the depth,
:func:`overlay_shot` is ``mrcheck overlay``: everything checked first, then render and blend.

CAD edges (``--edges``) come from the depth buffer alone. On any plane the *inverse* depth
``1/z`` is an affine function of the pixel coordinates, so its second differences are zero on
flat faces at every viewing angle (plain depth is not: a floor seen at a grazing angle would
light up). A crease between two faces is a step in the gradient of ``1/z``, a silhouette a step
in ``1/z`` itself: both show up as a large second difference relative to ``1/z``. The threshold
is in units of ``1/fx`` because that is what a crease's second difference scales with (a change
of surface slope seen through the lens).
"""

from __future__ import annotations

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_shot, read_photo
from mrcheck.core.output import IMAGE_SUFFIXES, check_not_inputs, check_output_path
from mrcheck.mr.lens import distortion_map, padded_camera
from mrcheck.mr.overlay import (
    STUDY_ORDER,
    check_alpha,
    overlay_images,
    parse_edge_color,
    study_sheet,
)
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.render.views import warn_if_nothing_in_view
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

CREASE_THRESHOLD = 0.3  # second difference of 1/z relative to 1/z, times fx (~17 degrees face-on)


def cad_edges(depth: np.ndarray, fx: float, threshold: float = CREASE_THRESHOLD) -> np.ndarray:
    """(H, W) bool silhouette and crease pixels of a linear depth buffer (0 = background).

    A pixel is an edge when the second difference of inverse depth across it (horizontally or
    vertically) exceeds ``threshold / fx`` relative to its inverse depth, or when it is
    geometry next to background (background is inverse depth 0, the limit of a far surface).
    """
    depth = np.asarray(depth, np.float64)
    inverse = np.where(depth > 0.0, 1.0 / np.where(depth > 0.0, depth, 1.0), 0.0)  # background: 1/inf
    edges = np.zeros(depth.shape, bool)
    limit = threshold / fx
    for axis in (0, 1):
        w = np.moveaxis(inverse, axis, 0)
        centre = w[1:-1]
        second = np.abs(w[2:] - 2.0 * centre + w[:-2])
        scale = np.maximum(np.maximum(w[2:], w[:-2]), centre)  # the nearest of the three
        hit = second > limit * scale
        # a step marks the pixels on both sides of it: silhouettes are 2 px wide, centred on the edge
        np.moveaxis(edges, axis, 0)[1:-1] |= hit
    return edges


def photo_frame(
    renderer: Renderer, camera: Camera, modes, settings: RenderSettings, maps=None, want_normals: bool = False
):
    """The ideal render (a :class:`mrcheck.render.renderer.Frame`: images, depth, the normals
    when ``want_normals``) covering the photo's distorted frame. Returns ``(frame, render_camera, offset, maps)``."""
    if maps is None:
        maps = distortion_map(camera)
    render_camera, offset = padded_camera(camera, maps)
    # the AO radius stays that of the photo's height, not of the padded render's
    settings = settings.validated(camera.height)
    return renderer.render(render_camera, modes, settings, want_normals=want_normals), render_camera, offset, maps


def render_for_photo(renderer: Renderer, camera: Camera, modes, settings: RenderSettings, want_edges: bool, maps=None):
    """Ideal renders covering the photo's distorted frame.

    ``maps``: the :func:`mrcheck.mr.lens.distortion_map` of ``camera`` when already computed (several renders
    of one shot). Returns ``(renders, edges, offset, maps)``, ready for :func:`mrcheck.mr.overlay.overlay_images`.
    """
    frame, render_camera, offset, maps = photo_frame(renderer, camera, modes, settings, maps)
    edges = cad_edges(frame.depth, render_camera.fx) if want_edges else None
    return {m: frame[m].image for m in modes}, edges, offset, maps


def overlay_shot(
    shot,
    scene,
    mode="vector",
    alpha=0.5,
    edges=False,
    edge_color="ff00ff",
    intensity=None,
    samples=16,
    output=None,
    antialias=True,
    accumulate=1,
) -> np.ndarray:
    """``mrcheck overlay``: the (H, W, 3) uint8 overlay of ``shot`` (the study's sheet for mode
    all). Everything is checked before the work: ``output``, when given, is where the caller
    will write the image (its suffix, its folder, not one of the inputs)."""
    if output is not None:
        output = check_output_path(output, IMAGE_SUFFIXES)
    alpha = check_alpha(alpha)
    color = parse_edge_color(edge_color)
    settings = RenderSettings(samples=samples, intensity=intensity, antialias=antialias, accumulate=accumulate)
    camera, photo_path = load_shot(shot)
    check_not_inputs(
        [output] if output is not None else [],
        [("the shot", shot), ("the shot's photo", photo_path), ("the scene", scene_files(scene))],
    )
    settings.validated(camera.height)  # option errors before the scene is loaded
    photo = read_photo(photo_path, camera)

    modes = list(STUDY_ORDER) if mode == "all" else [mode]
    loaded = load_scene(scene, progress=True)
    renderer = Renderer(loaded)
    try:
        frame, render_camera, offset, maps = photo_frame(renderer, camera, modes, settings)
        renders = {m: frame[m].image for m in modes}
        edge_mask = cad_edges(frame.depth, render_camera.fx) if edges else None
        # the overlay would be the bare photo
        warn_if_nothing_in_view(frame.depth, None, shot, "shot", "a wrong pose, or the shot of another scene?")
    finally:
        renderer.release()
    mixed = overlay_images(photo, renders, camera, alpha, edge_mask, color, offset, maps)
    if mode != "all":
        return mixed[mode]
    virtual = overlay_images(photo, renders, camera, 0.0, None, color, offset, maps)
    return study_sheet(virtual, mixed, alpha)


__all__ = ["overlay_shot", "render_for_photo", "photo_frame", "cad_edges", "CREASE_THRESHOLD"]
