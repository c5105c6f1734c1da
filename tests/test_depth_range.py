"""Depth that survives huge extents (issue 17, defect 3).

A part 3e7 m away used to set the near plane to 1e-6 of the farthest distance (30 m), which
clipped everything nearer: one flat colour and "no CAD part is in view", exit 0. The depth buffer
is now reversed-Z float with an infinite far plane, so nothing far away changes what is near.
Every case is compared with the same near geometry rendered alone (or at the origin): the far
parts must change nothing that the camera sees in front of them. The same holds for what works
on the scene in float32 elsewhere (ray-traced reference, discrepancy ids, review pick,
deviation), and for a far element in the SAME mesh as the near ones (one file of a whole model),
which float32 around the mesh's one centre would round to metres.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.eval.reference import REFERENCE_LOD_PX, reference_ao
from mrcheck.render.gl import made_current
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene, make_part

from .conftest import box

W, H = 160, 120
SETTINGS = RenderSettings(samples=8, blur=False)
FAR = 3e7  # the second copy, this much further along the view direction


def _part(name, mesh: trimesh.Trimesh, offset=(0.0, 0.0, 0.0)):
    """A part whose FILE coordinates are moved by ``offset`` (float64, as a site export's)."""
    return make_part(name, name, np.asarray(mesh.vertices, np.float64) + offset, np.asarray(mesh.faces), np.eye(4))


def _render(ctx, parts, camera, modes=("phong", "vector")):
    renderer = Renderer(Scene("t", "t", list(parts)), ctx=ctx)
    try:
        results = renderer.render(camera, list(modes), SETTINGS, want_ao=True)
        return results, results.depth
    finally:
        renderer.release()


def _assert_same_render(ctx, parts, reference_parts, camera, camera_ref=None, covered=0.05):
    """``parts`` seen from ``camera`` render what ``reference_parts`` do from ``camera_ref``."""
    got, depth = _render(ctx, parts, camera)
    want, depth_ref = _render(ctx, reference_parts, camera_ref or camera)
    assert (depth_ref > 0).mean() > covered  # there is something to compare
    assert np.array_equal(depth > 0, depth_ref > 0)
    np.testing.assert_allclose(depth, depth_ref, rtol=1e-5)
    for mode in ("phong", "vector"):
        diff = np.abs(got[mode].image.astype(float) - want[mode].image.astype(float)) / 255.0
        assert diff.mean() < 0.002 and (diff > 8 / 255).mean() < 0.002, mode
        assert np.abs(got[mode].ao - want[mode].ao).mean() < 0.002, mode


# -- 1. a 2 m box 5 m in front of the camera, and the same mesh 3e7 m further -------------------
CUBE = trimesh.creation.box((2.0, 2.0, 2.0))
LOOK = Camera.from_look_at((0.3, -5.0, 0.4), (0.0, 0.0, 0.0), (0, 0, 1), 60, W, H)
VIEW_DIR = LOOK.R[2]


def test_a_copy_far_along_the_view_direction_changes_nothing(ctx):
    far = _part("far", CUBE, FAR * VIEW_DIR)
    _assert_same_render(ctx, [_part("box", CUBE), far], [_part("box", CUBE)], LOOK)


def test_a_copy_far_along_the_view_direction_through_the_cli(tmp_path, capsys):
    """The issue's reproduction, end to end: the near box is drawn and no warning is printed."""
    CUBE.export(tmp_path / "box.obj")
    parts = ['[[parts]]\nname = "box"\nmesh = "box.obj"\nunits = "m"\n']
    (tmp_path / "alone.toml").write_text("format = 1\n" + parts[0])
    translate = ", ".join(repr(float(v)) for v in FAR * VIEW_DIR)
    parts.append(f'[[parts]]\nname = "far"\nmesh = "box.obj"\nunits = "m"\ntranslate = [{translate}]\n')
    (tmp_path / "both.toml").write_text("format = 1\n" + "".join(parts))
    (tmp_path / "cam.json").write_text(json.dumps(LOOK.to_dict()))
    images = {}
    for name in ("alone", "both"):
        out = tmp_path / f"{name}.png"
        assert (
            main(
                [
                    "render",
                    str(tmp_path / f"{name}.toml"),
                    "--camera",
                    str(tmp_path / "cam.json"),
                    "--mode",
                    "phong",
                    "-o",
                    str(out),
                ]
            )
            == 0
        )
        assert "no CAD part is in view" not in capsys.readouterr().err
        images[name] = cv2.imread(str(out)).astype(float)
    assert np.abs(images["both"] - images["alone"]).mean() < 0.5


# -- 2. a hall at 5e6 m, the camera 0.3 m from a column ----------------------------------------
HALL_AT = np.array([5e6, 0.0, 0.0])


def _hall(offset):
    """A small hall of boxes: floor, walls and roof as one part (the camera stands inside its
    bounds), 3 x 4 columns, two rows of racks; everything moved by ``offset``."""
    shell = trimesh.util.concatenate(
        [
            box((40, 60, 0.3), (0, 0, -0.15)),
            box((40, 60, 0.3), (0, 0, 8.15)),
            box((0.3, 60, 8), (-20.15, 0, 4)),
            box((0.3, 60, 8), (20.15, 0, 4)),
            box((40, 0.3, 8), (0, -30.15, 4)),
            box((40, 0.3, 8), (0, 30.15, 4)),
        ]
    )
    columns = trimesh.util.concatenate([box((0.4, 0.4, 8), (x, y, 4)) for x in (-10, 0, 10) for y in (-20, -5, 10, 25)])
    racks = trimesh.util.concatenate(
        [
            box((12, 1.2, 3 + 0.5 * i), (x, y, 1.5 + 0.25 * i))
            for i, (x, y) in enumerate([(-8, -12), (8, -12), (-8, 3), (8, 3), (-8, 18)])
        ]
    )
    return [_part("shell", shell, offset), _part("columns", columns, offset), _part("racks", racks, offset)]


def _column_camera(offset) -> Camera:
    """0.3 m in front of the +x face of the column at (0, -5), looking along -x past it."""
    eye = np.array([0.2 + 0.3, -5.0 + 0.15, 1.6]) + offset
    return Camera.from_look_at(eye, eye + (-10.0, -1.5, -0.4), (0, 0, 1), 70, W, H)


def test_a_hall_at_5e6_m_renders_as_at_the_origin(ctx):
    _assert_same_render(
        ctx, _hall(HALL_AT), _hall(np.zeros(3)), _column_camera(HALL_AT), _column_camera(np.zeros(3)), covered=0.99
    )


def _merged(name, parts):
    """One part of the world-space geometry of ``parts`` (one mesh file of a whole model)."""
    meshes = [
        trimesh.Trimesh(p.vertices.astype(np.float64) + p.transforms[0, :3, 3], p.faces, process=False) for p in parts
    ]
    whole = trimesh.util.concatenate(meshes)
    return make_part(name, name, np.asarray(whole.vertices, np.float64), np.asarray(whole.faces), np.eye(4))


def _in_view(camera, point) -> bool:
    z = (camera.R @ point + camera.t)[2]
    ((u, v),) = camera.project([point])
    return z > 0 and 0 <= u < camera.width and 0 <= v < camera.height


@pytest.mark.parametrize("how", ["a part of its own", "in the same mesh"])
def test_a_hall_at_5e6_m_with_a_stray_element_at_the_origin(ctx, how):
    """IFC exports at map coordinates often carry one element at the world origin: here straight
    ahead of the camera, 5e6 m behind the hall's end wall; as a part of its own, or in the one
    mesh file of the whole model (whose centre is then halfway, where float32 steps 0.25 m)."""
    parts = _hall(HALL_AT) + [_part("stray", box((1, 1, 1), (0, 0, 0)))]
    if how == "in the same mesh":
        parts = [_merged("model", parts)]
    camera = _column_camera(HALL_AT)
    assert _in_view(camera, np.zeros(3))
    _assert_same_render(ctx, parts, _hall(np.zeros(3)), camera, _column_camera(np.zeros(3)), covered=0.99)


# -- 3. one mesh spanning +-1e12 m with a small box in it ----------------------------------------
def _write_obj(path, vertices, faces):
    # text with every float64 digit: 1e12 m and millimetres in one file
    with open(path, "w") as f:
        f.writelines(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in vertices)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)


