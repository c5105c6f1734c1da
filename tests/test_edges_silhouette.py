"""The silhouette and region term of the edge registration (issue 40): outline samples from the
rendered depth (:mod:`mrcheck.mr.edges.silhouette`), the colour split along their normals
(:mod:`mrcheck.mr.edges.region`), and ``EdgeOptions.silhouette`` that turns them on."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import EdgeFitError, EdgeOptions, model, refine_pose, region, silhouette
from mrcheck.mr.edges.fitter import render_depth
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import Scene, make_part

# smooth balls (no crease; their facet edges are about a pixel on screen): as LM-O's scanned objects
_BALLS = (((0.0, 0.0, 0.0), 0.15), ((0.35, 0.1, 0.05), 0.1), ((-0.2, 0.3, -0.05), 0.08))
_COLOURS = ((200, 60, 50), (230, 210, 40), (240, 240, 230))


def _scene() -> Scene:
    parts = []
    for k, (centre, radius) in enumerate(_BALLS):
        mesh = trimesh.creation.icosphere(subdivisions=4, radius=radius)
        T = np.eye(4)
        T[:3, 3] = centre
        vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
        parts.append(make_part(f"ball{k}", Path(f"ball{k}"), vertices, faces, T[None], units="m"))
    return Scene("balls", Path("balls"), parts)


def _truth() -> Camera:
    return Camera.from_look_at([0.3, -1.6, 0.9], [0.05, 0.1, 0.0], [0, 0, 1], 40.0, 320, 240)


def _photo(scene: Scene, camera: Camera) -> np.ndarray:
    """A colour photo of the balls at ``camera``: each ball its colour (by its depth order is not
    needed: they do not overlap in this view), a grey-blue desk, a slight blur."""
    renderer = Renderer(scene)
    try:
        depth = render_depth(renderer, camera)
    finally:
        renderer.release()
    photo = np.empty((*depth.shape, 3), np.uint8)
    photo[:] = (70, 80, 110)
    rows, cols = np.nonzero(depth > 0)
    rays = np.column_stack([cols, rows, np.ones(len(rows))]) @ np.linalg.inv(camera.K).T
    world = (rays * depth[rows, cols, None] - camera.t) @ camera.R
    centres = np.array([c for c, _ in _BALLS])
    nearest = np.argmin(np.linalg.norm(world[:, None, :] - centres[None], axis=2), axis=1)
    photo[rows, cols] = np.array(_COLOURS, np.uint8)[nearest]
    return cv2.GaussianBlur(photo, (0, 0), 0.8)


def _off(camera: Camera, degrees: float, metres: float) -> Camera:
    R = cv2.Rodrigues(np.radians(degrees) * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]))[0]
    return camera.with_pose(R @ camera.R, camera.t + metres * np.array([0.6, -0.3, 0.2]))


def _median_px(a: Camera, b: Camera) -> float:
    points = np.array([c for c, _ in _BALLS])
    return float(np.median(np.linalg.norm(a.project(points) - b.project(points), axis=1)))


@pytest.fixture(scope="module")
def balls():
    scene = _scene()
    truth = _truth()
    return scene, truth, _photo(scene, truth)


def test_smooth_balls_register_by_their_outline_by_default(balls):
    """Started a few px off, the fit with the outline term (the default for curved parts, and
    ``silhouette=True``) ends within half a pixel of the truth; without it
    (``silhouette=False``) the balls give too few mesh-edge samples and the fit refuses (as on
    LM-O)."""
    scene, truth, photo = balls
    start = _off(truth, 1.5, 0.03)
    assert 3.0 < _median_px(start, truth) < 12.0
    for options in (EdgeOptions(), EdgeOptions(silhouette=True)):
        fit = refine_pose(scene, truth, photo, initial=start, options=options)
        assert _median_px(fit.camera, truth) < 0.5, _median_px(fit.camera, truth)
    with pytest.raises(EdgeFitError, match="visible CAD edge samples"):
        refine_pose(scene, truth, photo, initial=start, options=EdgeOptions(silhouette=False))


def test_curved_parts_are_the_balls_and_cylinders_not_the_boxes():
    """:func:`silhouette.curved_parts`: a ball and a cylinder (faces meeting at under 30 deg) are
    curved, a box (creases, and flat diagonals) and a coarse prism (8 sides, 45 deg) are not."""
    meshes = {
        "ball": trimesh.creation.icosphere(subdivisions=3, radius=0.1),
        "pipe": trimesh.creation.cylinder(radius=0.05, height=1.0, sections=32),
        "box": trimesh.creation.box((0.3, 0.2, 0.1)),
        "prism": trimesh.creation.cylinder(radius=0.2, height=0.1, sections=8),
    }
    parts = [
        make_part(name, Path(name), np.asarray(m.vertices, np.float64), np.asarray(m.faces), np.eye(4)[None], units="m")
        for name, m in meshes.items()
    ]
    scene = Scene("shapes", Path("shapes"), parts)
    edges = model.scene_edges(scene)
    curved = dict(zip(edges.group_names, silhouette.curved_parts(edges)))
    assert curved == {"ball": True, "pipe": True, "box": False, "prism": False}, curved


def test_a_failed_chamfer_schedule_is_retried_along_the_normal_only_with_outlines(balls, monkeypatch):
    """When the chamfer schedule fails, a fit sampling outlines is made again with the search
    along the normal on every level (and succeeds on the balls); without outlines the failure
    is the chamfer schedule's own."""
    from mrcheck.mr.edges import refine as refine_module

    def failing(*args):
        raise EdgeFitError("chamfer schedule failed")

    calls = []
    normal = refine_module.normal_schedule

    def spy(*args):
        calls.append(1)
        return normal(*args)

    monkeypatch.setattr(refine_module, "chamfer_schedule", failing)
    monkeypatch.setattr(refine_module, "normal_schedule", spy)
    scene, truth, photo = balls
    start = _off(truth, 1.5, 0.03)
    fit = refine_pose(scene, truth, photo, initial=start)
    assert _median_px(fit.camera, truth) < 0.5 and calls == [1]
    with pytest.raises(EdgeFitError):
        refine_pose(scene, truth, photo, initial=start, options=EdgeOptions(silhouette=False))
    assert calls == [1]


