"""Occlusion culling (exact: the image must not change) and levels of detail (bounded change).

The scenes are built in code: a wall hiding a field of spheres, with a few spheres beside it in
view, so that both what is hidden and what is not are known.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.core.progress import showing_progress
from mrcheck.core.resources import shipped_scene
from mrcheck.render import culling, lod
from mrcheck.render.gbuffer import FLUSH_TRIANGLES, DrawOptions, GBuffer
from mrcheck.render.gl import made_current
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene, make_part

W, H = 320, 240


def _grid(xs, ys, z=1.0):
    return [trimesh.transformations.translation_matrix((x, y, z)) for x in xs for y in ys]


def _scene(sphere_subdivisions=2) -> tuple[Scene, Camera]:
    """A floor, a 12 m wide wall 12 m ahead (26.6 degrees to either side), 160 spheres behind it
    (at most 14 degrees off the axis) and 8 beside it, 30-36 degrees off (the image's half-width
    is 37.6 degrees)."""
    floor = trimesh.creation.box((80, 80, 0.1), trimesh.transformations.translation_matrix((0, 20, -0.05)))
    wall = trimesh.creation.box((12, 0.3, 6), trimesh.transformations.translation_matrix((0, 10, 3)))
    sphere = trimesh.creation.icosphere(sphere_subdivisions, radius=0.5)
    hidden = _grid(np.linspace(-4, 4, 16), np.linspace(14, 30, 10))
    beside = [
        trimesh.transformations.translation_matrix((sx * x, y, 1.0))
        for sx in (-1, 1)
        for x, y in ((11.0, 16.0), (12.5, 16.0), (14.5, 22.0), (16.0, 22.0))
    ]
    parts = [
        make_part("floor", Path("floor"), floor.vertices, floor.faces, [np.eye(4)]),
        make_part("wall", Path("wall"), wall.vertices, wall.faces, [np.eye(4)]),
        make_part("spheres", Path("spheres"), sphere.vertices, sphere.faces, hidden + beside),
    ]
    camera = Camera.from_look_at((0.0, -2.0, 1.7), (0.0, 20.0, 1.7), (0, 0, 1), 60, W, H)
    return Scene("culling-test", Path("culling-test"), parts), camera


def _draw(
    renderer: Renderer,
    camera: Camera,
    occlusion: bool,
    lod_px: float,
    prepare: bool = True,
    backface: bool = True,
    size=(W, H),
    flush_triangles: int = FLUSH_TRIANGLES,
):
    with made_current(renderer.ctx):
        if prepare:
            renderer.geometry.prepare_levels()
        gbuffer = GBuffer.create(renderer.ctx, size)
        options = DrawOptions(
            lod_px=lod_px, occlusion_culling=occlusion, backface_culling=backface, flush_triangles=flush_triangles
        )
        stats = renderer.geometry.draw(gbuffer, camera, options)
        depth = gbuffer.read_depth().copy()
        gbuffer.release()
    return stats, depth


def test_occlusion_culling_skips_hidden_instances_and_changes_no_pixel(monkeypatch):
    monkeypatch.setattr(culling, "MIN_CANDIDATE_TRIANGLES", 0)  # the test scene is small
    scene, camera = _scene()
    renderer = Renderer(scene)
    try:
        plain, depth_plain = _draw(renderer, camera, occlusion=False, lod_px=0.0)
        culled, depth_culled = _draw(renderer, camera, occlusion=True, lod_px=0.0)
    finally:
        renderer.release()
    assert plain["instances_occluded"] == 0
    # the wall hides the 160 spheres behind it; floor, wall and the 8 beside it are drawn
    assert culled["instances_occluded"] == 160
    assert culled["instances_drawn"] == 8 + 2
    assert culled["triangles_drawn"] < plain["triangles_drawn"] / 2
    np.testing.assert_array_equal(depth_culled, depth_plain)


def test_closed_faces_finds_closed_outward_bodies_only():
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    assert culling.closed_faces(box.vertices, box.faces).all()
    # flat-shaded exports repeat every vertex per face: the same box, still closed
    flat = box.vertices[box.faces.reshape(-1)]
    assert culling.closed_faces(flat, np.arange(len(flat)).reshape(-1, 3)).all()
    assert not culling.closed_faces(box.vertices, box.faces[:, ::-1]).any()  # wound inwards
    assert not culling.closed_faces(box.vertices, box.faces[1:]).any()  # a hole
    sheet = np.array([[0, 1, 2], [0, 2, 3]])
    two_sided = np.concatenate([sheet, sheet[:, ::-1]])  # closed, no volume
    assert not culling.closed_faces(box.vertices[[0, 1, 3, 2]], two_sided).any()
    # one part, two bodies: the closed one qualifies, the open one does not
    other = box.copy()
    other.apply_translation((5.0, 0.0, 0.0))
    vertices = np.concatenate([box.vertices, other.vertices])
    faces = np.concatenate([box.faces, other.faces[2:] + len(box.vertices)])
    assert culling.closed_faces(vertices, faces).tolist() == [True] * 12 + [False] * 10


def _closed_scene() -> tuple[Scene, Camera]:
    """Closed boxes (one mirrored), an inward-wound box, an open box and a floor."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    move = trimesh.transformations.translation_matrix
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    floor = trimesh.creation.box((40, 40, 0.1), move((0, 10, -0.05)))
    parts = [
        make_part("floor", Path("floor"), floor.vertices, floor.faces, [np.eye(4)]),
        make_part(
            "boxes",
            Path("boxes"),
            box.vertices,
            box.faces,
            [move((-2, 6, 0.5)), move((0, 7, 0.5)) @ mirror, move((2, 6, 0.5)) @ np.diag([1, 2, 1, 1.0])],
        ),
        make_part("inward", Path("inward"), box.vertices, box.faces[:, ::-1], [move((-1, 9, 1.5))]),
        make_part("open", Path("open"), box.vertices, box.faces[2:], [move((1, 9, 1.5))]),
    ]
    camera = Camera.from_look_at((0.3, -1.0, 2.5), (0.0, 8.0, 0.5), (0, 0, 1), 60, W, H)
    return Scene("backface-test", Path("backface-test"), parts), camera