@pytest.mark.parametrize("far_part", ["stray triangles", "one stray triangle", "ground"])
def test_a_mesh_spanning_1e12_m_keeps_and_renders_its_small_box(ctx, tmp_path, capsys, far_part):
    """One mesh file: the 2 m box and small triangles 1e12 m off on both sides or on one (stray
    vertices of a broken export; the mesh's centre is then 5e11 m from the box), or a ground quad
    +-1e12 m wide under the camera."""
    span = 1e12
    if far_part == "ground":
        far = np.array([[-span, -span, -3.0], [span, -span, -3.0], [span, span, -3.0], [-span, span, -3.0]])
        far_faces = [[0, 1, 2], [0, 2, 3]]
    elif far_part == "stray triangles":
        far = np.array([[-span, 0, 0], [-span, 1, 0], [-span, 0, 1], [span, 0, 0], [span, 1, 0], [span, 0, 1]])
        far_faces = [[0, 1, 2], [3, 4, 5]]
    else:
        far = np.array([[span, 0, 0], [span, 1, 0], [span, 0, 1]])
        far_faces = [[0, 1, 2]]
    vertices = np.concatenate([far, CUBE.vertices])
    faces = np.concatenate([far_faces, CUBE.faces + len(far)])
    _write_obj(tmp_path / "huge.obj", vertices, faces)
    scene = load_scene(tmp_path / "huge.obj", units="m")
    assert "degenerate" not in capsys.readouterr().err
    assert scene.parts[0].triangle_count == len(faces)
    renderer = Renderer(scene, ctx=ctx)
    depth = renderer.render(LOOK, ["phong"]).depth
    renderer.release()
    _, alone = _render(ctx, [_part("box", CUBE)], LOOK, ["phong"])
    on_box = alone > 0
    assert on_box.mean() > 0.05
    np.testing.assert_allclose(depth[on_box], alone[on_box], rtol=1e-5)  # the box, where it is alone
    if far_part != "ground":
        assert np.array_equal(depth, alone)


