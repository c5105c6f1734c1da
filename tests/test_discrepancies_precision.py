"""Issue 22a: the photo detector's precision -- texture inside a CAD face is no "extra" region,
the floor is told from other faces, a suggested marker lies on (and names) its own part, the
photo's light is fitted and an unchanged sun-lit view gives at most one suspect."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mrcheck.apps.discrepancies import detect, planned_view
from mrcheck.apps.discrepancies.light import estimate_light
from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_shot, read_photo
from mrcheck.core.resources import sample_scene_path, shipped_scene
from mrcheck.eval.discrepancy_eval import synthetic_photo
from mrcheck.render.composite import light_direction
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import load_scene

BOX = Path(__file__).resolve().parent / "data" / "pose" / "box"
CELL = shipped_scene("cell")


def _view_camera(scene, view, w, h, k1):
    cam = scene.camera(view, w, h)
    return view, Camera(w, h, cam.K, cam.R, cam.t, np.array([k1, 0.0, 0.0, 0.0]))


@pytest.fixture(scope="module")
def box_detection(tmp_path_factory):
    shot = tmp_path_factory.mktemp("box") / "SHOT.json"
    assert (
        main(
            [
                "register",
                str(BOX / "scene.toml"),
                "--photo",
                str(BOX / "resized_IMG_3875.JPG"),
                "--intrinsics",
                str(BOX / "canon.json"),
                "--points",
                str(BOX / "corners.json"),
                "-o",
                str(shot),
            ]
        )
        == 0
    )
    camera, photo_path = load_shot(shot)
    photo = read_photo(photo_path, camera)
    return detect(load_scene(BOX / "scene.toml"), camera, photo)


@pytest.mark.slow
def test_the_box_artwork_is_texture_not_structure(box_detection):
    """The real box photo's printed artwork lies inside the CAD box's faces: before, it made 3
    regions there (14053, 3810 and 2566 edge px; 16 in all, the rest on the table and the
    clutter around the box, which no CAD explains). Now no unexplained edge pixel lies on the
    box's faces away from its outline, and no region is wholly inside the box's image."""
    d = box_detection
    on_box = d.planned.ids >= 0
    assert not np.any(d.unexplained & on_box)
    ys, xs = np.nonzero(on_box)
    inside = [
        r
        for r in d.regions
        if r.bbox[0] > xs.min() and r.bbox[2] < xs.max() and r.bbox[1] > ys.min() and r.bbox[3] < ys.max()
    ]
    assert len(inside) <= 1  # measured: 0 (1, the box's shadow below its left side, before contact lines)
    assert not d.planned.ground.any()  # the box scene has no floor
    # the box is still as planned (texture did not disturb the outline score)
    (box,) = d.suspects
    assert not box.suspect and box.support > 0.85


@pytest.mark.slow
def test_the_floor_is_ground_and_walls_and_machines_are_not(ctx):
    """ground_pixels: upward faces at the lowest seen level -- the floor, not a wall, a machine's
    top or a conveyor (objects are added on the floor; structure elsewhere on a face is texture)."""
    scene = load_scene(sample_scene_path())
    name, camera = _view_camera(scene, "overview", 320, 240, -0.12)
    pv = planned_view(scene, camera, Renderer(scene, ctx=ctx))
    names = np.array([lab[1] for lab in pv.labels] + [""])
    seen = names[pv.ids]
    floor = seen == "floor"
    assert pv.ground[floor].mean() > 0.9
    assert pv.ground[(seen != "floor") & (pv.ids >= 0)].mean() < 0.05


@pytest.mark.slow
def test_suggested_markers_lie_on_their_own_part(ctx, tmp_path):
    """A suspect's marker is put on a pixel of its own planned image (the centre of its
    unsupported outline may lie on the floor next to it: the review then named the floor)."""
    from mrcheck.scene.asbuilt import make_asbuilt

    planned = load_scene(sample_scene_path())
    make_asbuilt(sample_scene_path(), tmp_path / "b", seed=3)
    built = load_scene(tmp_path / "b" / "scene.toml")
    checked = 0
    for view in ("overview", "conveyor"):
        name, camera = _view_camera(planned, view, 640, 480, -0.12)
        photo = synthetic_photo(built, camera, Renderer(built, ctx=ctx), seed=3)
        d = detect(planned, camera, photo, renderer=Renderer(planned, ctx=ctx))
        index = {lab[1]: i for i, lab in enumerate(d.planned.labels)}
        for m in d.suggested_markers:
            if m.part is not None:
                assert d.planned.ids[int(m.y), int(m.x)] == index[m.part], (view, m)
                checked += 1
    assert checked >= 2
    json.dumps([m.__dict__ for m in d.suggested_markers])  # still a plain JSON record


@pytest.mark.slow
def test_the_light_fitted_to_a_sun_lit_photo_is_the_sun(ctx):
    """estimate_light on the evaluation's sun-lit photo of the planned sample cell (conveyor,
    320x240) finds the sun's direction (measured 5.8 degrees off), and on the headlight render
    the headlight's (3.6 degrees off); the two lights are 89 degrees apart. A view of mostly one
    orientation cannot tell: the overview at 320x240, mostly floor, is fitted 49 degrees off the
    sun (its floor shaded right, its few walls not)."""
    scene = load_scene(sample_scene_path())
    name, camera = _view_camera(scene, "conveyor", 320, 240, -0.12)
    renderer = Renderer(scene, ctx=ctx)
    pv = planned_view(scene, camera, renderer)
    sun, head = (light_direction(camera, light) for light in ("sun", "headlight"))
    assert np.degrees(np.arccos(sun @ head)) > 60
    for image, light in ((synthetic_photo(scene, camera, renderer), "sun"), (pv.render, "headlight")):
        fitted = estimate_light(image, pv.albedo, pv.normals, pv.ids, pv.cad)
        off = np.degrees(np.arccos(np.clip(fitted.direction @ light_direction(camera, light), -1, 1)))
        print(light, round(float(off), 1), fitted)
        assert off < 15, (light, off)


@pytest.mark.slow
@pytest.mark.parametrize("path, view, most", [(sample_scene_path(), "robot", 1), (CELL, "overview", 1)])
def test_an_unchanged_sun_lit_view_gives_at_most_one_suspect(ctx, path, view, most):
    """The planned scene as its own sun-lit photo (blur, noise), 320x240: judged on the outline
    the headlight render shows, the sample cell's robot view (fence posts and panels, the mesh
    fence in front) gave 5 false suspects and the generated cell's overview (lights, roof decks,
    purlins) 14; on the outline relit by the photo's fitted light, 0 and 0."""
    scene = load_scene(path)
    name, camera = _view_camera(scene, view, 320, 240, -0.12)
    renderer = Renderer(scene, ctx=ctx)
    d = detect(scene, camera, synthetic_photo(scene, camera, renderer), planned=planned_view(scene, camera, renderer))
    assert len(d.flagged) + len(d.regions) <= most, [s.id for s in d.flagged]