def test_the_outline_samples_lie_on_the_rendered_outline(balls):
    """Each contour sample projects onto the balls' true outline (its distance to the nearest
    ball's centre in the image is that ball's projected radius, within half a pixel), its
    tangent's normal points away from the ball, and it belongs to its ball's instance."""
    scene, truth, _ = balls
    renderer = Renderer(scene)
    try:
        depth = render_depth(renderer, truth)
    finally:
        renderer.release()
    edges = model.scene_edges(scene)
    samples = silhouette.contour_samples(silhouette.ContourModel(edges), truth, depth, 3.0, 3000)
    assert len(samples) > 60 and samples.contour.all()
    uv, normal, local = model.pinhole_samples(truth, samples, depth.shape)
    for k, (centre, radius) in enumerate(_BALLS):
        mine = samples.group == edges.group_names.index(f"ball{k}")
        assert np.count_nonzero(mine) > 10
        c = truth.project(np.array([centre]))[0]
        z = float(np.asarray(centre) @ truth.R[2] + truth.t[2])
        r_px = truth.K[0, 0] * radius / np.sqrt(z * z - radius * radius)  # a sphere's outline, near the axis
        d = np.linalg.norm(uv[mine] - c, axis=1)
        assert np.median(np.abs(d - r_px)) < 0.5, (k, np.median(d), r_px)
        outward = np.einsum("ij,ij->i", normal[mine], uv[mine] - c)
        assert np.all(outward > 0)


def test_the_region_split_finds_the_colour_step_and_nothing_on_one_colour():
    """Along lines crossing from a red disc (inside) to the desk (outside), the split lies on the
    disc's border within a quarter pixel; on lines wholly on the desk there is no split (nan)."""
    photo = np.full((80, 80, 3), (70, 80, 110), np.uint8)
    cv2.circle(photo, (40, 40), 20, (200, 60, 50), -1)
    bins = region.colour_levels(photo, 1)[0]
    mask = np.zeros((80, 80), bool)
    cv2.circle(mask.view(np.uint8), (40, 40), 20, 1, -1)
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    normals = np.column_stack([np.cos(angles), np.sin(angles)])
    on = 40 + 20 * normals
    tables = region.posteriors(bins, mask, on, np.zeros(len(on), np.int64), 1)
    offset = region.step_search(bins, tables, on - 3 * normals, normals, np.zeros(len(on), np.int64), 8)
    assert np.all(np.abs(offset - 3.0) < 0.75), offset
    far = region.step_search(bins, tables, np.full((4, 2), 8.0), normals[:4], np.zeros(4, np.int64), 4)
    assert np.all(np.isnan(far))