# -- consumers of the far scene: ray-traced reference, review pick, deviation --------------------
def _cell(offset=(0.0, 0.0, 0.0)):
    """The box standing on a floor (AO in the crease), off the integer grid."""
    o = np.asarray(offset) + (0.137, 0.41, 0.05)
    return [_part("floor", box((8, 8, 0.2), (0, 0, -1.1)), o), _part("box", CUBE, o)]


def _with_far(how, offset):
    """The cell and a copy at ``offset``, and the cell alone: as parts, or each as one mesh."""
    both, alone = _cell() + _cell(offset), _cell()
    if how == "one mesh":
        return [_merged("cell", both)], [_merged("cell", alone)]
    return both, alone


HOWS = ["parts", "one mesh"]
OFF_GRID = 3.3e7 + 0.73  # float32 rounds the cell's coordinates around a centre halfway there


@pytest.mark.parametrize("how", HOWS)
def test_reference_ao_of_the_far_scene(ctx, how):
    results = []
    for parts in _with_far(how, FAR * VIEW_DIR):
        scene = Scene("t", "t", parts)
        renderer = Renderer(scene, ctx=ctx)
        frame = renderer.render(LOOK, ["phong"], RenderSettings(lod_px=REFERENCE_LOD_PX), want_normals=True)
        depth, normals = frame.depth, frame.normals
        renderer.release()
        results.append(reference_ao(scene, LOOK, depth, normals, 16, "world", 0.5))
    assert (results[1] < 0.9).mean() > 0.01
    assert np.abs(results[0] - results[1]).max() < 1e-6


@pytest.mark.parametrize("how", HOWS)
def test_discrepancies_ids_and_overlay_edges_of_the_far_scene(ctx, how):
    """The discrepancy check's per-pixel instances (a ray cast) and the overlay's CAD edges
    (from the render's depth) see the near cell as if it were alone."""
    from mrcheck.apps.discrepancies import object_ids
    from mrcheck.mr.shot import cad_edges

    (ids, depth, _), (ids_alone, depth_alone, _) = (
        object_ids(Scene("t", "t", p), LOOK) for p in _with_far(how, FAR * VIEW_DIR)
    )
    assert (ids_alone >= 0).mean() > 0.05
    assert np.array_equal(ids, ids_alone)
    np.testing.assert_allclose(depth, depth_alone, rtol=1e-5)
    edges, edges_alone = (
        cad_edges(_render(ctx, p, LOOK, ["phong"])[1], LOOK.fx) for p in _with_far(how, FAR * VIEW_DIR)
    )
    assert edges_alone.sum() > 100 and np.array_equal(edges, edges_alone)


