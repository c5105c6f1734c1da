"""Anti-aliasing (mrcheck.render.antialias): the multisampled G-buffer, its resolve, the edge pass.

The error against a 4x4 supersampled render is measured in tests/test_light_tone.py; here: that
the driver places the samples where the composite reads the AO, that the packed G-buffer keeps
normals, colours and faces, that only edge pixels change, and the fallback without anti-aliasing.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import moderngl
import numpy as np
import pytest

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckWarning
from mrcheck.core.resources import sample_scene_path
from mrcheck.render.antialias import MSAA_SAMPLES, SAMPLE_OFFSETS, linear_to_srgb, srgb_to_linear
from mrcheck.render.gbuffer import PALETTE_MAX
from mrcheck.render.gl import made_current
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene

from .conftest import box, scene_of

COVER = """
in vec2 in_p;
void main() { gl_Position = vec4(in_p, 0.0, 1.0); }
"""
READ = """
uniform sampler2DMS u_t;
out vec4 o;
void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    o = vec4(texelFetch(u_t, ij, 0).r, texelFetch(u_t, ij, 1).r, texelFetch(u_t, ij, 2).r, texelFetch(u_t, ij, 3).r);
}
"""


def _covered_samples(ctx, x1: float, y1: float) -> np.ndarray:
    """(4,) bool: which samples of pixel (3, 3) of an 8x8 target a rectangle (0, 0)-(x1, y1) px covers."""
    n = 8
    target = ctx.texture((n, n), 1, dtype="f4", samples=MSAA_SAMPLES)
    fbo = ctx.framebuffer([target])
    fill = ctx.program(
        vertex_shader="#version 450 core\n" + COVER,
        fragment_shader="#version 450 core\nout float v; void main() { v = 1.0; }",
    )
    read = ctx.program(
        vertex_shader="#version 450 core\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, "
        "gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }",
        fragment_shader="#version 450 core\n" + READ,
    )
    X, Y = x1 / n * 2 - 1, y1 / n * 2 - 1
    vbo = ctx.buffer(np.array([-1, -1, X, -1, X, Y, -1, -1, X, Y, -1, Y], "f4").tobytes())
    out = ctx.texture((n, n), 4, dtype="f4")
    out_fbo = ctx.framebuffer([out])
    fbo.use()
    fbo.clear(0.0, 0.0, 0.0, 0.0)
    ctx.vertex_array(fill, [(vbo, "2f", "in_p")]).render(moderngl.TRIANGLES)
    target.use(0)
    out_fbo.use()
    ctx.vertex_array(read, []).render(moderngl.TRIANGLES, vertices=3)
    return np.frombuffer(out.read(), np.float32).reshape(n, n, 4)[3, 3] > 0.5


def test_the_driver_places_the_samples_where_the_composite_reads_them(ctx):
    """Sweep an edge across pixel (3, 3) in 1/32 px steps, along x and along y: each sample turns
    covered once the edge passes its position, which must be SAMPLE_OFFSETS (+ the centre 3.5)."""
    with made_current(ctx):
        steps = np.arange(1, 33) / 32.0
        first_x = [next(e for e in steps if _covered_samples(ctx, 3 + e, 8)[k]) for k in range(MSAA_SAMPLES)]
        first_y = [next(e for e in steps if _covered_samples(ctx, 8, 3 + e)[k]) for k in range(MSAA_SAMPLES)]
    for k, (dx, dy) in enumerate(SAMPLE_OFFSETS):
        # covered from the first step past the position (a sample on the edge itself is not covered)
        assert 0.5 + dx < first_x[k] <= 0.5 + dx + 1 / 32 + 1e-9
        assert 0.5 + dy < first_y[k] <= 0.5 + dy + 1 / 32 + 1e-9


@pytest.fixture(scope="module")
def sample_cell(ctx):
    renderer = Renderer(load_scene(sample_scene_path()), ctx=ctx)
    yield renderer
    renderer.release()


@pytest.mark.slow
def test_inside_surfaces_the_frame_is_the_one_without_anti_aliasing(sample_cell):
    """The packed G-buffer (10-bit octahedral normals, a palette index, the face) and the resolve
    keep a pixel that one surface covers as it was: its normal within 0.15 degrees of the
    surface's, its colour within 2 levels of the frame without anti-aliasing (where its centre
    sample saw that surface; 6 with AO, which reads the neighbourhood); what changes are the
    edge pixels."""
    camera = sample_cell.scene.camera("robot", 160, 120)
    modes = ["phong", "vector"]
    # full detail throughout: a level of detail chosen per resolution would change the geometry
    plain = sample_cell.render(camera, modes, RenderSettings(antialias=False, lod_px=0), want_normals=True)
    smooth = sample_cell.render(camera, modes, RenderSettings(lod_px=0), want_normals=True)
    # a pixel inside a surface: all 16 sub-pixels of a 4x4 supersampled render on one plane
    fine = sample_cell.render(
        camera.resized(640, 480), ["phong"], RenderSettings(antialias=False, lod_px=0), want_normals=True
    )
    z = fine.depth.reshape(120, 4, 160, 4).transpose(0, 2, 1, 3).reshape(120, 160, 16)
    n = fine.normals.reshape(120, 4, 160, 4, 3).transpose(0, 2, 1, 3, 4).reshape(120, 160, 16, 3)
    one_normal = np.abs(n - n[:, :, :1]).max(axis=(2, 3)) < 2e-3
    inside = (z.min(axis=2) > 0) & one_normal & (z.max(axis=2) - z.min(axis=2) < 0.02 * z.min(axis=2))
    # (not the 1x render's normals: its centre sample may hit a grazing sliver the pixel hardly shows)
    assert inside.mean() > 0.3
    unit = [n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9) for n in (smooth.normals, n[:, :, 0])]
    cos = np.clip((unit[0] * unit[1]).sum(axis=2), -1, 1)  # (the G-buffer's f16 normals are unit to 1e-4)
    assert np.degrees(np.arccos(cos[inside])).max() < 0.15
    centre_on_it = (
        inside
        & (np.abs(plain.normals - n[:, :, 0]).max(axis=2) < 2e-3)
        & (np.abs(plain.depth - z.mean(axis=2)) < 0.02 * z.min(axis=2))
    )
    for mode in modes:
        diff = np.abs(smooth[mode].image.astype(int) - plain[mode].image).max(axis=2)
        # (but for a few pixels where two coplanar parts overlap, whose samples show either; the
        # AO also reads the neighbourhood, whose edge pixels now hold their majority surface)
        assert (diff[centre_on_it] <= (2 if mode == "phong" else 6)).mean() > 0.99, mode
        assert (diff > 8).mean() > 0.01  # and the edges did change


def test_an_edge_pixel_is_the_mean_of_its_samples_surfaces_in_linear_light(ctx):
    """Two boxes (red in front, blue behind) whose edges run through pixel centres: each of the
    pixel's samples shows the surface on its side of the edges (SAMPLE_OFFSETS), and the edge pass
    (shaders/composite.glsl) makes the pixel the mean in linear light of those surfaces' colours,
    taken from pixels nearby that one surface covers: on a vertical edge (red | blue), a horizontal
    one (background over red), and the corner where all three meet (two surfaces besides the
    resolved one, the case the pass tells apart)."""
    front, behind = box((2.0, 2.0, 0.2), (-1.0, 1.0, 5.1)), box((2.5, 2.0, 0.2), (0.75, 1.0, 6.1))
    base = scene_of(front, behind, name="edges")
    scene = Scene(
        base.name,
        base.source,
        [replace(base.parts[0], color=(0.8, 0.1, 0.1)), replace(base.parts[1], color=(0.1, 0.2, 0.8))],
    )
    # camera at the origin looking down +z: the boxes' sides x = 0 and tops y = 0 are seen edge-on
    # and project onto the centres of column 16 and row 12
    camera = Camera(32, 24, np.array([[50.0, 0.0, 16.0], [0.0, 50.0, 12.0], [0.0, 0.0, 1.0]]))
    renderer = Renderer(scene, ctx=ctx)
    try:
        image = renderer.render(camera, ["phong"], RenderSettings(lod_px=0))["phong"].image
    finally:
        renderer.release()
    linear = srgb_to_linear(image)
    colour = {"background": linear[8, 16], "red": linear[15, 13], "blue": linear[15, 19]}

    def side(dx, dy, v, u):  # the surface a sample of pixel (v, u) sees
        y, x = v + dy - 12.0, u + dx - 16.0
        return "background" if y < 0 else ("red" if x < 0 else "blue")

    for v, u in ((16, 16), (12, 10), (12, 16)):
        expected = np.mean([colour[side(dx, dy, v, u)] for dx, dy in SAMPLE_OFFSETS], axis=0)
        assert np.abs(image[v, u].astype(int) - linear_to_srgb(expected)).max() <= 3, (v, u)
    assert len({side(dx, dy, 12, 16) for dx, dy in SAMPLE_OFFSETS}) == 3  # the corner has all three


def test_back_faces_stay_back_faces_through_the_packing(ctx):
    """The face flag travels in the packed word's sign bit: an open box seen from inside shows
    back faces, which the resolved G-buffer reports as such (the camera-inside check reads it)."""
    scene = scene_of(box((4.0, 4.0, 4.0), (0.0, 0.0, 0.0)))
    camera = Camera.from_look_at((0.5, 0.2, 0.3), (2.0, 0.0, 0.0), (0.0, 0.0, 1.0), 60, 64, 48)
    renderer = Renderer(scene, ctx=ctx)
    try:
        for antialias in (False, True):
            with pytest.raises(Exception, match="inside geometry"):
                renderer.render(camera, ["phong"], RenderSettings(antialias=antialias))
    finally:
        renderer.release()


@pytest.mark.slow
def test_more_part_colours_than_the_palette_holds_render_without_anti_aliasing(ctx):
    """Past PALETTE_MAX distinct part colours the packed index cannot tell them apart: the frame
    is rendered without anti-aliasing (the same image), with one warning naming the count."""
    count = PALETTE_MAX + 8
    meshes = [box((0.1, 0.1, 0.1), (0.3 * (i % 24), 0.3 * (i // 24), 0.0)) for i in range(count)]
    base = scene_of(*meshes, name="many-colours")
    parts = [replace(part, color=(i / count, 0.5, 1.0 - i / count)) for i, part in enumerate(base.parts)]
    scene = Scene(base.name, base.source, parts)
    camera = Camera.from_look_at((3.5, 3.2, 6.0), (3.5, 3.2, 0.0), (0.0, 1.0, 0.0), 70, 96, 72)
    renderer = Renderer(scene, ctx=ctx)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            smooth = renderer.render(camera, ["phong"], RenderSettings())
            renderer.render(camera, ["phong"], RenderSettings())
        said = [str(w.message) for w in caught if issubclass(w.category, MrcheckWarning)]
        assert len(said) == 1 and f"{count} distinct part colours" in said[0]
        plain = renderer.render(camera, ["phong"], RenderSettings(antialias=False))
        assert np.array_equal(smooth["phong"].image, plain["phong"].image)
    finally:
        renderer.release()
