"""The geometry pass: scene parts on the GPU, drawn into a G-buffer from a camera.

G-buffer (one texture per attachment, image row 0 = texel row 0):

=========  ========  ==============================================================
name       format    content
=========  ========  ==============================================================
depth      R32F      linear camera-space z (metres for parts with units); 0 = background
normal     RGBA16F   xyz: camera-space unit normal, facing the camera; w (anti-aliased): the
                     samples the pixel's surface covers, as bits (:mod:`mrcheck.render.antialias`)
albedo     RGBA8     rgb: part colour (linear); a: 1 front face, 0 back face
zbuffer    D32F      reversed-Z hardware depth near / z, infinite far plane (:func:`near_plane`)
=========  ========  ==============================================================

Each part is one vertex/index buffer (a float64 part, :func:`mrcheck.scene.precision.float32_tiles`, a
few), drawn instanced with per-instance model-view matrices
that are computed in float64 (view @ world) and cast to float32 only afterwards. Instances
outside the view frustum or hidden behind the big near occluders are skipped
(:mod:`mrcheck.render.culling`, exact), and parts are drawn front to back so that early depth testing
saves fragment work (llvmpipe shades every covered fragment).
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from mrcheck.core.camera import Camera, gl_projection
from mrcheck.core.errors import MrcheckError
from mrcheck.render import culling, lod
from mrcheck.render.gl import float_depth_texture, flush, load_program, uniform
from mrcheck.render.settings import DEFAULT_LOD_PX
from mrcheck.scene.model import Scene
from mrcheck.scene.precision import float32_tiles

PALETTE_MAX = 512  # part colours the anti-aliased G-buffer tells apart (gbuffer_pack.glsl)
FLUSH_TRIANGLES = 20_000  # see GeometryPass._submit
NEAR_SHARE = 0.5  # the near plane at half the nearest box in view (see near_plane)
NEAR_FLOOR = 2.0**-60  # ... or at this share of the farthest one, with the camera inside a box


@dataclass(frozen=True)
class DrawOptions:
    """How :meth:`GeometryPass.draw` draws a frame.

    lod_px : allowed error of a level of detail on screen, pixels (0 draws every part at full
        detail); see :mod:`mrcheck.render.lod`.
    occlusion_culling, backface_culling : exact (:mod:`mrcheck.render.culling`), off only to
        measure them.
    flush_triangles : a glFlush after this many triangles (0: none; see ``GeometryPass._submit``).
    """

    lod_px: float = DEFAULT_LOD_PX
    occlusion_culling: bool = True
    backface_culling: bool = True
    flush_triangles: int = FLUSH_TRIANGLES


@dataclass
class GBuffer:
    size: tuple
    depth: moderngl.Texture
    normal: moderngl.Texture | None  # None: the multisampled G-buffer (packed into ``depth``)
    albedo: moderngl.Texture | None
    zbuffer: moderngl.Texture
    fbo: moderngl.Framebuffer
    frame: int = 0  # counts the geometry passes drawn into it (what is derived from it is per frame)
    samples: int = 0  # > 1: multisampled (anti-aliasing, mrcheck.render.antialias), read by texelFetch only

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

    @classmethod
    def create_packed(cls, ctx: moderngl.Context, size, samples: int) -> "GBuffer":
        """The anti-aliased G-buffer: ``samples`` per pixel of (depth, packed normal, albedo
        and face) in one RG32F attachment (``shaders/gbuffer_pack.glsl``); no normal, albedo."""
        depth = ctx.texture(size, 2, dtype="f4", samples=samples)
        zbuffer = float_depth_texture(ctx, size, samples)
        return cls(tuple(size), depth, None, None, zbuffer, ctx.framebuffer([depth], zbuffer), samples=samples)

    def read_depth(self) -> np.ndarray:
        """(H, W) float32 linear depth, 0 = background."""
        w, h = self.size
        return np.frombuffer(self.depth.read(), np.float32).reshape(h, w)

    def read_front_facing(self) -> np.ndarray:
        """(H, W) bool: the visible surface is a front face (by the mesh's winding)."""
        w, h = self.size
        _, _, albedo = self.single_sampled()
        return np.frombuffer(albedo.read(), np.uint8).reshape(h, w, 4)[..., 3] > 127

    def single_sampled(self) -> tuple[moderngl.Texture, moderngl.Texture, moderngl.Texture]:
        """(depth, normal, albedo): what the passes after the geometry read. The multisampled
        G-buffer has only ``depth`` (all three packed), which the resolve and the edge pass read."""
        if self.normal is None or self.albedo is None:
            raise ValueError("the multisampled G-buffer packs its normal and albedo into its depth")
        return self.depth, self.normal, self.albedo

    def release(self) -> None:
        for obj in (self.fbo, self.depth, self.normal, self.albedo, self.zbuffer):
            if obj is not None:
                obj.release()


@dataclass
class Palette:
    """The scene's distinct part colours, for the anti-aliased G-buffer, which stores a
    sample's albedo as an index (``shaders/gbuffer_pack.glsl``): ``index`` by colour, and
    ``texture`` (N x 1 RGBA32F, linear RGB) that the resolve and the composite look them up in."""

    index: dict
    texture: moderngl.Texture

    @classmethod
    def of(cls, ctx: moderngl.Context, colors) -> "Palette":
        distinct = list(dict.fromkeys(tuple(c) for c in colors)) or [(0.0, 0.0, 0.0)]
        texture = ctx.texture(
            (max(len(distinct), 1), 1),
            4,
            dtype="f4",
            data=np.array([[*c, 1.0] for c in distinct], np.float32).tobytes(),
        )
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return cls({c: float(i) for i, c in enumerate(distinct)}, texture)

    @property
    def fits(self) -> bool:
        """Whether the packed index can hold every colour (9 bits)."""
        return len(self.index) <= PALETTE_MAX


@dataclass
class _GpuMesh:
    """One level of detail of a part on the GPU, with its own per-instance buffer. The first
    ``closed`` triangles belong to closed outward bodies (:func:`mrcheck.render.culling.closed_faces`)."""

    vbo: moderngl.Buffer
    ibo: moderngl.Buffer
    instances: moderngl.Buffer
    vao: moderngl.VertexArray
    triangles: int
    closed: int

    def release(self) -> None:
        for obj in (self.vao, self.vbo, self.ibo, self.instances):
            obj.release()


@dataclass
class _GpuPart:
    """A part's mesh on the GPU, or one piece of it (:func:`mrcheck.scene.precision.float32_tiles`)."""

    name: str  # the scene part's (labels a level-of-detail build)
    vertices: np.ndarray  # (n, 3) float32 local (the piece's own centre), for levels of detail
    faces: np.ndarray  # (m, 3) uint32
    levels: list  # [_GpuMesh]: 0 = the part's own mesh, then coarser ones
    errors: np.ndarray  # (len(levels),) measured error of each level, part units (0 first)
    lod_pending: bool  # levels to be loaded or built on first need (mrcheck.render.lod.eligible)
    color: tuple
    transforms: np.ndarray  # (k, 4, 4) float64 local -> world
    scales: np.ndarray  # (k,) largest stretch of each transform (units, scaling)
    local_corners: np.ndarray  # (8, 4) float64 homogeneous corners of the local bounds

    @property
    def triangles(self) -> int:
        return self.levels[0].triangles


class GeometryPass:
    """Uploads a :class:`Scene` once; :meth:`draw` renders it into a :class:`GBuffer` as its
    :class:`DrawOptions` say."""

    def __init__(self, ctx: moderngl.Context, scene: Scene):
        self.ctx = ctx
        self.scene = scene
        self.program = load_program(ctx, "gbuffer")
        self.parts = [gpu for part in scene.parts for gpu in self._upload(part)]
        self.palette = Palette.of(ctx, [gpu.color for gpu in self.parts])
        self.boxes = culling.Boxes(self.parts)
        self.hiz = culling.HiZ(ctx)
        self.last_stats: dict = {}

    def _upload_mesh(self, vertices, faces, instance_count: int) -> _GpuMesh:
        ctx = self.ctx
        closed = culling.closed_faces(vertices, faces)
        faces = np.concatenate([faces[closed], faces[~closed]])  # closed bodies first: one culled range
        vbo = ctx.buffer(np.ascontiguousarray(vertices, np.float32).tobytes())
        ibo = ctx.buffer(np.ascontiguousarray(faces, np.uint32).tobytes())
        instances = ctx.buffer(reserve=64 * instance_count, dynamic=True)
        vao = ctx.vertex_array(
            self.program,
            [(vbo, "3f", "in_position"), (instances, "16f/i", "in_model_view")],
            index_buffer=ibo,
            index_element_size=4,
        )
        return _GpuMesh(vbo, ibo, instances, vao, len(faces), int(closed.sum()))

    def _upload(self, part) -> list[_GpuPart]:
        """The part as one mesh, or a float64 part (:attr:`mrcheck.scene.model.Part.vertices`) in
        pieces that float32 holds around their own centres, each moved there by its transforms."""
        if part.vertices.dtype == np.float32:
            return [self._upload_piece(part, part.vertices, part.faces, part.transforms)]
        pieces = []
        for group in float32_tiles(part.vertices, part.faces):
            used, faces = np.unique(part.faces[group], return_inverse=True)
            vertices = part.vertices[used]
            centre = np.eye(4)
            centre[:3, 3] = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
            local = (vertices - centre[:3, 3]).astype(np.float32)  # subtracted in float64
            pieces.append(
                self._upload_piece(part, local, faces.reshape(-1, 3).astype(np.uint32), part.transforms @ centre)
            )
        return pieces

    def _upload_piece(self, part, vertices, faces, transforms) -> _GpuPart:
        mesh = self._upload_mesh(vertices, faces, len(transforms))
        lo, hi = vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        scales = np.linalg.norm(transforms[:, :3, :3], ord=2, axis=(1, 2))
        pending = lod.eligible(len(faces), len(transforms))
        return _GpuPart(
            part.name, vertices, faces, [mesh], np.zeros(1), pending, part.color, transforms, scales, corners
        )

    def _use_levels(self, gpu: _GpuPart) -> None:
        """Give ``gpu`` its levels of detail (from the disk cache, or built now)."""
        levels = lod.levels_for(gpu.vertices, gpu.faces, name=gpu.name)
        gpu.levels += [self._upload_mesh(level.vertices, level.faces, len(gpu.transforms)) for level in levels]
        gpu.errors = np.array([0.0] + [level.error for level in levels])
        gpu.lod_pending = False

    def prepare_levels(self) -> None:
        """Load or build every eligible part's levels of detail now instead of on first need
        (the benchmark does, so that no timed frame includes a build)."""
        for gpu in self.parts:
            if gpu.lod_pending:
                self._use_levels(gpu)

    # -- per-camera work --------------------------------------------------------------------
    def draw(self, gbuffer: GBuffer, camera: Camera, options: DrawOptions = DrawOptions()) -> dict:
        """Render the scene into ``gbuffer``; returns stats (near, far, what was drawn and culled)."""
        batches = culling.frustum(self.boxes, camera)
        near, far = near_plane(batches)
        P = gl_projection(camera, near)
        uniform(self.program, "u_projection").write(P.T.astype(np.float32).tobytes())
        self.program["u_pack"] = gbuffer.samples > 1

        gbuffer.fbo.use()
        gbuffer.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)
        gbuffer.frame += 1
        stats = {
            "near": near,
            "far": far,
            "instances_in_frustum": int(sum(len(b) for b in batches)),
            "instances_occluded": 0,
        }
        focal = max(camera.fx, camera.fy)
        occluders, candidates = culling.split_occluders(batches, camera)
        planned = self._plan(candidates, focal, options)
        if options.occlusion_culling and _triangles(planned) >= culling.MIN_CANDIDATE_TRIANGLES:
            draws = self._plan(occluders, focal, options)
            self._submit(draws, options.flush_triangles)
            drawn = list(occluders)
            for band in culling.depth_bands(candidates, culling.DEPTH_BANDS):
                self.hiz.build(gbuffer.depth, gbuffer.samples)
                hidden = [self.hiz.occluded(b.rect, b.z_near) for b in band]
                stats["instances_occluded"] += int(sum(h.sum() for h in hidden))
                visible = [b.subset(~h) for b, h in zip(band, hidden) if not h.all()]
                gbuffer.fbo.use()
                band_draws = self._plan(visible, focal, options)
                self._submit(band_draws, options.flush_triangles)
                draws += band_draws
                drawn += visible
        else:
            drawn = batches
            draws = self._plan(occluders, focal, options) + planned
            self._submit(draws, options.flush_triangles)
        stats.update(
            triangles_drawn=_triangles(draws),
            triangles_full_detail=_triangles(drawn),
            instances_drawn=int(sum(len(b) for b in drawn)),
            triangles_with_backface_culling=int(sum(d.mesh.closed * len(d.mv) for d in draws if d.cull)),
        )
        self.last_stats = stats
        return stats

    def _plan(self, batches, focal: float, options: DrawOptions) -> list["_Draw"]:
        """One draw per part and level of detail: each instance at the coarsest level whose
        error stays below ``lod_px`` pixels at its nearest depth (levels loaded or built on first
        need: which level an instance gets never depends on what was rendered before)."""
        draws = []
        for batch in batches:
            gpu = batch.part
            level = np.zeros(len(batch), np.int64)
            if options.lod_px > 0 and (gpu.lod_pending or len(gpu.levels) > 1):
                allowed = lod.allowed_error(batch.z_near, batch.scale, focal, options.lod_px)
                if gpu.lod_pending and allowed.max() > 0:
                    self._use_levels(gpu)
                level = lod.choose(gpu.errors, allowed)
            # Back faces of closed bodies may be culled for instances wholly in front of the
            # camera; which faces are "back" on screen flips with a mirroring transform.
            cull = np.full(len(batch), None, object)
            if options.backface_culling:
                in_front = batch.z_near > 0
                mirrored = np.linalg.det(batch.mv[:, :3, :3]) < 0
                cull[in_front] = np.where(mirrored[in_front], "front", "back")
            for index in np.unique(level):
                for face in ("back", "front", None):  # a fixed order: the same bytes every run
                    chosen = (level == index) & (cull == face)
                    if not chosen.any():
                        continue
                    draws.append(
                        _Draw(float(batch.z_near[chosen].min()), gpu.levels[index], batch.mv[chosen], gpu.color, face)
                    )
        return draws

    def _submit(self, draws: list["_Draw"], flush_triangles: int) -> None:
        """Draw into the bound framebuffer, nearest first (early depth testing saves fragments).

        A flush every ``flush_triangles`` triangles lets llvmpipe's threads rasterise what was
        submitted while this thread shades and bins the next draws' vertices; otherwise it
        rasterises the whole pass only after the last draw (measured, paired rounds: the `line`
        scene's aisle 1024x768 -10 %, the 1 M hall -5 to -7 %; 10-40 k triangles all about as
        good, 160 k no better than none)."""
        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"  # reversed-Z: larger is nearer
        # image row 0 is framebuffer row 0, a y flip, so counter-clockwise meshes appear clockwise
        ctx.front_face = "cw"
        pending = 0
        for draw in sorted(draws, key=lambda d: d.z_near):
            mesh, count = draw.mesh, len(draw.mv)
            mesh.instances.orphan(64 * count)
            # column-major for GLSL: transpose each 4x4
            mesh.instances.write(np.ascontiguousarray(draw.mv.transpose(0, 2, 1), np.float32).tobytes())
            self.program["u_albedo"] = draw.color
            self.program["u_albedo_index"] = self.palette.index[tuple(draw.color)]
            # closed bodies with back-face culling, the rest (open shells, inconsistent winding:
            # CAD exports have both) without; normals face the camera either way
            culled = 3 * mesh.closed if draw.cull else 0
            if culled and draw.cull:
                ctx.enable(moderngl.CULL_FACE)
                ctx.cull_face = draw.cull
                mesh.vao.render(moderngl.TRIANGLES, vertices=culled, instances=count)
            ctx.disable(moderngl.CULL_FACE)
            if culled < 3 * mesh.triangles:
                mesh.vao.render(moderngl.TRIANGLES, vertices=3 * mesh.triangles - culled, first=culled, instances=count)
            pending += mesh.triangles * count
            if flush_triangles and pending >= flush_triangles:
                flush()
                pending = 0
        ctx.disable(moderngl.DEPTH_TEST)

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
            for mesh in gpu.levels:
                mesh.release()
        self.hiz.release()
        self.palette.texture.release()