@pytest.mark.parametrize("how", HOWS)
@pytest.mark.parametrize("far", [FAR, OFF_GRID])
def test_review_pick_of_the_far_scene(far, how):
    from mrcheck.apps.review.pick import Picker

    camera = Camera.from_look_at((0.3, -5.37, 0.2), (0.3, 0.0, 0.2), (0, 0, 1), 60, W, H)
    with_far, near_only = (Picker(Scene("t", "t", parts)) for parts in _with_far(how, (0, far, 0)))
    hits = 0
    for u, v in ((79.5, 59.5), (60.0, 40.0), (100.0, 80.0), (30.0, 100.0), (5.0, 5.0)):
        want, got = near_only.pick(camera, u, v), with_far.pick(camera, u, v)
        assert (got["part"], got["instance"]) == (want["part"], want["instance"]), (u, v)
        if want["distance"] is not None:
            hits += 1
            assert got["distance"] == pytest.approx(want["distance"], abs=2e-3), (u, v)
    assert hits >= 3


@pytest.mark.parametrize("how", HOWS)
def test_deviation_of_a_scan_near_the_origin_with_a_part_far_away(how):
    from mrcheck.apps.deviation import signed_distances

    # scan points on the box's faces and 5 cm above its top face
    rng = np.random.default_rng(0)
    points = rng.uniform(-1.0, 1.0, (500, 3))
    points[np.arange(500), rng.integers(0, 3, 500)] = rng.choice([-1.0, 1.0], 500)
    lifted = rng.uniform(-0.9, 0.9, (100, 3)) * (1, 1, 0) + (0, 0, 1.05)
    scan = np.concatenate([points, lifted]) + (0.137, 0.41, 0.05)
    for parts in _with_far(how, (0, OFF_GRID, 0)):
        d, _ = signed_distances(Scene("t", "t", parts), scan)
        assert np.abs(d[:500]).max() < 1e-4
        np.testing.assert_allclose(d[500:], 0.05, atol=1e-4)


# -- which meshes float32 holds -----------------------------------------------------------------
def test_ordinary_meshes_stay_float32_in_one_piece(ctx):
    from mrcheck.core.resources import sample_scene_path
    from mrcheck.render.gbuffer import GeometryPass

    scene = load_scene(sample_scene_path())
    assert all(p.vertices.dtype == np.float32 for p in scene.parts)
    with made_current(ctx):
        geometry = GeometryPass(ctx, scene)
        assert len(geometry.parts) == len(scene.parts)
        geometry.release()
    # a hall 5e6 m from the origin is re-centred: float32 holds it
    assert all(p.vertices.dtype == np.float32 for p in _hall(HALL_AT))


def test_a_model_with_a_stray_element_is_drawn_in_few_pieces_that_float32_holds(ctx):
    from mrcheck.render.gbuffer import GeometryPass
    from mrcheck.scene.precision import float32_holds, float32_tiles, longest_edges

    [part] = [_merged("model", _hall(HALL_AT) + [_part("stray", box((1, 1, 1), (0, 0, 0)))])]
    assert part.vertices.dtype == np.float64
    tiles = float32_tiles(part.vertices, part.faces)
    assert 2 <= len(tiles) <= 4
    assert np.array_equal(np.sort(np.concatenate(tiles)), np.arange(part.triangle_count))
    for group in tiles:
        used = part.vertices[part.faces[group]].reshape(-1, 3)
        radius = float(np.abs(used - (used.min(axis=0) + used.max(axis=0)) / 2).max())
        assert float32_holds(radius, longest_edges(part.vertices, part.faces[group]))
    with made_current(ctx):
        geometry = GeometryPass(ctx, Scene("t", "t", [part]))
        assert len(geometry.parts) == len(tiles)
        assert sum(gpu.triangles for gpu in geometry.parts) == part.triangle_count
        geometry.release()
