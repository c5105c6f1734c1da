"""`mrcheck bench` runs and reports every figure and ratio (its numbers are not asserted:
timings belong to the machine, see the README's performance section)."""

from __future__ import annotations

import json

from mrcheck.cli import main


def test_bench_quick_writes_every_figure_and_ratio(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--repeat", "1", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert set(report["ratios"]) >= {"vector_over_ssao", "vector_over_fetch_floor", "half_over_full", "ao_10m_over_1m"}
    assert "geometry_20m_over_1m" in report["ratios"]
    for peer in ("vtk_over_mrcheck_frame", "open3d_over_mrcheck_frame"):  # null only with a reason
        assert peer in report["ratios"]
        assert report["ratios"][peer] is not None or isinstance(report["reasons"][peer], str)
    assert all(value > 0 for value in report["ratios"].values() if value is not None)
    halls = [f for f in report["figures"] if f["name"] == "geometry" and f["stats"].get("generated") == "hall"]
    assert {f["triangles"] for f in halls} >= {1_000_000, 20_000_000}
    assert all(f["stats"]["triangles_drawn"] > 0 for f in halls)
    assert {(f["width"], f["height"], f["samples"]) for f in report["figures"] if f["name"] == "frame"
            and f["mode"] == "vector"} == {(1280, 1024, 16), (1024, 768, 32)}
    names = {(f["name"], f["mode"], f["scale"]) for f in report["figures"]}
    for needed in (("ao", "vector", 1.0), ("ao", "vector", 0.5), ("ao", "ssao", 1.0), ("fetch_floor", None, 1.0),
                   ("geometry", None, None), ("blur_9x9", None, 1.0), ("composite", None, 1.0)):
        assert needed in names
    for figure in report["figures"]:
        assert 0 < figure["min_ms"] <= figure["median_ms"] <= figure["max_ms"] and figure["unit"] == "ms"
    assert report["machine"]["gl_renderer"] and report["peak_rss_mb"] > 0
    printed = capsys.readouterr().out
    assert "vector_over_ssao" in printed and "GTX285" in printed
