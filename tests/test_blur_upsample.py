"""The depth-aware bilateral blur and the depth-aware upsampling of half-resolution AO, tested
on their own: textures filled here go through the production passes (``BilateralBlur.run``,
``shaders/ao_upsample.glsl``, the composite's fused variant), so each property is checked
per pixel instead of through a whole-image golden. One renderer-level test checks that the
half-resolution AO pass and the upsampling agree on where a half-resolution texel lies.

(AO, depth) texels as in ``shaders/ao_common.glsl``: RG32F, depth 0 = background; image row 0
is texel row 0.
"""

from __future__ import annotations

from types import SimpleNamespace

import moderngl
import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.render.blur import BilateralBlur
from mrcheck.render.composite import Composite
from mrcheck.render.gl import load_program, made_current

from .conftest import box, render_ao, scene_of


# -- helpers ----------------------------------------------------------------------------------
@pytest.fixture
def gl(ctx):
    with made_current(ctx):
        yield ctx


def _texture(ctx, array: np.ndarray) -> moderngl.Texture:
    """A float32 texture of (H, W) or (H, W, C) ``array``, sampled like the renderer's AO
    targets (nearest, clamped at the border: the upsampling's gathers rely on it)."""
    array = np.ascontiguousarray(array, np.float32)
    h, w = array.shape[:2]
    components = 1 if array.ndim == 2 else array.shape[2]
    texture = ctx.texture((w, h), components, data=array.tobytes(), dtype="f4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    texture.repeat_x = texture.repeat_y = False
    return texture


def _ao_depth(ctx, ao, depth) -> moderngl.Texture:
    return _texture(ctx, np.dstack([ao, depth]))


def _blur(ctx, ao, depth, size=9):
    """(AO, depth) after the production bilateral blur of kernel ``size``."""
    h, w = ao.shape
    scratch, target = (ctx.framebuffer([_ao_depth(ctx, np.zeros((h, w)), np.zeros((h, w)))]) for _ in range(2))
    BilateralBlur(ctx, size).run(_ao_depth(ctx, ao, depth), scratch, target)
    out = np.frombuffer(target.color_attachments[0].read(), np.float32).reshape(h, w, 2)
    return out[..., 0], out[..., 1]


def _upsample(ctx, ao_half, depth_half, depth_full) -> np.ndarray:
    """(H, W) AO of ``shaders/ao_upsample.glsl`` (what --output-ao writes at --ao-scale 0.5)."""
    h, w = depth_full.shape
    half = _ao_depth(ctx, ao_half, depth_half)
    out = ctx.texture((w, h), 1, dtype="f4")
    fbo = ctx.framebuffer([out])
    program = load_program(ctx, "ao_upsample")
    program["u_ao_half"].value = 0
    program["u_depth_full"].value = 1
    program["u_size_half"].value = half.size
    half.use(0)
    _texture(ctx, depth_full).use(1)
    fbo.use()
    ctx.vertex_array(program, []).render(moderngl.TRIANGLES, vertices=3)
    return np.frombuffer(out.read(), np.float32).reshape(h, w)


def _bilinear(ao_half: np.ndarray, shape) -> np.ndarray:
    """The reference: full-res pixel p sits at half-res coordinate p / 2 (half-res texel i is
    full-res pixel 2i, ao_common.glsl), bilinear between texels, clamped at the border."""
    h, w = shape
    hh, wh = ao_half.shape
    y, x = np.arange(h) / 2.0, np.arange(w) / 2.0
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    y1, x1 = np.minimum(y0 + 1, hh - 1), np.minimum(x0 + 1, wh - 1)
    fy, fx = (y - y0)[:, None], (x - x0)[None, :]
    top = ao_half[y0][:, x0] * (1 - fx) + ao_half[y0][:, x1] * fx
    bottom = ao_half[y1][:, x0] * (1 - fx) + ao_half[y1][:, x1] * fx
    return top * (1 - fy) + bottom * fy


# -- bilateral blur ---------------------------------------------------------------------------
def test_blur_keeps_constant_ao_constant_over_any_depth_and_ignores_the_background(gl):
    """Normalisation: the weights are divided by their sum, so a constant AO stays that constant
    whatever the depth does under it (blocks 1 to 20 m apart, steep steps everywhere), and
    background texels (depth 0, AO 1 as the AO passes write it) give no weight. Guards `sum /
    weight` (an unnormalised sum, or one divided by the Gaussian weights alone, changes it at
    every depth step). The depth channel is passed on unchanged."""
    rng = np.random.default_rng(7)
    h, w = 32, 48
    depth = np.kron(rng.uniform(1.0, 20.0, (8, 12)), np.ones((4, 4))).astype(np.float32)
    depth[rng.random((h, w)) < 0.1] = 0.0  # scattered background texels
    ao = np.where(depth > 0, 0.37, 1.0).astype(np.float32)
    blurred, z = _blur(gl, ao, depth)
    assert np.array_equal(z, depth)
    # measured: max error 1.2e-7 (float rounding); background centres pass their AO through
    assert np.abs(blurred - ao).max() < 1e-5


def _step_scene(h=40, w=40, near=8.0, far=10.0):
    """A near square (AO 0.2) over a far wall (AO 1.0): the AO step and the depth step coincide
    on all four sides, so both blur directions cross one."""
    depth = np.full((h, w), far, np.float32)
    ao = np.ones((h, w), np.float32)
    inside = np.zeros((h, w), bool)
    inside[12:28, 12:28] = True
    depth[inside], ao[inside] = near, 0.2
    return ao, depth, inside


def test_blur_does_not_carry_ao_across_a_depth_step(gl):
    """Edge preservation: an object 2 m in front of a wall 10 m away (a 20 % depth step, four
    times DEPTH_TOLERANCE = 5 %) keeps its dark AO, and the wall right beside its silhouette keeps
    its open AO, within the whole 9-tap kernel. Guards the depth weight exp(-d^2) (removed: the
    wall beside the silhouette falls to 0.72, the square rises to 0.66) and its tolerance (10x
    larger, 0.5: the 20 % step weighs exp(-0.16) = 0.85; wall 0.75, square 0.60)."""
    ao, depth, inside = _step_scene()
    blurred, _ = _blur(gl, ao, depth)
    ring = np.zeros_like(inside)
    ring[8:32, 8:32] = True  # the kernel's reach (radius 4) around the square
    wall_near_edge = ring & ~inside
    # measured: wall 1.0 exactly, square 0.2 (both within 1e-7)
    assert blurred[wall_near_edge].min() > 0.995
    assert np.abs(blurred[inside] - 0.2).max() < 0.005


def test_blur_smooths_an_ao_step_on_a_continuous_surface(gl):
    """The blur does blur: an AO step on a continuous surface is spread over the kernel, and
    away from the step nothing changes; on a slanted surface (depth 10 m growing 0.4 % per pixel,
    1.6 % across the kernel's radius) it smooths as much as on a fronto-parallel one. Guards
    against a blur that does not mix, e.g. a depth tolerance so small that a slanted surface
    counts as a silhouette (DEPTH_TOLERANCE / 10: differs from the flat case by 0.097)."""
    h, w = 24, 40
    ao = np.ones((h, w), np.float32)
    ao[:, :20] = 0.2
    flat, _ = _blur(gl, ao, np.full((h, w), 10.0))
    slanted_depth = np.tile(10.0 * 1.004 ** np.arange(w), (h, 1))
    slanted, _ = _blur(gl, ao, slanted_depth)
    row = flat[12]
    # measured: 0.480 and 0.720 beside the step (unblurred: 0.2 and 1.0); 0.2 / 1.0 at 6-7 px away
    assert 0.35 < row[19] < 0.6 and 0.6 < row[20] < 0.85
    assert abs(row[13] - 0.2) < 1e-3 and abs(row[26] - 1.0) < 1e-3
    assert np.allclose(flat, flat[12], atol=1e-6)  # a vertical step stays vertical
    # measured: max difference 0.0022 (at 1 % per pixel it would be 0.013)
    assert np.abs(slanted - flat).max() < 0.01


# -- depth-aware upsampling of half-resolution AO -----------------------------------------------
def test_upsampling_on_one_surface_is_bilinear_with_half_texel_i_at_full_pixel_2i(gl):
    """Alignment: on a single surface (constant depth) the upsampling is exactly bilinear
    interpolation with half-res texel (i, j) at full-res pixel (2i, 2j), the pixel whose G-buffer
    the half-res AO pass read; odd pixels are the mean of their two or four neighbours. Random AO,
    so every tap of the 2x2 footprint matters. Guards the gather position (`floor(h) + 1.0`:
    with + 0.0 everything moves by one half-res texel, 2 full-res pixels), the tap order of the
    gathers (`.wzyx` flips the footprint) and the weighted path (always taking the nearest-depth
    fallback averages all four taps). Odd full size: the last half-res texel is clamped."""
    rng = np.random.default_rng(3)
    h, w = 17, 23
    hh, wh = (h + 1) // 2, (w + 1) // 2  # as the renderer sizes it
    ao_half = rng.random((hh, wh)).astype(np.float32)
    up = _upsample(gl, ao_half, np.full((hh, wh), 4.0), np.full((h, w), 4.0))
    # measured: max error 6e-8; the mutants above err by 0.64 (fallback) to 0.93 (+ 0.0)
    assert np.abs(up - _bilinear(ao_half, (h, w))).max() < 1e-4
    assert np.array_equal(up[::2, ::2], ao_half)


def test_upsampling_keeps_each_side_of_a_silhouette(gl):
    """Edge preservation: a near square (depth 5, AO 0.2) over a far wall (depth 10, AO 1.0).
    The full-res silhouette lies one pixel off the half-res samples on every side, where the
    bilinear footprint holds both surfaces 50/50: on the left and top edges a near pixel, on the
    right and bottom edges a wall pixel. Each must take its own surface's AO, not the blend.
    Guards the depth weight (`w = bilinear`: 0.6 on the wall, 0.8 on the square at those
    pixels) and the depth taps' order (`zq.wzyx` pairs one row's depth with the other row's AO:
    0.21 on the wall)."""
    hh, wh = 14, 16
    h, w = 2 * hh, 2 * wh
    near_half = np.zeros((hh, wh), bool)
    near_half[4:10, 5:11] = True  # half-res texels i in [5, 11), j in [4, 10)
    near_full = np.zeros((h, w), bool)
    near_full[2 * 4 - 1 : 2 * 10 - 1, 2 * 5 - 1 : 2 * 11 - 1] = True  # full-res: 2i, plus one pixel left / top
    ao_half = np.where(near_half, 0.2, 1.0).astype(np.float32)
    up = _upsample(gl, ao_half, np.where(near_half, 5.0, 10.0), np.where(near_full, 5.0, 10.0))

    # the pixels whose footprint straddles the silhouette (both surfaces' texels in it)
    straddle = np.abs(_bilinear(near_half.astype(np.float32), (h, w)) - 0.5) < 0.49
    assert straddle[near_full].sum() >= 20 and straddle[~near_full].sum() >= 20  # the test's premise
    # measured: wall >= 0.9922 (the near texels keep 1/101 of their weight), square <= 0.2059
    assert up[~near_full].min() > 0.98
    assert up[near_full].max() < 0.22


def test_upsampling_with_no_neighbour_on_the_surface_takes_the_nearest_depth(gl):
    """Fallback: a thin near part seen only at full resolution (a one-pixel column at depth 1
    between half-res samples on a step from 5 m, AO 0.3, to 10 m, AO 1.0) has no half-res texel
    on its surface; it takes the AO of the texel nearest in depth (0.3), not a depth-weighted mix
    of surfaces that are all wrong (0.41). Guards the fallback branch of upsampled_ao."""
    hh, wh = 8, 8
    h, w = 2 * hh, 2 * wh
    depth_half = np.where(np.arange(wh) < 4, 5.0, 10.0)[None, :].repeat(hh, 0)
    ao_half = np.where(depth_half < 7, 0.3, 1.0).astype(np.float32)
    depth_full = np.where(np.arange(w) < 8, 5.0, 10.0)[None, :].repeat(h, 0)
    depth_full[:, 7] = 1.0  # odd column: between half texels 3 (5 m) and 4 (10 m)
    up = _upsample(gl, ao_half, depth_half, depth_full)
    # measured: 0.3 exactly (the weighted mix, fallback never taken: 0.4155)
    assert np.abs(up[:, 7] - 0.3).max() < 1e-4


def test_composite_shades_with_the_same_upsampled_ao_as_the_ao_output(gl):
    """The composite's fused upsampling (AO_HALF) gives the image the AO that --output-ao
    writes: shading with the half-res texture equals shading with the upsampled full-res AO.
    Guards the composite's wiring of the half-res path (texture unit, u_size_half)."""
    rng = np.random.default_rng(5)
    hh, wh = 12, 16
    h, w = 2 * hh, 2 * wh
    depth_full = np.where(np.arange(w) < 13, 3.0, 6.0)[None, :].repeat(h, 0).astype(np.float32)
    depth_half = depth_full[::2, ::2]
    ao_half = rng.uniform(0.0, 1.0, (hh, wh)).astype(np.float32)
    ao_full = _upsample(gl, ao_half, depth_half, depth_full)

    camera = Camera.from_look_at((0, 0, 0), (0, 1, 0), (0, 0, 1), 60, w, h)
    facing = np.zeros((h, w, 4))
    facing[..., 2] = -1.0  # camera-space normals towards the camera
    gbuffer = SimpleNamespace(
        depth=_texture(gl, depth_full), normal=_texture(gl, facing), albedo=_texture(gl, np.full((h, w, 4), 0.8))
    )
    composite = Composite(gl)
    images = []
    inputs = ((_ao_depth(gl, ao_half, depth_half), True), (_ao_depth(gl, ao_full, depth_full), False))
    for texture, half in inputs:
        color = gl.texture((w, h), 4, dtype="f1")
        composite.run(gl.framebuffer([color]), gbuffer, texture, camera, use_ao=True, ao_half=half, tone="clip")
        images.append(np.frombuffer(color.read(), np.uint8).reshape(h, w, 4)[..., :3].astype(int))
    assert images[0].std() > 20  # the AO shows in the image (measured: 29)
    # measured: identical (max difference 0)
    assert np.abs(images[0] - images[1]).max() <= 1


@pytest.mark.slow
def test_half_resolution_ao_lands_where_full_resolution_ao_puts_it(ctx):
    """Alignment through the renderer: the half-res AO pass (texel (i, j) reads full-res pixel
    (2i, 2j)) and the upsampling agree, so the dark band along a crease lies where the full-res
    AO puts it. Room corner: the floor meets the back wall in a horizontal crease, the back wall
    meets a side wall in a vertical one; per column (row) the centroid of darkness 1 - AO of the
    half-res AO is compared with the full-res one's, unblurred (the blur runs in half-res pixels
    and widens the band). An upsampling shifted by one half-res texel moves it by ~1.5-1.7 px."""
    floor = box((30, 30, 0.2), (0, 0, -0.1))
    back_wall = box((30, 0.2, 10), (0, 6.1, 5))
    side_wall = box((0.2, 30, 10), (3.1, 0, 5))
    scene = scene_of(floor, back_wall, side_wall)
    camera = Camera.from_look_at((0.3, -2, 1.5), (0.3, 6, 1.5), (0, 0, 1), 60, 160, 120)
    settings = dict(radius_px=8, samples=32, seed=0, blur=False)
    full = render_ao(ctx, scene, camera, "vector", **settings)
    half = render_ao(ctx, scene, camera, "vector", ao_scale=0.5, **settings)

    def centroid(ao, axis):
        darkness = 1.0 - ao
        assert darkness.sum(axis).min() > 0.5  # a band to locate in every line
        position = np.arange(ao.shape[axis]).reshape((-1, 1) if axis == 0 else (1, -1))
        return (darkness * position).sum(axis) / darkness.sum(axis)

    # windows around one crease each: the floor's at row ~79, the corner's at column ~115
    rows, cols = (slice(64, 96), slice(5, 100)), (slice(5, 70), slice(100, 135))
    shift_rows = centroid(half[rows], 0) - centroid(full[rows], 0)
    shift_cols = centroid(half[cols], 1) - centroid(full[cols], 1)
    # measured: mean shift -0.32 px (rows), -0.20 px (columns), a sampling-phase effect (moving the
    # principal point by 0.25..1 px gives -0.08..+0.32 and -0.24..-0.12); off by one half-res
    # texel: +1.49, +1.68
    assert abs(shift_rows.mean()) < 0.8
    assert abs(shift_cols.mean()) < 0.8
