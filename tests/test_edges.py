"""Edge registration (issue 20): the CAD's visible edges, the snap onto a photo's edges, its
accuracy on photos made by another renderer (Open3D ray casts with sun, sky, shadows, albedo
noise, lens distortion, blur and sensor noise, clutter the CAD lacks and a CAD part left out),
the reported uncertainty, the warnings and the failures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.eval.edgephotos import corner_errors, make_case, reprojection_error, synthetic_photo
from mrcheck.eval.edgescenes import crate_camera, crate_scene
from mrcheck.mr.edges import EdgeFitError, model, refine_pose, scene_edges
from mrcheck.mr.edges.fitter import render_depth
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import Scene, make_part

SEEDS = range(10)


def _box(extents=(1.0, 2.0, 0.5), flip_every_other=False):
    mesh = trimesh.creation.box(extents=extents)
    faces = np.asarray(mesh.faces).copy()
    if flip_every_other:  # a CAD export that winds half the triangles the other way
        faces[::2] = faces[::2, ::-1]
    return np.asarray(mesh.vertices, np.float64), faces


def test_a_box_has_twelve_creases_whatever_its_winding():
    """Each face of a box is two triangles; with mixed winding the face's diagonal looked like a
    180-degree fold (a crease along every diagonal) before the angle was taken between planes."""
    for flip in (False, True):
        a, b, na, nb, crease = model.mesh_edges(*_box(flip_every_other=flip))
        assert len(a) == 18 and crease.sum() == 12, (flip, crease.sum())
        diagonal = ~crease
        assert np.allclose(np.abs(np.einsum("ij,ij->i", na[diagonal], nb[diagonal])), 1.0)


def _one_box_scene():
    vertices, faces = _box()
    return Scene("box", Path("box"), [make_part("box", Path("box"), vertices, faces, np.eye(4)[None], units="m")])


def test_only_visible_edges_are_sampled():
    """From above a corner, three of a box's twelve edges are hidden behind it: no sample of
    them passes the depth test, every sample of the nine others does (but at their ends)."""
    scene = _one_box_scene()
    camera = Camera.from_look_at([2.0, -3.0, 2.5], [0, 0, 0], [0, 0, 1], 40.0, 320, 240)
    edges = scene_edges(scene)
    samples = model.sample_edges(edges, camera, 2.0)
    renderer = Renderer(scene)
    try:
        seen = model.visible(samples, camera, render_depth(renderer, camera))
    finally:
        renderer.release()
    hidden_corner = np.array([-0.5, 1.0, -0.25])  # the corner farthest from the camera
    touches = np.linalg.norm(edges.a - hidden_corner, axis=1) < 1e-6
    touches |= np.linalg.norm(edges.b - hidden_corner, axis=1) < 1e-6
    hidden = np.isin(samples.edge, np.flatnonzero(touches & edges.crease))
    assert hidden.sum() > 50 and seen[hidden].mean() < 0.1
    assert seen[~hidden].mean() > 0.9


@pytest.fixture(scope="module")
def crate_fits():
    """The protocol: the crate scene at 640x480 (lens distortion), ten seeded Open3D photos, each
    from a rough pose 15-40 px off (median over the CAD surface points in view)."""
    scene, camera = crate_scene(), crate_camera(640, 480)
    edges = scene_edges(scene)
    renderer = Renderer(scene)
    out = []
    try:
        for seed in SEEDS:
            case = make_case(scene, camera, seed)
            try:
                fit = refine_pose(scene, camera, case.photo, initial=case.rough, edges=edges, renderer=renderer)
            except EdgeFitError as exc:
                fit = exc
            out.append((case, fit))
    finally:
        renderer.release()
    return out


@pytest.mark.slow
def test_snap_is_within_a_pixel_in_nine_of_ten_cases(crate_fits):
    """Median reprojection error on the scene points <= 1 px in at least 9 of 10 seeds (the
    target), here in all 10 (measured: 0.02-0.12 px with the whole-pose search;
    0.03-0.28 px with the chamfer coarse stage alone; with neither,
    9 of 10 with seed 0, 28 px off, failing with "too little support"). A case that fails must
    say so, never return a wrong pose quietly."""
    assert all(15.0 <= case.offset_px <= 40.0 for case, _ in crate_fits)
    errors = []
    for case, fit in crate_fits:
        if isinstance(fit, EdgeFitError):
            assert "support" in str(fit) or "diverged" in str(fit)
            errors.append(np.inf)
            continue
        errors.append(float(np.median(reprojection_error(case.truth, fit.camera, case.points))))
        assert errors[-1] <= 1.0 or fit.warnings, (errors[-1], fit.warnings)
    assert sum(e <= 1.0 for e in errors) == 10, errors


@pytest.mark.slow
def test_the_reported_uncertainty_covers_the_true_error(crate_fits):
    """At every image corner the true error is within 3x the reported 1-sigma (measured over the
    ten seeds: 0.15-1.38x, the same with OpenCV 5.1.0.95 / numpy 2.4.6 and 5.0.0.93 / 2.2.6; an
    earlier fitter reached 2.8x), and the sigma is not a blanket (below 1 px at the corners on
    this easy scene)."""
    for case, fit in crate_fits:
        if isinstance(fit, EdgeFitError):
            continue
        true = corner_errors(case.truth, fit.camera, fit.uncertainty.depth_m)
        reported = np.array(fit.uncertainty.corner_px)
        assert np.all(true <= 3.0 * reported), (true, reported)
        assert reported.max() < 1.0
        assert all(0 < v < 50 for v in fit.uncertainty.position_mm)
        # not rounded to zero (cv2.Rodrigues returns 0 below 1e-5 rad; measured 0.002-0.02 deg)
        assert all(1e-4 < v < 1.0 for v in fit.uncertainty.angle_deg)


CELL_SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def cell_fits():
    """The generated cell's ``overview`` at 640x480 (the crates' lens distortion), Open3D photos
    with sun, shadows, clutter and a part left out, from 15-40 px off: the dense scene (fences,
    trusses, roof decks) on which the coarse stage's shift search failed in every case."""
    from mrcheck.core.resources import shipped_scene
    from mrcheck.scene.model import load_scene

    cell = load_scene(shipped_scene("cell"))
    view = cell.camera("overview", 640)
    camera = Camera(view.width, view.height, view.K, view.R, view.t, crate_camera(640, 480).dist)
    edges, renderer = scene_edges(cell), Renderer(cell)
    try:
        cases = [make_case(cell, camera, seed) for seed in CELL_SEEDS]
        return [
            (case, refine_pose(cell, camera, case.photo, initial=case.rough, edges=edges, renderer=renderer))
            for case in cases
        ]
    finally:
        renderer.release()


