"""The renderer's GL objects and shader loading, through public behaviour: what is alive in the
driver (glIsTexture and friends), what a compile error says."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import sample_scene_path
from mrcheck.render.gl import create_context, load_program, made_current
from mrcheck.render.renderer import MODES, Renderer, RenderSettings
from mrcheck.scene.model import load_scene

# the object kinds a renderer makes (programs excluded: they belong to the context's program cache)
KINDS = ("glIsTexture", "glIsBuffer", "glIsFramebuffer", "glIsVertexArray", "glIsRenderbuffer")
MAX_NAME = 4096  # a fresh context hands out small names


def live_gl_objects(ctx) -> dict[str, set[int]]:
    """The names of every live GL object of each kind on ``ctx``, as the driver says (glIs*)."""
    egl = ctypes.CDLL("libEGL.so.1")
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    live = {}
    with made_current(ctx):
        for kind in KINDS:
            is_alive = ctypes.CFUNCTYPE(ctypes.c_ubyte, ctypes.c_uint)(egl.eglGetProcAddress(kind.encode()))
            live[kind] = {name for name in range(1, MAX_NAME) if is_alive(name)}
    return live


@pytest.fixture
def fresh_ctx():
    context = create_context()
    yield context
    context.release()


def _every_pass(renderer: Renderer, camera) -> None:
    """A frame of every mode at both AO resolutions, blurred and not, with the AO read back (the
    upsampling pass) and the normals: every GL object the renderer makes."""
    for scale in (1.0, 0.5):
        for blur in (True, False):
            frame = renderer.render(
                camera,
                list(MODES),
                RenderSettings(samples=4, ao_scale=scale, blur=blur),
                want_ao=True,
                want_normals=True,
            )
            assert frame.depth.shape == frame.normals.shape[:2] == (camera.height, camera.width)


@pytest.mark.slow
def test_release_frees_every_gl_object_the_renderer_made(fresh_ctx):
    """The blurs', the screen passes' and the composite's vertex arrays stayed alive after release."""
    before = live_gl_objects(fresh_ctx)
    scene = load_scene(sample_scene_path())
    renderer = Renderer(scene, ctx=fresh_ctx)
    _every_pass(renderer, scene.camera("robot", 64, 48))
    during = live_gl_objects(fresh_ctx)
    assert all(during[k] > before[k] for k in ("glIsTexture", "glIsBuffer", "glIsFramebuffer", "glIsVertexArray"))
    renderer.release()
    after = live_gl_objects(fresh_ctx)
    assert {k: sorted(after[k] - before[k]) for k in KINDS} == {k: [] for k in KINDS}


def test_a_second_release_does_nothing(fresh_ctx):
    """The bench's stages share renderers and release each: a second release must not fail."""
    before = live_gl_objects(fresh_ctx)
    scene = load_scene(sample_scene_path())
    renderer = Renderer(scene, ctx=fresh_ctx)
    renderer.render(scene.camera("robot", 64, 48), ["vector"], RenderSettings(samples=4))
    renderer.release()
    renderer.release()
    assert live_gl_objects(fresh_ctx) == before


@pytest.mark.slow
def test_the_frame_carries_the_depth_of_its_g_buffer(fresh_ctx):
    """What ``last_depth()`` used to read after a render is in the render's result."""
    scene = load_scene(sample_scene_path())
    renderer = Renderer(scene, ctx=fresh_ctx)
    try:
        camera = scene.camera("overview", 80, 60)
        # without anti-aliasing, whose edge pixels mix the background's colour with the CAD's
        frame = renderer.render(camera, ["phong", "vector"], RenderSettings(samples=4, antialias=False))
        assert set(frame) == {"phong", "vector"} and len(frame) == 2 and frame.normals is None
        assert frame.depth.dtype == np.float32 and frame.depth.shape == (60, 80)
        assert 0 < (frame.depth > 0).mean() < 1  # the cell and some background
        # the background pixels of the depth are those painted in the background colour
        background = (frame["phong"].image == frame["phong"].image[frame.depth == 0][0]).all(axis=2)
        assert background[frame.depth == 0].all()
        # anti-aliased, each pixel's depth is that of the surface covering most of its samples
        # (mrcheck.render.antialias), its plane at the pixel centre: inside a surface the centre's
        # depth as without anti-aliasing; at an edge a surface that covers part of the pixel,
        # which a 4x4 supersampled render sees in the pixel's area (sub-pixel wires too, which the
        # centre may miss), its plane a fraction of a pixel away
        antialiased = renderer.render(camera, ["phong"], RenderSettings(samples=4)).depth
        differs = np.abs(antialiased - frame.depth) > 1e-5 * np.maximum(frame.depth, 1e-3)
        assert 0 < differs.mean() < 0.15
        fine = renderer.render(camera.resized(320, 240), ["phong"], RenderSettings(antialias=False)).depth
        blocks = fine.reshape(60, 4, 80, 4).transpose(0, 2, 1, 3).reshape(60, 80, 16)
        seen = (np.abs(blocks - antialiased[..., None]) <= 0.03 * np.maximum(antialiased[..., None], 1e-3)).any(axis=2)
        assert seen[differs].mean() > 0.97
    finally:
        renderer.release()


BROKEN_INCLUDE = """// a helper with a typo
float helper(float x) {
    return x * undefined_thing;
}
"""
BROKEN = """// a pass that includes a broken helper
#include "helper.glsl"
out vec4 color;

void main() {
    color = vec4(helper(1.0));
    float y = also_undefined;
}
"""


def test_a_compile_error_names_the_file_and_line_across_includes(tmp_path, fresh_ctx):
    (tmp_path / "helper.glsl").write_text(BROKEN_INCLUDE)
    (tmp_path / "broken.glsl").write_text(BROKEN)
    with made_current(fresh_ctx), pytest.raises(MrcheckError) as error:
        load_program(fresh_ctx, "broken", directory=tmp_path)
    message = str(error.value)
    assert "\n" not in message and message.startswith("shader broken.glsl does not compile: ")
    assert "helper.glsl:3(" in message and "undefined_thing" in message  # in the included file
    assert "broken.glsl:7(" in message and "also_undefined" in message  # in the file itself, after it


def test_a_shader_that_compiles_from_another_folder(tmp_path, fresh_ctx):
    """The harness is not vacuous: the same files without the typos compile."""
    (tmp_path / "helper.glsl").write_text(BROKEN_INCLUDE.replace("undefined_thing", "2.0"))
    (tmp_path / "broken.glsl").write_text(BROKEN.replace("also_undefined", "1.0"))
    with made_current(fresh_ctx):
        assert load_program(fresh_ctx, "broken", directory=tmp_path) is not None


@pytest.mark.slow
@pytest.mark.parametrize("samples", [1, 3, 4, 36, 64])
def test_hbao_compiles_at_every_split_of_its_budget(fresh_ctx, samples):
    """HBAO's directions and steps come from Python (one place): every budget compiles and gives
    AO in [0, 1]."""
    scene = load_scene(sample_scene_path())
    renderer = Renderer(scene, ctx=fresh_ctx)
    try:
        ao = renderer.render(
            scene.camera("robot", 64, 48), ["hbao"], RenderSettings(samples=samples, blur=False), want_ao=True
        )["hbao"].ao
    finally:
        renderer.release()
    assert ao.min() >= 0.0 and ao.max() <= 1.0 and ao.min() < 1.0
