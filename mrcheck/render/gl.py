"""Headless OpenGL: the EGL context, shader loading with injected defines, reversed-Z depth.

Everything renders through ``moderngl.create_standalone_context(backend="egl")``, so it runs
without a display (Mesa llvmpipe on a CPU, or any GPU driver with EGL).

Shaders are one ``.glsl`` file per pass in the repository's top-level ``shaders/`` folder (the
wheel carries them as ``mrcheck/_data/shaders``). A file holds both stages split by
``#if defined VERTEX_SHADER`` / ``#elif defined FRAGMENT_SHADER``; a screen-space pass may omit
the vertex stage and gets the full-screen triangle of ``fullscreen.glsl``. ``#include "x.glsl"``
pastes another file of the folder. Constants that Python and GLSL both need (sample counts,
noise size, blur radius) are injected as ``#define`` lines from one place, never written twice.
"""

from __future__ import annotations

import ctypes
import re
import time
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import moderngl

from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import shader_dir

GL_VERSION = 450  # OpenGL 4.5 core: glClipControl, texelFetch, float depth buffers

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"[^\n]*$', re.MULTILINE)

# GL enums used through ctypes (moderngl does not wrap them)
_GL_TEXTURE_2D = 0x0DE1
_GL_TEXTURE_2D_MULTISAMPLE = 0x9100
_GL_DEPTH_COMPONENT32F = 0x8CAC
_GL_DEPTH_COMPONENT = 0x1902
_GL_FLOAT = 0x1406
_GL_LOWER_LEFT = 0x8CA1
_GL_ZERO_TO_ONE = 0x935F
_GL_SRGB8_ALPHA8 = 0x8C43
GL_FRAMEBUFFER_SRGB = 0x8DB9


@contextmanager
def made_current(ctx: moderngl.Context):
    """Make ``ctx`` the current GL context for the block, re-entrantly.

    moderngl issues GL calls on whatever context is current, and creating another context
    makes that one current. ``with ctx:`` fixes that, but glcontext's exit *releases* the
    context instead of restoring the outer one, so a nested ``with ctx:`` would leave the outer
    block with no context. This counts the nesting and enters/exits only at the outermost level.
    """
    state = _extra(ctx)
    if state.get("current_depth", 0) == 0:
        ctx.__enter__()
    state["current_depth"] = state.get("current_depth", 0) + 1
    try:
        yield ctx
    finally:
        state["current_depth"] -= 1
        if state["current_depth"] == 0:
            ctx.__exit__(None, None, None)


def _extra(ctx: moderngl.Context) -> dict:
    """mrcheck's per-context state (program cache, nesting depth) in ``ctx.extra``."""
    if not isinstance(ctx.extra, dict):
        ctx.extra = {}
    return ctx.extra


def create_context() -> moderngl.Context:
    """An OpenGL 4.5 core context through EGL, or a one-line :class:`MrcheckError`."""
    try:
        # the stubs type moderngl's keyword settings as dicts; glcontext takes the backend's name
        ctx = moderngl.create_standalone_context(backend="egl", require=GL_VERSION)  # type: ignore[arg-type]
    except Exception as exc:  # moderngl/glcontext raise bare Exceptions with multi-line text
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise MrcheckError(
            f"no headless OpenGL 4.5 through EGL ({reason}); install the Debian packages libegl1 and libgl1-mesa-dri"
        ) from None
    _enable_reversed_z(ctx)
    return ctx


class _GLFunctions:
    """The GL entry points moderngl does not expose, looked up through EGL once."""

    def __init__(self):
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]

        def lookup(name, *argtypes):
            address = egl.eglGetProcAddress(name.encode())
            if not address:
                raise MrcheckError(f"the OpenGL driver has no {name}")
            return ctypes.CFUNCTYPE(None, *argtypes)(address)

        u, i, p = ctypes.c_uint, ctypes.c_int, ctypes.c_void_p
        self.clip_control = lookup("glClipControl", u, u)
        self.bind_texture = lookup("glBindTexture", u, u)
        self.tex_image_2d = lookup("glTexImage2D", u, i, i, i, i, i, u, u, p)
        self.tex_image_2d_multisample = lookup("glTexImage2DMultisample", u, i, u, i, i, ctypes.c_ubyte)
        self.flush = lookup("glFlush")


@lru_cache(maxsize=1)
def _gl() -> _GLFunctions:
    return _GLFunctions()