@dataclass
class _Draw:
    z_near: float
    mesh: _GpuMesh
    mv: np.ndarray
    color: tuple
    cull: str | None  # "back" / "front": cull those faces of the mesh's closed bodies; None: none

    @property
    def triangles(self) -> int:
        return self.mesh.triangles * len(self.mv)


def _triangles(items) -> int:
    """Triangles of batches (at full detail) or of draws (at their level)."""
    return int(sum(item.triangles if isinstance(item, _Draw) else item.part.triangles * len(item) for item in items))


def near_plane(batches) -> tuple[float, float]:
    """(near, far): the near plane for the instances in view, and their farthest box depth.

    The projection has no far plane (:func:`mrcheck.core.camera.gl_projection`): depth ``near / z``
    in a float32 buffer resolves z to the same relative precision at any distance, so nothing
    far away (a stray element at the origin of a model at map coordinates, 5e6 m off) takes
    precision from what is near. ``near`` only decides what is clipped: half the nearest box
    depth when every box in view lies wholly in front of the camera. A camera inside some box
    (a hall's walls, a floor reaching under it) may have that part's surface arbitrarily close;
    then ``near`` is ``far * NEAR_FLOOR``, which clips nothing a camera can see (for a farthest
    part at 1e12 m, what is nearer than 1 micrometre) and keeps ``near / z`` a normal float32
    (>= 2**-126) for every z in view: llvmpipe flushes smaller ones to 0, the background
    (measured: a near plane at 2**-128 of the farthest part lost 19 % of a hall's pixels).
    ``far`` is reported only, in the geometry pass's stats.
    """
    far = max((float(b.z_far.max()) for b in batches), default=1.0)
    front = [b.z_near[b.z_near > 0] for b in batches]
    nearest = min((float(z.min()) for z in front if z.size), default=far)
    inside = any(bool((b.z_near <= 0).any()) for b in batches)
    near = min(NEAR_SHARE * nearest, far * NEAR_FLOOR) if inside else NEAR_SHARE * nearest
    return near, far


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


__all__ = ["DrawOptions", "GBuffer", "GeometryPass", "check_camera_outside", "near_plane"]