@pytest.mark.slow
def test_the_dense_cell_snaps_within_a_pixel_and_its_uncertainty_covers_the_error(cell_fits):
    """Measured (seeds 0-19): all within 1 px, 0.14-0.65 px, the true corner
    error at most 1.9x the reported 1-sigma (0.3-1.9 px); before the whole-pose
    search every seed failed (0 of 10), before the parts as clusters of the covariance the true
    error reached 6x the sigma."""
    for case, fit in cell_fits:
        assert 15.0 <= case.offset_px <= 40.0
        assert np.median(reprojection_error(case.truth, fit.camera, case.points)) <= 1.0
        true = corner_errors(case.truth, fit.camera, fit.uncertainty.depth_m)
        reported = np.array(fit.uncertainty.corner_px)
        assert np.all(true <= 3.0 * reported) and reported.max() < 2.0, (true, reported)


@pytest.mark.slow
def test_the_part_missing_in_the_hall_is_left_out(crate_fits):
    """The crate left out of the photo finds too little support and is dropped (measured: in 8 of
    the 9 fits; in the ninth it keeps enough support, cause not investigated). The column, which
    is in the photo, is dropped in 3 of them as well: dropping is a robustness aid, not a verdict."""
    fitted = [(case, fit) for case, fit in crate_fits if not isinstance(fit, EdgeFitError) and case.left_out]
    assert len(fitted) >= 8
    assert sum(case.left_out in fit.dropped for case, fit in fitted) >= len(fitted) - 1