def flush() -> None:
    """glFlush on the current context: hand the commands issued so far to the driver now.

    On llvmpipe this starts rasterising the draws binned so far on its worker threads while the
    calling thread goes on shading and binning the vertices of the next ones (see
    :meth:`mrcheck.render.gbuffer.GeometryPass._submit`); without it the two run one after the other.
    """
    _gl().flush()


def _enable_reversed_z(ctx: moderngl.Context) -> None:
    """Depth in [0, 1] instead of [-1, 1] (glClipControl), for reversed-Z.

    Reversed-Z with an infinite far plane (:func:`mrcheck.core.camera.gl_projection`) and a 32-bit
    float depth buffer stores depth = near / z, whose float exponent keeps the *relative*
    precision constant from millimetres to 1e12 m: nothing far away, however far, takes
    precision from what is near (:func:`mrcheck.render.gbuffer.near_plane`). Without ZERO_TO_ONE the
    [-1, 1] -> [0, 1] remap (z * 0.5 + 0.5) would round away the small values that carry the far
    depths (float32's spacing next to 0.5 is 2**-25).
    """
    _gl().clip_control(_GL_LOWER_LEFT, _GL_ZERO_TO_ONE)


def float_depth_texture(ctx: moderngl.Context, size, samples: int = 0) -> moderngl.Texture:
    """A depth attachment stored as GL_DEPTH_COMPONENT32F (moderngl's default is 24-bit fixed);
    ``samples`` > 1: a multisample one (the anti-aliased G-buffer, :mod:`mrcheck.render.antialias`)."""
    texture = ctx.depth_texture(size, samples=samples)
    gl = _gl()
    if samples > 1:
        gl.bind_texture(_GL_TEXTURE_2D_MULTISAMPLE, texture.glo)
        gl.tex_image_2d_multisample(_GL_TEXTURE_2D_MULTISAMPLE, samples, _GL_DEPTH_COMPONENT32F, size[0], size[1], 1)
        return texture
    gl.bind_texture(_GL_TEXTURE_2D, texture.glo)
    gl.tex_image_2d(
        _GL_TEXTURE_2D, 0, _GL_DEPTH_COMPONENT32F, size[0], size[1], 0, _GL_DEPTH_COMPONENT, _GL_FLOAT, None
    )
    return texture


def srgb_texture(ctx: moderngl.Context, size) -> moderngl.Texture:
    """An 8-bit sRGB colour attachment: with GL_FRAMEBUFFER_SRGB enabled, the driver encodes
    the linear colour a shader writes (llvmpipe's table: at most 1 step from the exact curve,
    and 2 ms less than three pow() per pixel at 1024x768). Read back, it holds sRGB bytes."""
    return ctx.texture(size, 4, dtype="f1", internal_format=_GL_SRGB8_ALPHA8)


# -- shader loading -------------------------------------------------------------------------------
PRELUDE = "<defines>"  # what GLSL source string 0 is: the #version line and the injected defines
# Line numbers of source string S start at S * LINE_BASE + 1. Mesa reports the line of every error
# but, for some errors (undeclared names), source string 0 whatever the #line said: the line
# number alone still tells the file.
LINE_BASE = 100_000
# a driver's position of a message: Mesa "S:L(C):", NVIDIA "S(L) :"; S is the source string number
_POSITION = re.compile(r"\b(\d+):(\d+)\((\d+)\)|\b(\d+)\((\d+)\)(?=\s*:)")


def _expand(name: str, directory: Path, files: list[str]) -> str:
    """The text of shader file ``name`` with its includes pasted in. Each pasted file is a GLSL
    source string of its own, numbered S by its place in ``files``, its lines numbered from
    S * LINE_BASE + 1 (``#line N S``: in GLSL 4.5 the line after it is line N of source string S),
    so that a compile error names its file and line (:func:`compile_errors`)."""
    path = directory / name
    try:
        text = path.read_text()
    except OSError:
        raise MrcheckError("shader file missing from the installation", path) from None
    number = len(files)
    files.append(name)
    base = number * LINE_BASE
    lines = [f"#line {base + 1} {number}"]
    for n, line in enumerate(text.splitlines(), 1):
        include = _INCLUDE.match(line)
        if include is None:
            lines.append(line)
        else:
            lines += [_expand(include.group(1), directory, files), f"#line {base + n + 1} {number}"]
    return "\n".join(lines)