def test_the_silhouette_is_automatic_by_default_and_validated_options_keep_it():
    options = EdgeOptions()
    assert options.silhouette is None and options.region is True
    assert EdgeOptions(silhouette=True).validated().silhouette is True
    assert EdgeOptions(silhouette=False).validated().silhouette is False


@pytest.mark.slow
def test_register_silhouette_flag_snaps_the_balls_from_the_command_line(balls, tmp_path, capsys):
    """``mrcheck register --initial``: the outline term of curved parts is on by default and
    ``--silhouette on`` keeps it, with the photo in colour; ``--silhouette off`` refuses the
    same balls for too few samples."""
    from mrcheck.cli import main
    from mrcheck.core.camerafiles import write_camera
    from mrcheck.core.output import write_image
    from mrcheck.core.shot import read_shot

    _, truth, photo = balls
    mesh = trimesh.util.concatenate(
        [trimesh.creation.icosphere(subdivisions=4, radius=r).apply_translation(c) for c, r in _BALLS]
    )
    mesh.export(tmp_path / "balls.ply")
    write_image(tmp_path / "photo.png", photo)
    write_camera(tmp_path / "cam.json", truth)
    write_camera(tmp_path / "rough.json", _off(truth, 1.5, 0.03))
    args = ["register", tmp_path / "balls.ply", "--photo", tmp_path / "photo.png", "--intrinsics"]
    args += [tmp_path / "cam.json", "--initial", tmp_path / "rough.json", "-o"]
    assert main([str(a) for a in [*args, tmp_path / "plain.json", "--silhouette", "off"]]) == 1
    assert "visible CAD edge samples" in capsys.readouterr().err
    for name, extra in (("auto.json", []), ("on.json", ["--silhouette", "on"])):
        assert main([str(a) for a in [*args, tmp_path / name, *extra]]) == 0
        assert _median_px(read_shot(tmp_path / name).camera, truth) < 0.5


def test_automatic_outlines_follow_the_view_not_only_the_mesh():
    """``Fitter.judge_outlines``: when the curved parts' outline samples outnumber the samples on
    crease edges in the first view, every part's outline is used (the box's too), else none for
    the whole fit (contours off); a curved mesh's own facet contours do not count as creases."""
    from mrcheck.mr.edges.fitter import Fitter

    meshes = {
        "ball": trimesh.creation.icosphere(subdivisions=3, radius=0.1),
        "box": trimesh.creation.box((0.3, 0.2, 0.1)),
    }
    parts = [
        make_part(name, Path(name), np.asarray(m.vertices, np.float64), np.asarray(m.faces), np.eye(4)[None], units="m")
        for name, m in meshes.items()
    ]
    edges = model.scene_edges(Scene("shapes", Path("shapes"), parts))
    ball, box = edges.group_names.index("ball"), edges.group_names.index("box")
    crease_edge = int(np.flatnonzero(edges.crease & (edges.group == box))[0])
    facet_edge = int(np.flatnonzero(~edges.crease & (edges.group == ball))[0])

    def samples(edge: int, group: int, count: int) -> model.Samples:
        z = np.zeros((count, 3))
        return model.Samples(z, z, np.full(count, group), np.full(count, edge), np.zeros(count))

    def judged(creases: int, facets: int, outline: int) -> tuple[list, bool]:
        fitter = Fitter.__new__(Fitter)
        fitter.edges, fitter.judged = edges, False
        fitter.outlined = silhouette.curved_parts(edges)
        fitter.contours = silhouette.ContourModel(edges)
        mesh = silhouette.joined(samples(crease_edge, box, creases), samples(facet_edge, ball, facets))
        assert fitter.outlined.tolist() == [True, False]  # the ball is curved, the box is not
        fitter.judge_outlines(mesh, samples(facet_edge, ball, outline))
        return fitter.outlined.tolist(), fitter.contours is not None

    assert judged(creases=10, facets=50, outline=40) == ([True, True], True)  # facet contours do not count
    assert judged(creases=50, facets=0, outline=40) == ([False, False], False)
