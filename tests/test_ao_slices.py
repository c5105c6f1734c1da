"""The slice-based comparison modes gtao (Jimenez et al. 2016) and vbao (Therrien et al. 2023)
under the AO property tests of the vector mode (tests/test_ao_properties.py): a plane is
unoccluded, the projected radius is the same at every depth (scale invariance), AO is retained
far away; and vbao's thickness. The shared contract (range, background, a million metres from
the origin, the crease) runs for them in tests/test_ao_modes.py, which covers every mode.
Unblurred AO, fixed seeds."""

from __future__ import annotations

import pytest

from mrcheck.core.camera import Camera
from mrcheck.render.ao.gtao import slices_and_steps
from mrcheck.render.renderer import DEFAULT_RADIUS_FRACTION, RenderSettings

from .conftest import box, render_ao, render_depth, scene_of
from .test_ao_properties import bands_at_2_and_200_m, blocks_at_5_and_100_m, ring_darkening

W, H = 320, 240
SLICE_MODES = ["gtao", "vbao"]


@pytest.mark.parametrize("samples", [1, 2, 13, 16, 36, 64, 128, 512])
def test_sample_budget_is_never_exceeded(samples):
    slices, steps = slices_and_steps(samples)
    assert slices >= 1 and steps >= 1
    assert 2 * slices * steps <= max(samples, 2)


@pytest.mark.parametrize("scale", [1.0, 0.5])
@pytest.mark.parametrize("mode", SLICE_MODES)
def test_planes_are_unoccluded(ctx, mode, scale):
    # a large floor seen obliquely (grazing far away, steep near), and a frontal wall
    floor = scene_of(box((400, 400, 0.2), (0, 150, -0.1)))
    floor_camera = Camera.from_look_at((0, 0, 1.7), (0, 8, 0), (0, 0, 1), 60, W, H)
    plane = render_depth(ctx, floor, floor_camera) > 0
    ao = render_ao(ctx, floor, floor_camera, mode, samples=16, ao_scale=scale)
    assert ao[plane].min() >= 0.99, f"{mode} floor min {ao[plane].min():.4f}"
    wall = scene_of(box((50, 0.2, 50), (0, 10, 0)))
    wall_camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 60, W, H)
    front = render_ao(ctx, wall, wall_camera, mode, samples=16, ao_scale=scale)
    assert front.min() >= 0.99, f"{mode} frontal min {front.min():.4f}"


@pytest.mark.parametrize("mode", [*SLICE_MODES, "gtao clamped"])
def test_projected_sampling_radius_is_constant_with_depth(ctx, mode):
    # as the vector test: the same picture at 2 m and, scaled by 100, at 200 m
    clamp = {"max_world_radius": 0.12} if mode.endswith("clamped") else {}
    widths, totals = bands_at_2_and_200_m(ctx, mode.split()[0], radius_px=12, **clamp)
    print(mode, widths, totals)
    # a band to measure at 2 m (narrower than vector's: a horizon's elevation falls off with
    # distance from the step, and the steps are denser near the pixel)
    assert widths[2.0] > 1.0 and totals[2.0] > 10.0
    if mode.endswith("clamped"):  # the world clamp turns it into a world radius, as vector's
        assert totals[200.0] < 0.05 * totals[2.0]
    else:
        assert widths[200.0] == pytest.approx(widths[2.0], rel=0.05)
        assert totals[200.0] == pytest.approx(totals[2.0], rel=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("mode", SLICE_MODES)
def test_distance_retention(ctx, mode, record_property):
    # tests/test_ao_properties.py's scene: the same block at 5 m and at 100 m, seen at one angle
    camera, scene, slabs, near_mask, far_mask = blocks_at_5_and_100_m(ctx)
    radius_px = DEFAULT_RADIUS_FRACTION * camera.height
    ao = render_ao(ctx, scene, camera, mode, samples=36, radius_px=radius_px)
    ao_without = render_ao(ctx, slabs, camera, mode, samples=36, radius_px=radius_px)
    near = ring_darkening(ao, ao_without, near_mask, int(radius_px))
    far = ring_darkening(ao, ao_without, far_mask, int(radius_px))
    record_property(f"{mode}_far_over_near", far / near)
    print(f"{mode}: darkening near {near:.4f}, far {far:.4f}, far/near {far / near:.2f}")
    # measured: gtao 0.46, vbao 0.46 (vector 0.54, ssao 0.01; vector's test asks 0.5,
    # which these two miss: reported in docs/method.md); far above a world radius's fade
    assert near > 0.02 and far / near >= 0.4


def test_vbao_thickness_lets_light_behind_a_thin_plate(ctx):
    # a thin plate 1 m in front of a wall: gtao (and a thick vbao) take everything below the
    # plate's horizon as occluded; a thin vbao sees the wall behind the plate
    scene = scene_of(box((20, 0.2, 20), (0, 10, 0)), box((0.4, 0.02, 3), (0, 9.0, 0)))
    camera = Camera.from_look_at((-3, 0, 0), (0, 10, 0), (0, 0, 1), 60, W, H)
    settings = dict(samples=36, radius_px=30)
    darkening = {}
    for name, mode, thickness in (("thin", "vbao", 0.05), ("thick", "vbao", 50.0), ("gtao", "gtao", 1.0)):
        ao = render_ao(ctx, scene, camera, mode, thickness=thickness, **settings)
        darkening[name] = float((1.0 - ao).mean())
    print(darkening)
    assert darkening["thin"] < 0.7 * darkening["thick"]
    assert darkening["thick"] == pytest.approx(darkening["gtao"], rel=0.5)


def test_thickness_is_checked():
    from mrcheck.core.errors import MrcheckError

    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(MrcheckError, match="thickness"):
            RenderSettings(thickness=bad).validated(None)
