"""``mrcheck compare`` and :mod:`mrcheck.eval.metrics`: hand-computed metric values, the complete
outputs of a small comparison on the sample scene, and bad input leaving no output."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval import metrics
from mrcheck.eval.compare import legend_strip_height
from mrcheck.render.renderer import MODES

AO_MODES = [m for m in MODES if m != "phong"]
METRIC_KEYS = {"mae", "rmse", "ssim", "false_occlusion", "distance_retention", "ms", "reference"}
W, H = 96, 72


# -- metrics on hand-made arrays -------------------------------------------------------------------
def test_mae_rmse_on_a_2x2_example():
    ao = np.array([[0.5, 1.0], [0.2, 0.9]], np.float32)
    ref = np.array([[0.7, 1.0], [0.6, 0.5]], np.float32)
    depth = np.ones((2, 2), np.float32)
    # errors 0.2, 0, 0.4, 0.4
    assert metrics.mae(ao, ref, depth) == pytest.approx(1.0 / 4, abs=1e-6)
    assert metrics.rmse(ao, ref, depth) == pytest.approx(math.sqrt(0.36 / 4), abs=1e-6)
    # background (depth 0) is excluded: drop the pixel with error 0.4 at (1, 1)
    depth[1, 1] = 0
    assert metrics.mae(ao, ref, depth) == pytest.approx(0.6 / 3, abs=1e-6)
    assert metrics.rmse(ao, ref, depth) == pytest.approx(math.sqrt(0.2 / 3), abs=1e-6)


def test_false_occlusion_only_counts_pixels_the_reference_calls_unoccluded():
    ref = np.array([[1.0, 0.995, 0.5], [1.0, 0.2, 1.0]], np.float32)
    ao = np.array([[0.9, 0.7, 0.0], [0.6, 0.0, 0.1]], np.float32)
    depth = np.array([[1, 1, 1], [1, 1, 0]], np.float32)  # the last pixel is background
    # unoccluded covered pixels: ao 0.9, 0.7, 0.6 -> darkening 0.1, 0.3, 0.4
    assert metrics.false_occlusion(ao, ref, depth) == pytest.approx(0.8 / 3, abs=1e-6)
    with pytest.raises(metrics.MetricUndefined):
        metrics.false_occlusion(ao, np.zeros_like(ref), depth)


def test_distance_retention_on_constructed_depth_quartiles():
    depth = np.arange(1, 9, dtype=np.float32).reshape(2, 4)  # 1..8: Q1 = 2.75, Q3 = 6.25
    ao = np.array([[0.6, 0.8, 1.0, 1.0], [1.0, 1.0, 0.9, 0.7]], np.float32)
    near, far = metrics.depth_quartiles(depth)
    assert near.sum() == 2 and far.sum() == 2
    # near darkening mean(0.4, 0.2) = 0.3, far mean(0.1, 0.3) = 0.2
    assert metrics.distance_retention(ao, ao, depth) == pytest.approx(0.2 / 0.3, abs=1e-6)
    # no near darkening: no ratio, None and a reason from all_metrics
    flat = np.ones_like(ao)
    with pytest.raises(metrics.MetricUndefined, match="nearest depth quartile"):
        metrics.distance_retention(flat, flat, depth)
    result = metrics.all_metrics(flat, flat, depth)
    assert result["distance_retention"] is None and "distance_retention" in result["notes"]


def test_ssim_is_one_for_identical_and_less_for_different():
    rng = np.random.default_rng(0)
    ref = cv2.GaussianBlur(rng.random((40, 50)).astype(np.float32), (7, 7), 2)
    depth = np.ones_like(ref)
    depth[:, :5] = 0  # a background band: excluded, the result still 1 for identical buffers
    assert metrics.ssim(ref, ref, depth) == pytest.approx(1.0, abs=1e-9)
    noisy = np.clip(ref + rng.normal(0, 0.1, ref.shape), 0, 1).astype(np.float32)
    assert metrics.ssim(noisy, ref, depth) < 0.9
    assert metrics.ssim(noisy, ref, depth) == pytest.approx(metrics.ssim(ref, noisy, depth), abs=1e-12)
    result = metrics.all_metrics(ref, ref, depth)
    assert result["mae"] == 0 and result["rmse"] == 0 and result["ssim"] == pytest.approx(1.0, abs=1e-9)


def test_no_covered_pixel_is_undefined_everywhere():
    a = np.ones((3, 3), np.float32)
    result = metrics.all_metrics(a, a, np.zeros_like(a))
    assert all(result[name] is None for name in metrics.METRIC_NAMES)
    assert set(result["notes"]) == set(metrics.METRIC_NAMES)


# -- the command -----------------------------------------------------------------------------------
@pytest.mark.slow
def test_compare_writes_figure_and_metrics(tmp_path, capsys):
    out = tmp_path / "cmp"
    argv = [
        "compare",
        str(sample_scene_path()),
        "--view",
        "robot",
        "--width",
        str(W),
        "--height",
        str(H),
        "--rays",
        "32",
        "--samples",
        "8",
        "-o",
        str(out),
    ]
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["figure.png", "metrics.json", "metrics.md"]
    for name in ("figure.png", "metrics.json", "metrics.md"):
        assert str(out / name) in stdout

    report = json.loads((out / "metrics.json").read_text())
    assert {k: report[k] for k in ("view", "width", "height", "samples", "rays")} == {
        "view": "robot",
        "width": W,
        "height": H,
        "samples": 8,
        "rays": 32,
    }
    assert report["scene"].endswith("scene.toml")
    assert list(report["modes"]) == AO_MODES
    for mode, values in report["modes"].items():
        assert set(values) == METRIC_KEYS
        # the screen-radius modes share the vector mode's reference (same radius definition)
        assert values["reference"] == ("screen" if mode in ("vector", "gtao", "vbao") else "world")
        assert values["ms"] > 0
        for key in ("mae", "rmse", "ssim", "false_occlusion"):
            assert isinstance(values[key], float) and math.isfinite(values[key])
        assert 0 <= values["mae"] <= values["rmse"] <= 1 and -1 <= values["ssim"] <= 1
    # the renders are at full detail like the references' scene: from a render at the default
    # level of detail the reference's rays started inside the full-detail robot (RMSE 0.172)
    assert report["modes"]["vector"]["rmse"] < 0.12  # 0.093 here

    # rows: one per reference kind in use, then one per mode; three panels each
    kinds = {values["reference"] for values in report["modes"].values()}
    figure = cv2.imread(str(out / "figure.png"))
    rows = len(AO_MODES) + len(kinds)
    assert figure.shape[0] % rows == 0
    row_height = figure.shape[0] // rows
    assert H + legend_strip_height(H) < row_height < 2 * H
    assert 3 * W <= figure.shape[1] < 3 * W + 10

    md = (out / "metrics.md").read_text()
    for mode in AO_MODES:
        assert f"| {mode} |" in md
    # rankings follow the numbers, whatever they are
    fo = {m: v["false_occlusion"] for m, v in report["modes"].items()}
    assert f"lowest false occlusion: {min(fo, key=fo.get)}" in md


def test_compare_unknown_view_is_one_line_error_and_no_output(tmp_path, capsys):
    out = tmp_path / "cmp"
    argv = [
        "compare",
        str(sample_scene_path()),
        "--view",
        "nowhere",
        "--width",
        str(W),
        "--height",
        str(H),
        "-o",
        str(out),
    ]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "nowhere" in err[0]
    assert not out.exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--rays", "100000", "-o", "{tmp}/cmp"], "rays must be in [1, 4096]"),
        (["-o", "/proc/cmp"], "folder /proc is not writable"),
    ],
)
def test_compare_bad_option_or_unwritable_output_fails_before_rendering(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["compare", str(sample_scene_path()), "--view", "robot", *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0], err
    assert list(tmp_path.iterdir()) == []


def test_compare_outdir_that_is_a_file_fails_before_rendering(tmp_path, capsys):
    out = tmp_path / "cmp"
    out.write_text("x")
    assert main(["compare", str(sample_scene_path()), "--view", "robot", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "is a file" in err[0]
    assert out.read_text() == "x"
