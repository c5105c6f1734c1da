"""``mrcheck bench --accumulate`` (mrcheck.eval.accbench) on a small view of the sample cell: the
figures it prints are measured, and more frames lower the noise it measures."""

from __future__ import annotations

import json
import math

import pytest

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval.accbench import BenchSize, accumulate_bench, table_lines

pytestmark = pytest.mark.slow  # two ray-traced references and a converged render: seconds


def test_more_frames_lower_the_noise_and_the_figures_are_written(tmp_path):
    """Measured at 96x72 (the sample cell's overview): the raw noise falls from about 0.05 to
    0.02 with 4 frames; the limit (below 0.8 of one frame's) leaves room for other rasterisers."""
    size = BenchSize(96, 72, rays=8, footprint_offsets=2, footprint_rays=4, rounds=1)
    out = tmp_path / "acc.json"
    rows = accumulate_bench(sample_scene_path(), "overview", size, frames=(1, 4), json_path=out)
    assert [r.frames for r in rows] == [1, 4]
    for r in rows:
        figures = (r.noise_raw, r.noise_blurred, r.rmse_point, r.rmse_footprint, r.seconds)
        assert all(math.isfinite(v) and v >= 0 for v in figures)
    assert rows[1].noise_raw < 0.8 * rows[0].noise_raw, (rows[0].noise_raw, rows[1].noise_raw)
    written = json.loads(out.read_text())
    assert written["setup"]["width"] == 96 and [r["frames"] for r in written["rows"]] == [1, 4]
    lines = table_lines(rows, "sample overview 96x72")
    assert len(lines) == 4 and "lower" in lines[-1]


def test_the_benches_are_one_at_a_time(capsys):
    assert main(["bench", "--accumulate", "--edges"]) != 0
    assert "separate benches" in capsys.readouterr().err