def test_backface_culling_skips_closed_back_faces_and_changes_no_pixel():
    scene, camera = _closed_scene()
    renderer = Renderer(scene)
    try:
        plain, depth_plain = _draw(renderer, camera, occlusion=False, lod_px=0.0, backface=False)
        culled, depth_culled = _draw(renderer, camera, occlusion=False, lod_px=0.0)
    finally:
        renderer.release()
    assert plain["triangles_with_backface_culling"] == 0
    # the three boxes; not the inward and the open box, nor the floor, closed but reaching
    # behind the camera (a near plane may cut it open)
    assert culled["triangles_with_backface_culling"] == 3 * 12
    assert (depth_plain > 0).mean() > 0.5
    np.testing.assert_array_equal(depth_culled, depth_plain)


@pytest.mark.slow
@pytest.mark.parametrize("view", ["aisle", "robot_cell"])
def test_backface_culling_on_the_line_scene_changes_only_crack_pixels(view):
    """Exact in theory; in practice a ray through the crack between two bodies' faces (T-junction)
    may see a back face inside the neighbour, with culling the face behind it, at nearly the same
    depth."""
    scene = load_scene(shipped_scene("line"))
    camera = scene.camera(view, W, H)
    renderer = Renderer(scene)
    try:
        plain, depth_plain = _draw(renderer, camera, occlusion=False, lod_px=0.0, prepare=False, backface=False)
        culled, depth_culled = _draw(renderer, camera, occlusion=False, lod_px=0.0, prepare=False)
    finally:
        renderer.release()
    assert culled["triangles_with_backface_culling"] > 0.5 * culled["triangles_drawn"]
    changed = depth_culled != depth_plain
    assert changed.mean() < 1e-3  # 26 of 76,800 pixels here; 53 of 786,432 at 1024x768
    relative = np.abs(depth_culled - depth_plain)[changed] / depth_plain[changed]
    assert relative.max(initial=0.0) < 1e-3