@pytest.mark.slow
@pytest.mark.parametrize("view, before", [("conveyor", 3), ("overview", 5)])
def test_a_pose_two_pixels_off_moves_no_part(view, before):
    """The sample cell photographed 2 px off (the camera turned about its centre: what a
    registration's error does): every outline shifts alike, and judged against the shift the
    parts around each one show (``consensus.expected_shifts``) at most one part is flagged (measured: 0 on
    the conveyor view, 1 on the overview, a fence panel; ``before`` were flagged when judged
    unshifted; at 4 px 2 and 2 against about 20)."""
    import cv2

    scene = load_scene(sample_scene_path())
    cam = scene.camera(view, 640, 480)
    cam = Camera(640, 480, cam.K, cam.R, cam.t, np.zeros(5))
    angle = 2.0 / cam.fx
    R = cv2.Rodrigues(np.array([0.6 * angle, 0.8 * angle, 0.0]))[0] @ cam.R
    photo = synthetic_photo(scene, cam.with_pose(R, -R @ cam.center), seed=0)
    flagged = detect(scene, cam, photo).flagged
    assert len(flagged) <= 1 < before, [(s.id, s.score, s.best_shift) for s in flagged]


def test_the_expected_shift_is_the_median_of_the_nearest_parts():
    """Four parts shifted (3, -2) px and one far away shifted (-6, 0): each of the four expects
    (3, -2); with fewer than four parts nothing is expected."""
    from mrcheck.apps.discrepancies.consensus import expected_shifts

    boxes = [[x, 0, x + 10, 10] for x in (0, 20, 40, 60, 900)]
    shifts = [(3, -2), (3, -2), (3, -1), (3, -2), (-6, 0)]
    assert expected_shifts(boxes, shifts)[:4] == [(3, -2)] * 4
    assert expected_shifts(boxes[:3], shifts[:3]) == [(0, 0)] * 3
