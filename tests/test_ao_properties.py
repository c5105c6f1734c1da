"""The paper's claims about the vector method, measured on unblurred AO buffers, fixed seeds.

Scheer & Keutel section 3 + docs/papers_notes.md (NOTES): no occlusion on a flat plane, occlusion in
concave corners, a sampling radius whose projection is the same at every depth, and AO that
does not fade with distance (standard SSAO's does).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.render.renderer import DEFAULT_RADIUS_FRACTION

from .conftest import box, render_ao, render_depth, scene_of

W, H = 320, 240


def test_flat_plane_is_unoccluded_in_vector_mode_and_ssao_is_reported(ctx, record_property):
    # a large floor seen obliquely, from grazing far away to steep near the camera
    scene = scene_of(box((400, 400, 0.2), (0, 150, -0.1)))
    camera = Camera.from_look_at((0, 0, 1.7), (0, 8, 0), (0, 0, 1), 60, W, H)
    depth = render_depth(ctx, scene, camera)
    plane = depth > 0
    assert plane.mean() > 0.5  # the test sees a lot of floor

    vector = render_ao(ctx, scene, camera, "vector", samples=16)
    assert vector[plane].min() >= 0.999
    # half resolution reads the full-res G-buffer at (2i, 2j) with K halved exactly: still flat
    half = render_ao(ctx, scene, camera, "vector", samples=16, ao_scale=0.5)
    assert half[plane].min() >= 0.999

    # Standard SSAO on the same plane: report, do not require (NOTES: it is the comparison mode).
    # Its depth-delta test reads the neighbouring pixel's depth, which on a grazing floor
    # differs from the sample's by more than the bias: false occlusion far away.
    ssao = render_ao(ctx, scene, camera, "ssao", samples=16)
    record_property("ssao_plane_min", float(ssao[plane].min()))
    record_property("ssao_plane_mean", float(ssao[plane].mean()))
    record_property("ssao_plane_share_below_0.99", float((ssao[plane] < 0.99).mean()))
    print(
        f"ssao on a flat floor: min {ssao[plane].min():.3f}, mean {ssao[plane].mean():.4f}, "
        f"{(ssao[plane] < 0.99).mean():.1%} of pixels below 0.99"
    )


# sample counts: the sample loop is unrolled by the binary digits of the count up to 128
# (shaders/ao_unroll.glsl; 13 = 8 + 4 + 1) and stays a loop above (129)
@pytest.mark.parametrize("samples", [13, 36, 129])
def test_frontal_plane_is_unoccluded_in_vector_mode(ctx, samples):
    scene = scene_of(box((50, 0.2, 50), (0, 10, 0)))
    camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 60, W, H)
    ao = render_ao(ctx, scene, camera, "vector", samples=samples)
    assert ao.min() >= 0.999


def _corner_scene():
    # floor (z = 0) meeting a wall (y = 6): a 90 degree concave crease along x
    return scene_of(box((30, 12, 0.2), (0, 0, -0.1)), box((30, 0.2, 10), (0, 6.1, 5)))


@pytest.mark.parametrize("samples", [36, 129])
def test_concave_corner_is_clearly_occluded(ctx, samples):
    camera = Camera.from_look_at((0, 0, 1.7), (0, 6, 0.3), (0, 0, 1), 60, W, H)
    ao = render_ao(ctx, _corner_scene(), camera, "vector", samples=samples, radius_px=12)
    # the crease line projected from the world, and the AO across it in the middle half
    crease = camera.project(np.array([[x, 6.0, 0.0] for x in np.linspace(-2, 2, 9)]))
    row = int(round(crease[:, 1].mean()))
    band = ao[row - 3 : row + 4, W // 4 : 3 * W // 4]
    assert band.min(axis=0).mean() < 0.6  # darkest across the crease, column by column
    assert band.mean() < 0.85
    assert ao[H - 10 :, W // 4 : 3 * W // 4].min() >= 0.999  # open floor near the camera


def _band_width_px(ao, depth, wall_depth):
    """Darkening-weighted mean distance (pixels) of darkened wall pixels from the occluder."""
    wall = np.abs(depth - wall_depth) < 0.01 * wall_depth
    occluder = (depth > 0) & (depth < 0.99 * wall_depth)
    distance = cv2.distanceTransform((~occluder).astype(np.uint8), cv2.DIST_L2, 5)
    darkening = np.where(wall, 1.0 - ao, 0.0)
    return float((distance * darkening).sum() / max(darkening.sum(), 1e-9)), float(darkening.sum())


def bands_at_2_and_200_m(ctx, mode, **settings):
    """(widths, totals) by distance (2, 200 m) of the AO band around a block 0.1 m out of a
    facing wall, and the same scaled by 100 (see the test below); 64 samples."""
    camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 60, W, H)
    widths, totals = {}, {}
    for distance in (2.0, 200.0):
        s = distance / 2.0
        scene = scene_of(
            box((20 * s, 0.1 * s, 20 * s), (0, distance + 0.05 * s, 0)),
            box((0.6 * s, 0.1 * s, 0.6 * s), (0, distance - 0.05 * s, 0)),
        )
        ao = render_ao(ctx, scene, camera, mode, samples=64, **settings)
        widths[distance], totals[distance] = _band_width_px(ao, render_depth(ctx, scene, camera), distance)
    return widths, totals


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["vector", "ssao", "vector clamped"])
def test_projected_sampling_radius_is_constant_with_depth(ctx, mode):
    # A wall facing the camera with a block standing 0.1 m out of it at 2 m, and the same scaled
    # to stand at 200 m: both views show the same picture, so only the sampling radius decides
    # how wide the AO band around the block is, in pixels.
    # NOTES 6: the optional world clamp turns the vector radius back into a world one
    clamp = {"max_world_radius": 0.12} if mode == "vector clamped" else {}
    widths, totals = bands_at_2_and_200_m(ctx, mode.split()[0], radius_px=12, radius_world=0.12, **clamp)
    assert widths[2.0] > 2.0 and totals[2.0] > 10.0  # there is a band to measure at 2 m
    if mode == "vector":
        assert widths[200.0] == pytest.approx(widths[2.0], rel=0.05)
        assert totals[200.0] == pytest.approx(totals[2.0], rel=0.05)
    else:
        # constant world radius: at 200 m its footprint is 1/100 and the band all but vanishes
        assert totals[200.0] < 0.05 * totals[2.0]


def ring_darkening(ao, ao_without, mask, width_px):
    """Mean darkening an object causes (AO without it minus AO with it) in a ring ``width_px``
    wide around its silhouette. The difference removes what the ground does on its own."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * width_px + 1, 2 * width_px + 1))
    ring = (cv2.dilate(mask.astype(np.uint8), kernel) > 0) & ~mask
    return float(np.clip(ao_without - ao, 0.0, 1.0)[ring].mean())