def test_flushing_between_draws_changes_no_pixel():
    scene, camera = _closed_scene()
    renderer = Renderer(scene)
    try:
        _, depth_one_go = _draw(renderer, camera, occlusion=False, lod_px=0.0, flush_triangles=0)
        # glFlush after every draw
        _, depth_flushed = _draw(renderer, camera, occlusion=False, lod_px=0.0, flush_triangles=1)
    finally:
        renderer.release()
    np.testing.assert_array_equal(depth_flushed, depth_one_go)


def test_hiz_test_is_conservative_at_block_edges():
    """A box is hidden only if every block its rectangle touches is nearer than its nearest depth."""
    scene, camera = _scene()
    renderer = Renderer(scene)
    try:
        with made_current(renderer.ctx):
            depth = np.full((H, W), 5.0, np.float32)
            depth[:, 200:] = 0.0  # background from x = 200 on: nothing hidden there
            depth[100, 50] = 20.0  # one far pixel in an otherwise near block
            texture = renderer.ctx.texture((W, H), 1, depth.tobytes(), dtype="f4")
            renderer.geometry.hiz.build(texture)
            rects = np.array(
                [
                    [10, 10, 40, 40],  # all near: hidden behind 5 m
                    [190, 10, 205, 40],  # reaches the background: visible
                    [45, 95, 55, 105],  # covers the far pixel: visible at 10 m
                    [100, 150, 110, 160],
                ],
                float,
            )
            hidden = renderer.geometry.hiz.occluded(rects, np.full(4, 10.0))
            texture.release()
    finally:
        renderer.release()
    assert hidden.tolist() == [True, False, False, True]


def test_levels_have_measured_errors_and_remove_flat_subdivisions():
    # a box whose faces are subdivided 8x8: the coarser levels reach ~12 triangles at zero error
    box = trimesh.creation.box((1.0, 1.0, 1.0)).subdivide().subdivide().subdivide()
    levels = lod.build_levels(box.vertices, box.faces)
    assert levels and len(levels[-1].faces) < len(box.faces) / 16
    flat = [level for level in levels if level.error < 1e-5]
    assert flat and min(len(level.faces) for level in flat) <= 24
    # a sphere: fewer triangles cost shape, and the measured error says how much
    sphere = trimesh.creation.icosphere(4, radius=1.0)
    levels = lod.build_levels(sphere.vertices, sphere.faces)
    errors = [level.error for level in levels]
    assert len(levels) >= 3 and errors[-1] > errors[0] > 0
    for level in levels:  # the error is at least the distance of the level's vertices from the sphere
        assert level.error >= np.abs(np.linalg.norm(level.vertices, axis=1) - 1.0).max() - 1e-4


def test_choose_picks_the_coarsest_level_within_the_allowed_error():
    errors = np.array([0.0, 0.01, 0.05, 0.2])
    allowed = np.array([0.0, 0.009, 0.01, 0.1, 5.0])
    assert lod.choose(errors, allowed).tolist() == [0, 0, 1, 2, 3]
    # the allowed error grows with depth, shrinks with the instance's scale; 0 at the camera plane
    a = lod.allowed_error(np.array([-1.0, 10.0, 20.0, 20.0]), np.array([1.0, 1.0, 1.0, 2.0]), 500.0, 0.5)
    assert a.tolist() == pytest.approx([0.0, 0.01, 0.02, 0.01])