@pytest.mark.slow
def test_stage_times_are_reported(crate_fits):
    fit = next(f for _, f in crate_fits if not isinstance(f, EdgeFitError))
    assert set(fit.times_s) >= {"render", "edges", "photo", "match", "solve", "uncertainty", "total"}
    assert sum(v for k, v in fit.times_s.items() if k != "total") <= fit.times_s["total"] * 1.01


@pytest.mark.slow
def test_a_pyramid_made_beforehand_gives_the_same_fit_and_a_wrong_one_is_refused():
    """``refine_pose(pyramid=...)`` (a video's next frame, made on a thread): the pose is bitwise
    the one fitted to the photo itself; the pyramid of a blank photo is really used (the fit
    fails), and one of another size or level count is refused."""
    from mrcheck.core.errors import MrcheckError
    from mrcheck.mr.edges import EdgeOptions, photo_pyramid

    scene, camera = crate_scene(), crate_camera(320, 240)
    case = make_case(scene, camera, 0)
    options = EdgeOptions()
    own = refine_pose(scene, camera, case.photo, initial=case.rough, options=options)
    given = refine_pose(
        scene, camera, case.photo, initial=case.rough, options=options, pyramid=photo_pyramid(case.photo, options)
    )
    assert np.array_equal(own.camera.R, given.camera.R) and np.array_equal(own.camera.t, given.camera.t)
    blank = np.full(case.photo.shape, 0.5, np.float32)
    with pytest.raises(EdgeFitError):
        refine_pose(
            scene, camera, case.photo, initial=case.rough, options=options, pyramid=photo_pyramid(blank, options)
        )
    for other in (photo_pyramid(case.photo[::2, ::2], options), photo_pyramid(case.photo, EdgeOptions(levels=1))):
        with pytest.raises(MrcheckError, match="pyramid"):
            refine_pose(scene, camera, case.photo, initial=case.rough, options=options, pyramid=other)


@pytest.mark.slow
def test_a_photo_of_something_else_fails_with_a_reason():
    scene, camera = crate_scene(), crate_camera(320, 240)
    blank = np.full((240, 320), 128, np.uint8) + np.random.default_rng(0).integers(0, 6, (240, 320)).astype(np.uint8)
    with pytest.raises(EdgeFitError, match="no photo edges|support"):
        refine_pose(scene, camera, blank)


@pytest.mark.slow
def test_parallel_edges_warn_and_name_the_weak_direction():
    """A long bar across the view: every edge is horizontal, nothing pins the pose sideways."""
    vertices, faces = _box(extents=(40.0, 0.2, 0.2))
    scene = Scene("bar", Path("bar"), [make_part("bar", Path("bar"), vertices, faces, np.eye(4)[None], units="m")])
    camera = Camera.from_look_at([0.0, -4.0, 0.3], [0.0, 0.0, 0.0], [0, 0, 1], 50.0, 320, 240)
    photo, _, _ = synthetic_photo(scene, camera, 0, clutter=0, leave_out=False)
    fit = refine_pose(scene, camera, photo)
    assert any("parallel" in w for w in fit.warnings), fit.warnings
    assert any("poorly constrained" in w and "sideways" in w for w in fit.warnings), fit.warnings


def test_a_rough_pose_looking_away_fails_with_a_reason():
    """No CAD edge in view at all (the camera turned to the sky): a one-line failure, not a crash
    (cv2.projectPoints returns None for no points)."""
    scene, camera = crate_scene(), crate_camera(320, 240)
    away = Camera.from_look_at([0.0, 0.0, 50.0], [0.0, 0.0, 100.0], [0, 1, 0], 50.0, 320, 240)
    with pytest.raises(EdgeFitError, match="visible CAD edge samples"):
        refine_pose(scene, camera, np.zeros((240, 320), np.uint8), initial=away)
