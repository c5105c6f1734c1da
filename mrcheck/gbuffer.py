"""The geometry pass: scene parts on the GPU, drawn into a G-buffer from a camera.

G-buffer (one texture per attachment, image row 0 = texel row 0):

=========  ========  ==============================================================
name       format    content
=========  ========  ==============================================================
depth      R32F      linear camera-space z (metres for parts with units); 0 = background
normal     RGBA16F   xyz: camera-space unit normal, facing the camera
albedo     RGBA8     rgb: part colour (linear); a: 1 front face, 0 back face
zbuffer    D32F      reversed-Z hardware depth (see :func:`mrcheck.gl._enable_reversed_z`)
=========  ========  ==============================================================

Each part is one vertex/index buffer, drawn instanced with per-instance model-view matrices
that are computed in float64 (view @ world) and cast to float32 only afterwards. Instances
whose bounds lie outside the view frustum are skipped, and parts are drawn front to back so
that early depth testing saves fragment work (llvmpipe shades every covered fragment).
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from .camera import Camera, gl_projection
from .errors import MrcheckError
from .gl import float_depth_texture, load_program
from .scene import Scene


@dataclass
class GBuffer:
    size: tuple
    depth: moderngl.Texture
    normal: moderngl.Texture
    albedo: moderngl.Texture
    zbuffer: moderngl.Texture
    fbo: moderngl.Framebuffer

    @classmethod
    def create(cls, ctx: moderngl.Context, size) -> "GBuffer":
        depth = ctx.texture(size, 1, dtype="f4")
        normal = ctx.texture(size, 4, dtype="f2")
        albedo = ctx.texture(size, 4, dtype="f1")
        for texture in (depth, normal, albedo):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        zbuffer = float_depth_texture(ctx, size)
        fbo = ctx.framebuffer([depth, normal, albedo], zbuffer)
        return cls(tuple(size), depth, normal, albedo, zbuffer, fbo)

    def read_depth(self) -> np.ndarray:
        """(H, W) float32 linear depth, 0 = background."""
        w, h = self.size
        return np.frombuffer(self.depth.read(), np.float32).reshape(h, w)

    def read_front_facing(self) -> np.ndarray:
        """(H, W) bool: the visible surface is a front face (by the mesh's winding)."""
        w, h = self.size
        return np.frombuffer(self.albedo.read(), np.uint8).reshape(h, w, 4)[..., 3] > 127

    def release(self) -> None:
        for obj in (self.fbo, self.depth, self.normal, self.albedo, self.zbuffer):
            obj.release()


@dataclass
class _GpuPart:
    name: str
    vbo: moderngl.Buffer
    ibo: moderngl.Buffer
    instances: moderngl.Buffer
    vao: moderngl.VertexArray
    color: tuple
    transforms: np.ndarray     # (k, 4, 4) float64 local -> world
    local_corners: np.ndarray  # (8, 4) float64 homogeneous corners of the local bounds


class GeometryPass:
    """Uploads a :class:`Scene` once; :meth:`draw` renders it into a :class:`GBuffer`."""

    def __init__(self, ctx: moderngl.Context, scene: Scene):
        self.ctx = ctx
        self.scene = scene
        self.program = load_program(ctx, "gbuffer")
        self.parts = [self._upload(part) for part in scene.parts]
        self.last_stats = {}

    def _upload(self, part) -> _GpuPart:
        ctx = self.ctx
        vbo = ctx.buffer(np.ascontiguousarray(part.vertices, np.float32).tobytes())
        ibo = ctx.buffer(np.ascontiguousarray(part.faces, np.uint32).tobytes())
        instances = ctx.buffer(reserve=64 * len(part.transforms), dynamic=True)
        vao = ctx.vertex_array(
            self.program,
            [(vbo, "3f", "in_position"), (instances, "16f/i", "in_model_view")],
            index_buffer=ibo,
            index_element_size=4,
        )
        lo, hi = part.local_bounds()
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return _GpuPart(part.name, vbo, ibo, instances, vao, part.color, part.transforms, corners)

    # -- per-camera work --------------------------------------------------------------------
    def _visible_instances(self, camera: Camera):
        """Per part: (model-view (k, 4, 4) float64 of instances in the frustum, nearest z, farthest z)."""
        V = camera.view_matrix()
        # frustum side planes in camera space through the image corners (with a 1 px margin)
        u0, u1 = (-1.5 - camera.cx) / camera.fx, (camera.width + 0.5 - camera.cx) / camera.fx
        v0, v1 = (-1.5 - camera.cy) / camera.fy, (camera.height + 0.5 - camera.cy) / camera.fy
        result = []
        for gpu in self.parts:
            mv = V @ gpu.transforms                                   # (k, 4, 4) float64
            c = np.einsum("kij,cj->kci", mv, gpu.local_corners)[..., :3]  # (k, 8, 3) camera space
            x, y, z = c[..., 0], c[..., 1], c[..., 2]
            outside = (
                (z <= 0).all(axis=1)
                | (x < u0 * z).all(axis=1) | (x > u1 * z).all(axis=1)
                | (y < v0 * z).all(axis=1) | (y > v1 * z).all(axis=1)
            )
            keep = ~outside
            if keep.any():
                zk = z[keep]
                result.append((gpu, mv[keep], float(zk.min()), float(zk.max())))
        return result

    def draw(self, gbuffer: GBuffer, camera: Camera) -> dict:
        """Render the scene into ``gbuffer``; returns stats (near, far, drawn instances...)."""
        visible = self._visible_instances(camera)
        far = max((v[3] for v in visible), default=1.0)
        nearest = min((v[2] for v in visible), default=far)
        # Reversed-Z float depth keeps relative precision at any distance, so near only has to
        # be in front of every visible surface; a camera inside a part's bounds (a hall's walls)
        # falls back to a near plane 1e-6 of the far distance.
        near = nearest * 0.5 if nearest > 0 else far * 1e-6
        near = max(near, far * 1e-6)
        far = far * 1.01 + near

        P = _reversed_z(gl_projection(camera, near, far), near, far)
        self.program["u_projection"].write(P.T.astype(np.float32).tobytes())

        ctx = self.ctx
        gbuffer.fbo.use()
        gbuffer.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"   # reversed-Z: larger is nearer
        ctx.disable(moderngl.CULL_FACE)  # CAD exports have inconsistent winding; normals face the camera anyway
        # image row 0 is framebuffer row 0, a y flip, so counter-clockwise meshes appear clockwise
        ctx.front_face = "cw"
        triangles = 0
        for gpu, mv, _, _ in sorted(visible, key=lambda v: v[2]):  # front to back
            gpu.instances.orphan(64 * len(mv))
            # column-major for GLSL: transpose each 4x4
            gpu.instances.write(np.ascontiguousarray(mv.transpose(0, 2, 1), np.float32).tobytes())
            self.program["u_albedo"].value = gpu.color
            gpu.vao.render(moderngl.TRIANGLES, instances=len(mv))
            triangles += (gpu.ibo.size // 12) * len(mv)
        ctx.disable(moderngl.DEPTH_TEST)
        self.last_stats = {"near": near, "far": far, "triangles_drawn": triangles,
                           "instances_drawn": int(sum(len(v[1]) for v in visible))}
        return self.last_stats

    def camera_inside_part(self, camera: Camera) -> str | None:
        """Name of a part whose instance bounds contain the camera centre, if any."""
        centre = camera.center
        for part in self.scene.parts:
            boxes = part.instance_bounds()
            if ((boxes[:, 0] <= centre) & (centre <= boxes[:, 1])).all(axis=1).any():
                return part.name
        return None

    def release(self) -> None:
        for gpu in self.parts:
            for obj in (gpu.vao, gpu.vbo, gpu.ibo, gpu.instances):
                obj.release()


def _reversed_z(P: np.ndarray, near: float, far: float) -> np.ndarray:
    """Swap the z row of a [-1, 1] projection for reversed-Z in [0, 1]: z=near -> 1, z=far -> 0."""
    R = P.copy()
    R[2, 2] = -near / (far - near)
    R[2, 3] = near * far / (far - near)
    return R


def check_camera_outside(geometry: GeometryPass, gbuffer: GBuffer, camera: Camera, source) -> None:
    """Refuse a camera that sits inside a closed part: the view would show its inside faces.

    Only looked at when the camera centre lies inside some part's bounds (cheap CPU test), then
    decided on the G-buffer: nearly every pixel covered, mostly by back faces.
    """
    part = geometry.camera_inside_part(camera)
    if part is None:
        return
    covered = gbuffer.read_depth() > 0
    if covered.mean() < 0.98:
        return
    back = ~gbuffer.read_front_facing()[covered]
    if back.mean() > 0.9:
        raise MrcheckError(
            f"the camera is inside geometry (part {part!r}): {back.mean():.0%} of the view sees back faces; "
            "move the camera or hide that part",
            source,
        )


__all__ = ["GBuffer", "GeometryPass", "check_camera_outside"]
