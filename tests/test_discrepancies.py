"""``mrcheck discrepancies``: object ids, suspects, heat map, and precision / recall measured on
as-built variants of the sample cell (protocol: :mod:`mrcheck.eval.discrepancy_eval`)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from mrcheck.apps.discrepancies import behind_ids, detect, object_ids
from mrcheck.apps.discrepancies.thresholds import (
    DISCRIMINATIVE_FLOOR,
    DISCRIMINATIVE_THRESHOLD,
    SCORE_THRESHOLD,
)
from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval.discrepancy_eval import SAMPLE_CELL_FAR_VIEWS, evaluate, synthetic_photo
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import load_scene

SAMPLE = sample_scene_path()
W, H = 400, 300


def sample_camera(scene, view="conveyor", k1=-0.12):
    cam = scene.camera(view, W, H)
    return Camera(W, H, cam.K, cam.R, cam.t, np.array([k1, 0.0, 0.0, 0.0]))


@pytest.fixture(scope="module")
def sample():
    return load_scene(SAMPLE)


def test_object_ids_match_the_render_silhouette(ctx, sample):
    """The ray-cast id buffer covers what the renderer draws, and names real instances."""
    camera = sample_camera(sample, k1=0.0)
    ids, depth, labels = object_ids(sample, camera)
    renderer = Renderer(sample, ctx=ctx)
    gl_depth = renderer.render(camera, ["phong"]).depth
    renderer.release()
    agree = np.mean((ids >= 0) == (gl_depth > 0))
    assert agree > 0.99
    both = (ids >= 0) & (gl_depth > 0)
    assert np.median(np.abs(depth[both] - gl_depth[both]) / gl_depth[both]) < 1e-3
    names = {labels[i][1] for i in np.unique(ids[ids >= 0])}
    assert "conveyor" in names and all(isinstance(n, str) for n in names)


def test_behind_ids_see_past_the_first_instance(sample):
    """The second layer: never the pixel's own instance, always farther than it, and the floor
    behind the conveyor's pixels (it stands on the floor, in front of nothing else there)."""
    camera = sample_camera(sample, k1=0.0)
    ids, depth, labels = object_ids(sample, camera)
    bids, bdepth = behind_ids(sample, camera, ids, depth)
    hit = bids >= 0
    assert hit.mean() > 0.1
    assert not np.any(hit & (bids == ids))
    assert np.all(bdepth[hit] > depth[hit])
    conveyor = ids == [i for i, lab in enumerate(labels) if lab[1] == "conveyor"][0]
    behind = bids[conveyor & hit]
    assert len(behind) > 100 and np.mean([labels[i][1] == "floor" for i in behind]) > 0.8


@pytest.mark.slow
def test_precision_and_recall_on_asbuilt_variants(ctx, tmp_path):
    """A regression floor under the detector's figures, not their goal (issue 41's; the figures
    are in docs/discrepancy-evaluation.md). Protocol: seeds 0-2, views overview + conveyor +
    far_overview + far_back, 640x480 (the evaluation's default size), k1 -0.12, sun light, blur,
    noise.

    Measured: recall 0.627 (42/67), precision 0.841 (53 true / 10 false), moved >= 0.2 m 11/13,
    missing 8/11, false suspects on the unchanged scene 0, 1, 0, 0; before the photo's own null
    (issue 41) recall 0.642 (43/67) and precision 0.818, every case the same with OpenCV
    5.1.0.95 / numpy 2.4.6 (the lock) and OpenCV 5.0.0.93 / numpy 2.2.6, and 0.627 (42/67)
    with the lock's versions on another machine (issue 38). Other seeds spread far wider
    (per seed 0.36-0.81; seeds 3-5 together 34/70, 0.486), so the seeds stay fixed. The floors
    allow one item beyond that spread: recall 41/67, two more false suspects, one move and one
    missing part fewer. The outline the headlight render shows gave recall 0.60 (40/67) and
    missing 6/11 on this set, so the recall and missing floors fail if the relit expected outline
    stops working (its precision, 0.80, is above the floor); scoring every outline pixel gave
    precision 0.69 and up to 6 false suspects per view."""
    result = evaluate(
        SAMPLE,
        seeds=(0, 1, 2),
        views=("overview", "conveyor", *SAMPLE_CELL_FAR_VIEWS[:2]),
        width=640,
        height=480,
        workdir=tmp_path,
        ctx=ctx,
    )
    s = result.summary
    print(json.dumps(s, indent=1))
    kinds = s["per_kind"]
    assert kinds["moved >=0.2 m"]["recall"] >= 0.76  # 10/13
    assert s["recall"] >= 0.61  # 41/67
    assert s["precision"] >= 0.79  # 54 / (54 + 14)
    assert kinds["missing"]["recall"] >= 0.63  # 7/11
    # every truth item in view has a distance band, and the bands add up
    assert (
        sum(kinds.get(b, {"in_view": 0})["in_view"] for b in ("at <10 m", "at 10-20 m", "at >=20 m"))
        == kinds["all"]["in_view"]
    )
    # the untouched planned scene as the photo: at most one false suspect per view (issue 22)
    assert max(s["false_suspects_planned"]) <= 1