def _stage_source(body: str, stage: str, defines: dict) -> str:
    lines = [f"#version {GL_VERSION} core", f"#define {stage} 1"]
    lines += [f"#define {key} {_glsl_literal(value)}" for key, value in sorted(defines.items())]
    return "\n".join([*lines, body])


def _glsl_literal(value) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value) if "e" in repr(value) or "." in repr(value) else f"{value}.0"
    return str(value)


def compile_errors(message: str, files: dict[str, list[str]]) -> str:
    """The driver's compile ``message`` as one line: its error lines, each position given as
    ``file.glsl:LINE(COL)`` of the file it is in. ``files``: by stage (moderngl's "vertex_shader" /
    "fragment_shader" headings), the file name of every source string."""
    names, found = next(iter(files.values())), []
    for line in message.splitlines():
        stage = next((s for s in files if line.strip() == s), None)
        if stage is not None:
            names = files[stage]
            continue
        if _POSITION.search(line) is None or "error" not in line.lower():
            continue

        def place(m):
            row, col = (int(m.group(2)), m.group(3)) if m.group(1) else (int(m.group(5)), None)
            source, row = divmod(row, LINE_BASE)
            name = names[source] if source < len(names) else f"source {source}"
            return f"{name}:{row}" + (f"({col})" if col else "")

        found.append(_POSITION.sub(place, line.strip(), count=1))
    return "; ".join(found) or " ".join(message.split())


def load_program(
    ctx: moderngl.Context, name: str, defines: dict | None = None, directory: Path | None = None
) -> moderngl.Program:
    """Compile ``<directory>/<name>.glsl`` (the shipped ``shaders/`` by default) with ``defines``;
    cached per (context, name, defines, directory). A compile error is one :class:`MrcheckError`
    line naming the file and line of each error, in whichever included file it is."""
    defines = dict(defines or {})
    directory = Path(directory) if directory is not None else shader_dir()
    key = (name, tuple(sorted(defines.items())), str(directory))
    cache = _extra(ctx).setdefault("programs", {})
    if key in cache:
        return cache[key]
    fragment_files, vertex_files = [PRELUDE], [PRELUDE]
    body = _expand(f"{name}.glsl", directory, fragment_files)
    if "VERTEX_SHADER" in body:
        vertex_body, vertex_files = body, fragment_files
    else:
        vertex_body = _expand("fullscreen.glsl", shader_dir(), vertex_files)
    try:
        program = ctx.program(
            vertex_shader=_stage_source(vertex_body, "VERTEX_SHADER", defines),
            fragment_shader=_stage_source(body, "FRAGMENT_SHADER", defines),
        )
    except moderngl.Error as exc:
        files = {"vertex_shader": vertex_files, "fragment_shader": fragment_files}
        raise MrcheckError(f"shader {name}.glsl does not compile: {compile_errors(str(exc), files)}") from None
    cache[key] = program
    return program


def uniform(program: moderngl.Program, name: str) -> moderngl.Uniform:
    """The uniform ``name`` of ``program``, for writing an array into it (``program[name] = value``
    sets a single value). moderngl types a member as any kind (uniform, block, attribute, varying)."""
    member = program[name]
    if not isinstance(member, moderngl.Uniform):
        raise TypeError(f"{name} is a {type(member).__name__} of the program, not a uniform")
    return member


def color_texture(fbo: moderngl.Framebuffer) -> moderngl.Texture:
    """The texture of ``fbo``'s first colour attachment (the framebuffers mrcheck reads back or
    samples from are made on textures; a renderbuffer attachment could be neither)."""
    attachment = fbo.color_attachments[0]
    if not isinstance(attachment, moderngl.Texture):
        raise TypeError(f"the framebuffer's colour attachment is a {type(attachment).__name__}, not a texture")
    return attachment


def timed_ms(ctx: moderngl.Context, work) -> float:
    """Milliseconds of the GL work of ``work()``, measured with the pipeline drained before and
    after (``ctx.finish()``), so that the figure includes llvmpipe's rasterisation threads."""
    ctx.finish()
    start = time.perf_counter()
    work()
    ctx.finish()
    return (time.perf_counter() - start) * 1000.0


def shader_path(name: str) -> Path:
    return shader_dir() / f"{name}.glsl"


__all__ = [
    "create_context",
    "flush",
    "made_current",
    "float_depth_texture",
    "srgb_texture",
    "load_program",
    "uniform",
    "color_texture",
    "compile_errors",
    "timed_ms",
    "shader_path",
    "GL_VERSION",
    "GL_FRAMEBUFFER_SRGB",
]
