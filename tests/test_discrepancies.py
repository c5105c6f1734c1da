"""``mrcheck discrepancies``: object ids, suspects, heat map, and precision / recall measured on
as-built variants of the sample cell (protocol: :mod:`mrcheck.discrepancies`)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from mrcheck.camera import Camera
from mrcheck.cli import main
from mrcheck.discrepancies import SCORE_THRESHOLD, detect, evaluate, object_ids, synthetic_photo
from mrcheck.renderer import Renderer
from mrcheck.resources import sample_scene_path
from mrcheck.scene import load_scene

SAMPLE = sample_scene_path()
W, H = 400, 300


def _camera(scene, view="conveyor", k1=-0.12):
    cam = scene.camera(view, W, H)
    return Camera(W, H, cam.K, cam.R, cam.t, np.array([k1, 0.0, 0.0, 0.0]))


@pytest.fixture(scope="module")
def sample():
    return load_scene(SAMPLE)


def test_object_ids_match_the_render_silhouette(ctx, sample):
    """The ray-cast id buffer covers what the renderer draws, and names real instances."""
    camera = _camera(sample, k1=0.0)
    ids, depth, labels = object_ids(sample, camera)
    renderer = Renderer(sample, ctx=ctx)
    renderer.render(camera, ["phong"])
    gl_depth = renderer.last_depth()
    renderer.release()
    agree = np.mean((ids >= 0) == (gl_depth > 0))
    assert agree > 0.99
    both = (ids >= 0) & (gl_depth > 0)
    assert np.median(np.abs(depth[both] - gl_depth[both]) / gl_depth[both]) < 1e-3
    names = {labels[i][1] for i in np.unique(ids[ids >= 0])}
    assert "conveyor" in names and all(isinstance(n, str) for n in names)


def test_precision_and_recall_on_asbuilt_variants(ctx, tmp_path):
    """Measured (seeds 0-2, views overview + conveyor, 400x300, k1 -0.12, sun light, blur, noise):
    recall 0.387 (12/31), precision 0.414 (12 true / 17 false; 8 more suspects are parts
    uncovered or covered by a change), moved 6/8, missing 4/12, added 6/12, replaced 1/5,
    rotated 0/6. Asserted with a small margin."""
    result = evaluate(SAMPLE, seeds=(0, 1, 2), views=("overview", "conveyor"), width=W, height=H,
                      workdir=tmp_path, ctx=ctx)
    s = result["summary"]
    print(json.dumps(s, indent=1))
    assert s["recall"] >= 0.35
    assert s["precision"] >= 0.37
    kinds = s["per_kind"]
    assert kinds["moved"]["recall"] >= 0.7
    assert kinds["added"]["recall"] >= 0.45
    assert kinds["missing"]["recall"] >= 0.3
    # the untouched planned scene as the photo: a few false suspects per view at most
    assert max(s["false_suspects_planned"]) <= 5


def test_planned_scene_as_photo_gives_few_suspects(ctx, sample):
    camera = _camera(sample)
    photo = synthetic_photo(sample, camera, Renderer(sample, ctx=ctx))
    result = detect(sample, camera, photo, renderer=Renderer(sample, ctx=ctx))
    scored = result["suspects"]
    assert len(scored) > 10
    flagged = [s for s in scored if s["score"] >= SCORE_THRESHOLD]
    assert len(flagged) <= 0.15 * len(scored)
    assert np.median([s["support"] for s in scored]) > 0.85


def _shot(tmp_path, scene, camera, photo):
    cv2.imwrite(str(tmp_path / "photo.png"), photo[..., ::-1])
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "photo.png"}))
    return shot


def test_cli_writes_heatmap_suspects_and_markers(ctx, sample, tmp_path):
    from mrcheck.asbuilt import make_asbuilt

    make_asbuilt(SAMPLE, tmp_path / "built", seed=2)
    built = load_scene(tmp_path / "built" / "scene.toml")
    camera = _camera(sample)
    shot = _shot(tmp_path, built, camera, synthetic_photo(built, camera, Renderer(built, ctx=ctx)))
    out = tmp_path / "out"
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 0
    heat = cv2.imread(str(out / "heatmap.png"))
    assert heat.shape == (H, W, 3)
    doc = json.loads((out / "suspects.json").read_text())
    ids = [s["id"] for s in doc["suspects"] if s["suspect"]]
    assert ids and ids[0] == "conveyor"           # seed 2 removed the conveyor: the top suspect
    markers = doc["suggested_markers"]
    assert markers and {"x", "y", "category", "severity", "note", "part"} <= set(markers[0])
    assert markers[0]["category"] in {"moved", "missing", "extra", "other"} and markers[0]["severity"] in (1, 2, 3)
    assert "conveyor" in (out / "suspects.md").read_text()


def test_bad_input_exits_1_with_one_line_and_no_files(sample, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["discrepancies", str(tmp_path / "nope.json"), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    camera = _camera(sample)
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "missing.png"}))
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    cv2.imwrite(str(tmp_path / "small.png"), np.zeros((100, 120, 3), np.uint8))
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "small.png"}))
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("error: ") for line in err)
    assert "120x100" in err[2]
    assert not out.exists()
