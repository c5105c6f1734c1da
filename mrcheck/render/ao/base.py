"""What every screen-space AO pass shares: G-buffer inputs, kernel, rotation tile, one draw."""

from __future__ import annotations

import moderngl

from mrcheck.render.ao import kernel
from mrcheck.render.gl import load_program, uniform
from mrcheck.render.settings import intensity_of


class AOPass:
    """A full-screen AO pass compiled for one sample count.

    Subclasses name their shader (``shader``), may replace the offsets (``offsets``, a function
    of (samples, seed)), add compile-time constants (:meth:`method_defines`) and set their own
    uniforms in :meth:`_set_method_uniforms` (by default the world radius, which every mode but
    ``vector`` uses).
    """

    shader: str = ""
    mode: str = ""  # the mode's name (MODES): its default strength (settings.default_intensity)
    offsets = staticmethod(kernel.sphere_kernel)

    def __init__(self, ctx: moderngl.Context, samples: int, seed: int = 0, stride: int = 1):
        self.ctx = ctx
        self.samples = int(samples)
        self.stride = int(stride)
        self.seed = int(seed)
        self.program = load_program(
            ctx, self.shader, {**kernel.defines(samples, stride), **self.method_defines(self.samples)}
        )
        self.noise = ctx.texture((kernel.NOISE_SIZE, kernel.NOISE_SIZE), 3, dtype="f4")
        self.noise.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.frame = -1
        self.use_frame(0)
        for unit, name in enumerate(("u_depth", "u_normal", "u_noise")):
            set_if_present(self.program, name, unit)  # crytek reads no normal
        self.vao = ctx.vertex_array(self.program, [])

    def use_frame(self, frame: int) -> None:
        """Sample with accumulation frame ``frame``'s kernel and rotation tile (another random
        orientation of the kernel, other reflection planes: :func:`kernel.frame_seed`); frame 0
        is the render's own. Uniform and texture writes only: no shader is compiled again."""
        if frame == self.frame:
            return
        seed = kernel.frame_seed(self.seed, frame)
        if "u_kernel" in self.program:  # a method may not use the kernel (hbao)
            uniform(self.program, "u_kernel").write(self.offsets(self.samples, seed).tobytes())
        self.noise.write(kernel.rotation_tile(seed).tobytes())
        self.frame = frame

    def run(
        self,
        target: moderngl.Framebuffer,
        depth: moderngl.Texture,
        normal: moderngl.Texture,
        intrinsics,
        settings,
        scale: float = 1.0,
    ) -> None:
        """Write (AO, depth) texels into ``target`` (RG32F, the G-buffer's size / stride; see
        ``shaders/ao_common.glsl``).

        ``intrinsics`` are (fx, fy, cx, cy) at the pass's resolution; ``scale`` is that
        resolution over the output resolution (0.5 for half-resolution AO).
        """
        fx, fy, cx, cy = intrinsics
        self.program["u_intrinsics"] = (fx, fy, cx, cy)
        self.program["u_size"] = target.size
        self.program["u_intensity"] = intensity_of(settings, self.mode)
        self._set_method_uniforms(settings, scale)
        depth.use(0)
        normal.use(1)
        self.noise.use(2)
        draw_covered(self.ctx, target, self.vao)

    def method_defines(self, samples: int) -> dict:
        """Constants of the method's shader beyond the shared ones (:func:`kernel.defines`)."""
        return {}

    def _set_method_uniforms(self, settings, scale: float) -> None:
        self.program["u_radius_world"] = float(settings.radius_world)

    def release(self) -> None:
        self.noise.release()
        self.vao.release()


def draw_covered(ctx: moderngl.Context, target: moderngl.Framebuffer, vao: moderngl.VertexArray) -> None:
    """Draw a full-screen pass into ``target`` only where the G-buffer has geometry: ``target``
    carries the G-buffer's depth buffer at full resolution, the coverage pass's at half
    (:class:`mrcheck.render.targets.RenderTargets`; both 0 on the background).

    The background's texels are cleared to (AO 1, depth 0) and an early depth test rejects its
    fragments: the full-screen triangle lies at depth 0, the reversed-Z background too, so
    "less" passes exactly where something was drawn. llvmpipe then skips every 4x4 block of
    background without running the shader; the shaders' own early return cannot do that for the
    unrolled sample loop (shaders/ao_unroll.glsl), whose straight-line code runs masked off
    (measured: without this, the sample cell's `overview`, a third sky, took 12-27 % longer
    unrolled than as a loop).
    """
    target.use()
    target.depth_mask = False  # the clear and the pass leave the G-buffer's depth alone
    target.clear(1.0, 0.0, 0.0, 0.0)
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "<"
    vao.render(moderngl.TRIANGLES, vertices=3)
    ctx.disable(moderngl.DEPTH_TEST)


def set_if_present(program: moderngl.Program, name: str, value) -> None:
    """Set a uniform the compiler may have optimised away (then there is nothing to set)."""
    if name in program:
        program[name] = value


__all__ = ["AOPass", "draw_covered", "set_if_present"]