def _block_on_slab(distance, x, with_block=True):
    """A 2 m machine block on a 5 m slab, tilted so the slab faces the camera (at the origin,
    looking along +y) at 45 degrees wherever it stands: both copies are seen at the same angle."""
    parts = [box((5, 5, 0.2), (0, 0, -0.1))] + ([box((2, 2, 2), (0, 0, 1))] if with_block else [])
    T = trimesh.transformations.rotation_matrix(np.radians(45), (1, 0, 0))
    T[:3, 3] = (x, distance, 0)
    return [p.apply_transform(T) for p in parts]


def blocks_at_5_and_100_m(ctx):
    """(camera, scene, the scene without the blocks, near block's mask, far block's mask) of the
    distance-retention test below: 800x600, 40 degrees."""
    camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 40, 800, 600)
    scene = scene_of(*_block_on_slab(5.0, -2.5), *_block_on_slab(100.0, 18.0))
    slabs = scene_of(*_block_on_slab(5.0, -2.5, False), *_block_on_slab(100.0, 18.0, False))
    depth = render_depth(ctx, scene, camera)
    blocks = (depth > 0) & (np.abs(depth - render_depth(ctx, slabs, camera)) > 1e-3 * depth)
    count, labels = cv2.connectedComponents(blocks.astype(np.uint8))
    assert count == 3, "expected the two blocks as two blobs"
    sizes = [(labels == i).sum() for i in (1, 2)]
    near_mask, far_mask = [(labels == i) for i in np.argsort(sizes)[::-1] + 1]
    return camera, scene, slabs, near_mask, far_mask


@pytest.mark.slow
def test_distance_retention_vector_keeps_ao_far_away_ssao_loses_it(ctx, record_property):
    # The paper's central claim (section 3): identical objects at 5 m and 100 m. Each stands on
    # its own slab seen at the same angle, so distance is the only difference. (On one common
    # floor the far contact is seen at 1 degree, where a pixel row spans metres of depth and no
    # screen-space method sees a crease at all.) The ssao radius equals the vector one at 5 m.
    camera, scene, slabs, near_mask, far_mask = blocks_at_5_and_100_m(ctx)
    radius_px = DEFAULT_RADIUS_FRACTION * camera.height  # the default screen radius
    radius_world = radius_px * 5.0 / camera.fy  # ssao: the same radius at 5 m
    ratios = {}
    for mode in ("vector", "ssao"):
        settings = dict(samples=36, radius_px=radius_px, radius_world=radius_world)
        ao = render_ao(ctx, scene, camera, mode, **settings)
        ao_without = render_ao(ctx, slabs, camera, mode, **settings)
        near = ring_darkening(ao, ao_without, near_mask, int(radius_px))
        far = ring_darkening(ao, ao_without, far_mask, int(radius_px))
        ratios[mode] = far / near
        record_property(f"{mode}_far_over_near", ratios[mode])
        print(f"{mode}: darkening near {near:.4f}, far {far:.4f}, far/near {far / near:.2f}")
    assert ratios["vector"] >= 0.5
    assert ratios["ssao"] < 0.25 * ratios["vector"]
