"""The edge registration's failure detection (issue 20: "a failure (exit 1, no SHOT written) when
it diverges or ends with too little support"): a wrong pose that fits only a few of the CAD's
parts -- the others left out as "missing in the hall" -- is a failure, not a result."""

from __future__ import annotations


import cv2
import pytest

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import write_camera
from mrcheck.core.resources import factory_scenes_dir
from mrcheck.eval.edgephotos import make_case, synthetic_photo
from mrcheck.eval.edgescenes import crate_camera, crate_scene
from mrcheck.mr.edges import EdgeFitError, EdgeOptions, refine_pose
from mrcheck.scene.model import Scene, load_scene

CELL = factory_scenes_dir() / "cell" / "scene.toml"


def _photo_of(parts: set | None, seed: int = 0):
    full, camera = crate_scene(), crate_camera(320, 240)
    shown = Scene("shown", full.source, [p for p in full.parts if parts is None or p.name in parts])
    photo, _, _ = synthetic_photo(shown, camera, seed, clutter=0, leave_out=False)
    return full, camera, photo


def test_a_fit_to_a_few_parts_of_the_cad_fails():
    """The photo shows one crate of six (and the floor, the wall): from the true pose the snap
    fits that crate and leaves out the others, which hold 45 % of the visible edge samples
    (measured); the parts kept find 94 % support, which alone passed before."""
    scene, camera, photo = _photo_of({"crate-a", "floor", "wall"})
    with pytest.raises(EdgeFitError, match=r"too little support across the CAD: the \d+ parts that found no photo"):
        refine_pose(scene, camera, photo)
    # the same fit with the test switched off returns a pose: it is the test that fails it
    fit = refine_pose(scene, camera, photo, options=EdgeOptions(max_left_out=1.0))
    assert len(fit.dropped) >= 4


def test_parts_missing_in_the_hall_within_the_limit_still_fit():
    """All parts shown: none left out but the column (measured); three of six crates missing: they
    are left out (about a quarter of the samples) and the fit is kept."""
    scene, camera, photo = _photo_of(None)
    assert refine_pose(scene, camera, photo).support > 0.6
    scene, camera, photo = _photo_of({"crate-a", "crate-b", "crate-c", "floor", "wall"})
    fit = refine_pose(scene, camera, photo)
    assert {"crate-d", "crate-e"} <= set(fit.dropped)


def test_options_check_the_left_out_share():
    with pytest.raises(Exception, match="max left-out share"):
        EdgeOptions(max_left_out=1.5).validated()


def _cell_case(seed: int):
    cell = load_scene(CELL)
    camera = cell.camera("overview", 640)
    camera = Camera(camera.width, camera.height, camera.K, camera.R, camera.t, crate_camera(640, 480).dist)
    return cell, camera, make_case(cell, camera, seed)


def test_support_above_chance_tells_the_cells_wrong_poses_from_good_ones():
    """The figure behind the failure: the cell's seed 0 ends 22 px off (measured: 0.05 above
    chance, with 33 % support of the parts kept), the same photo from the true pose 0.36; a
    good crate fit 0.56-0.84."""
    cell, camera, case = _cell_case(0)
    off = EdgeOptions(max_left_out=1.0, min_support=0.0)
    with pytest.raises(EdgeFitError, match="too little support beyond chance"):
        refine_pose(cell, camera, case.photo, initial=case.rough, options=off)
    fit = refine_pose(cell, camera, case.photo, initial=case.truth, options=off)
    assert fit.above_chance >= 0.35
    scene, crates = crate_scene(), crate_camera(640, 480)
    crate = make_case(scene, crates, 0)
    assert refine_pose(scene, crates, crate.photo, initial=crate.rough).above_chance > 0.5


@pytest.mark.parametrize("seed", [2])
def test_the_cells_wrong_pose_fails_through_the_cli(seed, tmp_path, capsys):
    """The generated cell, 640x480, seed 2 (24.5 px off): the snap ended 27-28 px off with 54-60 %
    support and only a "poorly constrained" warning, and a SHOT was written; now exit 1, one line
    naming the photo, no SHOT."""
    _, camera, case = _cell_case(seed)
    cv2.imwrite(str(tmp_path / "photo.png"), case.photo)
    write_camera(tmp_path / "cam.json", camera, pose=False)
    write_camera(tmp_path / "rough.json", case.rough)
    out = tmp_path / "shot.json"
    code = main(["register", str(CELL), "--photo", str(tmp_path / "photo.png"), "--intrinsics",
                 str(tmp_path / "cam.json"), "--initial", str(tmp_path / "rough.json"), "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and not out.exists()
    assert len(err) == 1 and "photo.png" in err[0] and "too little support" in err[0], err