def test_levels_of_detail_cut_triangles_and_move_silhouettes_by_less_than_a_pixel():
    scene, camera = _scene(sphere_subdivisions=4)  # 5120 triangles per sphere
    renderer = Renderer(scene)
    try:
        full, depth_full = _draw(renderer, camera, occlusion=False, lod_px=0.0)
        coarse, depth_lod = _draw(renderer, camera, occlusion=False, lod_px=lod.LOD_PIXELS)
    finally:
        renderer.release()
    assert coarse["triangles_drawn"] < full["triangles_drawn"] / 4
    assert coarse["triangles_full_detail"] == full["triangles_drawn"]
    both = (depth_full > 0) & (depth_lod > 0)
    assert ((depth_full > 0) != (depth_lod > 0)).mean() < 0.002  # coverage: silhouette pixels only
    relative = np.abs(depth_lod - depth_full)[both] / depth_full[both]
    assert np.mean(relative > 0.01) < 0.005


def test_which_parts_get_levels_depends_on_the_scene_alone():
    """A render must not depend on what was rendered before (reproducible bytes)."""
    scene, camera = _scene()
    first = Renderer(scene)
    try:
        one, depth_one = _draw(first, camera, occlusion=False, lod_px=lod.LOD_PIXELS, prepare=False)
        two, depth_two = _draw(first, camera, occlusion=False, lod_px=lod.LOD_PIXELS, prepare=False)
    finally:
        first.release()
    assert one["triangles_drawn"] < one["triangles_full_detail"]  # 168 spheres: levels from the first frame
    assert two == one
    np.testing.assert_array_equal(depth_two, depth_one)
    assert not lod.eligible(20_000, 1) and lod.eligible(20_000, lod.MIN_INSTANCES)
    assert lod.eligible(lod.MIN_SINGLE_TRIANGLES, 1)  # a robot
    assert not lod.eligible(10, 1000) and not lod.eligible(2_000_000, 100)


def test_lod_setting_is_validated():
    from mrcheck.core.errors import MrcheckError

    with pytest.raises(MrcheckError, match="level-of-detail"):
        RenderSettings(lod_px=-1).validated(240)


def test_levels_are_cached_on_disk_by_content(tmp_path, monkeypatch):
    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path))
    sphere = trimesh.creation.icosphere(3, radius=1.0)
    built = lod.levels_for(sphere.vertices, sphere.faces)
    files = list((tmp_path / "lod").glob("*.npz"))
    assert len(files) == 1
    loaded = lod.levels_for(sphere.vertices, sphere.faces)
    assert [len(level.faces) for level in loaded] == [len(level.faces) for level in built]
    assert [level.error for level in loaded] == [level.error for level in built]
    # another mesh, another entry; a damaged entry is rebuilt, not trusted
    lod.levels_for(sphere.vertices * 2.0, sphere.faces)
    assert len(list((tmp_path / "lod").glob("*.npz"))) == 2
    files[0].write_bytes(b"not an npz")
    rebuilt = lod.levels_for(sphere.vertices, sphere.faces)
    assert [level.error for level in rebuilt] == [level.error for level in built]


def test_building_levels_shows_progress_and_loading_them_does_not(tmp_path, monkeypatch):
    """Building a robot's levels on a first render took 8-12 s with nothing on the terminal after
    the loading bar: a progress display (the command line's bar, as mrcheck's others) says what
    is being built, step by step, and is closed when done."""
    bars = []

    def progress(items, desc, unit):
        bar = {"desc": desc, "unit": unit, "n": 0, "closed": False}
        bars.append(bar)
        try:
            for item in items:
                bar["n"] += 1
                yield item
        finally:
            bar["closed"] = True

    monkeypatch.setenv("MRCHECK_CACHE_DIR", str(tmp_path))
    sphere = trimesh.creation.icosphere(3, radius=1.0)
    with showing_progress(progress):
        levels = lod.levels_for(sphere.vertices, sphere.faces, "robot_2")
        assert len(bars) == 1
        bar = bars[0]
        assert bar["desc"] == f"building levels of detail (robot_2, {len(sphere.faces):,} triangles)"
        assert bar["closed"] and bar["n"] == len(levels) > 0
        lod.levels_for(sphere.vertices, sphere.faces)  # from the cache: milliseconds, no bar
        assert len(bars) == 1