@pytest.mark.slow
def test_planned_scene_as_photo_gives_few_suspects(ctx, sample):
    camera = sample_camera(sample)
    photo = synthetic_photo(sample, camera, Renderer(sample, ctx=ctx))
    result = detect(sample, camera, photo, renderer=Renderer(sample, ctx=ctx))
    scored = result.suspects
    assert len(scored) > 10
    flagged = [s for s in scored if s.suspect]
    assert len(flagged) <= 0.1 * len(scored)
    assert all(
        not s.thin
        and (
            s.score >= SCORE_THRESHOLD
            or (s.score >= DISCRIMINATIVE_FLOOR and s.discriminative_score >= DISCRIMINATIVE_THRESHOLD)
        )
        for s in flagged
    )
    solid = [s for s in scored if not s.thin]
    assert np.median([s.support for s in solid]) > 0.85
    # unshifted is (about) the best match of a part that is where it was planned
    assert np.median([s.best_shift_support - s.support for s in solid]) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("encode", [None, ".jpg"])
def test_a_clean_photo_of_the_planned_scene_gives_few_suspects(ctx, sample, encode):
    """Without sensor noise (a render, a low-noise photo, its JPEG) the non-zero gradients are
    mostly edges: a threshold from their median rejected the edges themselves and flagged a
    third of the parts (26 of 64 here); the measured noise now caps it."""
    camera = sample_camera(sample)
    photo = synthetic_photo(sample, camera, Renderer(sample, ctx=ctx), noise=0.0)
    if encode:
        photo = cv2.imdecode(cv2.imencode(encode, photo, [cv2.IMWRITE_JPEG_QUALITY, 90])[1], cv2.IMREAD_COLOR)
    result = detect(sample, camera, photo, renderer=Renderer(sample, ctx=ctx))
    flagged = [s for s in result.suspects if s.suspect]
    assert len(result.suspects) > 10 and len(flagged) <= 0.1 * len(result.suspects)
    assert all(s.score >= 0.0 for s in result.suspects)


def write_shot_files(tmp_path, scene, camera, photo):
    cv2.imwrite(str(tmp_path / "photo.png"), photo[..., ::-1])
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "photo.png"}))
    return shot


@pytest.mark.slow
def test_cli_writes_heatmap_suspects_and_markers(ctx, sample, tmp_path):
    from mrcheck.scene.asbuilt import make_asbuilt

    make_asbuilt(SAMPLE, tmp_path / "built", seed=2)
    built = load_scene(tmp_path / "built" / "scene.toml")
    camera = sample_camera(sample)
    shot = write_shot_files(tmp_path, built, camera, synthetic_photo(built, camera, Renderer(built, ctx=ctx)))
    out = tmp_path / "out"
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 0
    heat = cv2.imread(str(out / "heatmap.png"))
    assert heat.shape[1:] == (W, 3) and H + 10 <= heat.shape[0] <= H + 20  # the photo, a legend under it
    assert (heat[H + 2 :] == 32).mean() > 0.5  # a dark strip with text
    doc = json.loads((out / "suspects.json").read_text())
    ids = [s["id"] for s in doc["suspects"] if s["suspect"]]
    assert ids and ids[0] == "conveyor"  # seed 2 removed the conveyor: the top suspect
    markers = doc["suggested_markers"]
    assert markers and {"x", "y", "category", "severity", "note", "part"} <= set(markers[0])
    assert markers[0]["category"] in {"moved", "missing", "extra", "other"} and markers[0]["severity"] in (1, 2, 3)
    assert "conveyor" in (out / "suspects.md").read_text()
    # the suggested markers as BCF 2.1 topics: schema-valid, the part as component, the shot's camera
    from mrcheck.apps.bcf import read_bcf_bytes

    from .test_bcf import validate_bcfzip

    data = (out / "suspects.bcfzip").read_bytes()
    assert validate_bcfzip(data)
    topics = read_bcf_bytes(data)
    assert len(topics) == len(markers) and topics[0].components[0].tool_id == markers[0]["part"]
    assert topics[0].description == markers[0]["note"] and topics[0].snapshot_png.startswith(b"\xff\xd8\xff")  # a crop
    assert np.allclose(topics[0].camera.viewpoint, camera.center)


def test_bad_input_exits_1_with_one_line_and_no_files(sample, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["discrepancies", str(tmp_path / "nope.json"), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    camera = sample_camera(sample)
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "missing.png"}))
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    cv2.imwrite(str(tmp_path / "small.png"), np.zeros((100, 120, 3), np.uint8))
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "small.png"}))
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "-o", str(out)]) == 1
    # a tolerance near the image's size would pad arrays to gigabytes (seen: 48 GB at 10000 px)
    assert main(["discrepancies", str(shot), "--scene", str(SAMPLE), "--tolerance-px", "10000", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("error: ") for line in err)
    assert "120x100" in err[2]
    assert "tolerance must be at most 5% of the photo's shorter side" in err[3] and "shot.json" in err[3]
    assert not out.exists()
