"""`mrcheck bench` runs and reports every figure and ratio (its numbers are not asserted:
timings belong to the machine, see docs/performance.md)."""

from __future__ import annotations

import contextlib
import inspect
import io
import json
import mmap
import sys
import tempfile
import textwrap
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.eval.bench import figures as bench_figures
from mrcheck.eval.bench import line as bench_line
from mrcheck.eval.bench import peer_client as bench_client
from mrcheck.eval.bench import peers as bench_peers
from mrcheck.eval.bench import plan as bench_plan
from mrcheck.eval.bench import report as bench_report
from mrcheck.eval.bench import run as bench
from mrcheck.eval.bench import scenes as bench_scenes
from mrcheck.eval.bench import timing as bench_timing
from mrcheck.eval.bench.peer_client import PeerError, PeerNotInstalled, PeerWorker

from .conftest import box, scene_of


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """One quick run at the tiniest setting (one timed round) for every test of the report:
    (the JSON it wrote, what it printed)."""
    out = tmp_path_factory.mktemp("bench") / "bench.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["bench", "--quick", "--repeat", "1", "--json", str(out)]) == 0
    return json.loads(out.read_text()), printed.getvalue()


def _figures(report) -> list:
    """The report's figures as the measuring step returned them."""
    return [
        bench.Figure(
            f["name"],
            f["mode"],
            f["width"],
            f["height"],
            f["samples"],
            f["scale"],
            f["scene"],
            f["triangles"],
            f["paper_gtx285_ms"],
            list(f["runs_ms"]),
            f["stats"],
            f["timed_in_turns_with"],
            peak_rss_mb=f["peak_rss_mb"],
        )
        for f in report["figures"]
    ]


def _kind(scene: str) -> str:
    """Which scene a figure was timed on: sample (the sample cell), terrain, hall or line."""
    return "sample" if scene.startswith("sample_cell") else scene.split("_")[0].split(":")[0]


def _one(report, **match) -> dict:
    """The one figure of the report that matches, e.g. ``_one(report, name="ao", kind="sample", ...)``."""
    hits = [
        f for f in report["figures"] if all((_kind(f["scene"]) if k == "kind" else f[k]) == v for k, v in match.items())
    ]
    assert len(hits) == 1, f"{len(hits)} figures for {match}"
    return hits[0]


@pytest.mark.slow
def test_bench_quick_ratios_are_the_named_figures(quick):
    """With one timed round each ratio is the ratio of the one run of the two figures it names,
    in the issue's direction (vector / ssao, half / full, 10 M / 1 M, 20 M / 1 M, peer / mrcheck)."""
    report, _ = quick
    assert report["run"]["repeat"] == 1 and all(len(f["runs_ms"]) == 1 for f in report["figures"])

    def ms(**match):
        return _one(report, **match)["runs_ms"][0]

    def ao(mode="vector", samples=16, scale=1.0, kind="sample", **extra):
        return ms(name="ao", mode=mode, samples=samples, scale=scale, width=1280, height=1024, kind=kind, **extra)

    def floor(samples=16, kind="sample", **extra):
        return ms(name="fetch_floor", samples=samples, scale=1.0, width=1280, height=1024, kind=kind, **extra)

    expected = {
        "vector_over_ssao": ao() / ao("ssao"),
        "vector_over_fetch_floor": ao() / floor(),
        "half_over_full": ao(scale=0.5) / ao(),
        "ao_10m_over_1m": ao(kind="terrain", triangles=10_000_000) / ao(kind="terrain", triangles=1_000_000),
        "vector_over_fetch_floor_covered": ao(kind="terrain", triangles=1_000_000) / floor(kind="terrain"),
        "geometry_20m_over_1m": (
            ms(name="geometry", kind="hall", triangles=20_000_000, width=1280)
            / ms(name="geometry", kind="hall", triangles=1_000_000, width=1280)
        ),
    }
    ours = {
        scale: ms(name="frame", mode="vector", kind="line", width=1024, samples=32, scale=scale) for scale in (1.0, 0.5)
    }
    for peer in bench_peers.PEERS:
        if report["ratios"][f"{peer}_over_mrcheck_frame"] is not None:
            theirs = ms(name="frame", mode=peer, kind="line", width=1024)
            expected[f"{peer}_over_mrcheck_frame"] = theirs / ours[1.0]
            expected[f"{peer}_over_mrcheck_frame_half_res_ao"] = theirs / ours[0.5]
    assert {k: v for k, v in report["ratios"].items() if k in expected} == pytest.approx(expected, rel=1e-12)
    for n, ratios in report["ratios_by_samples"].items():
        n = int(n)
        assert ratios == pytest.approx(
            {
                "vector_over_ssao": ao(samples=n) / ao("ssao", n),
                "vector_over_fetch_floor": ao(samples=n) / floor(n),
                "half_over_full": ao(samples=n, scale=0.5) / ao(samples=n),
            },
            rel=1e-12,
        )
    for f in report["figures"]:  # every AO figure of the sample scene over the floor of its settings
        if f["name"] == "ao" and _kind(f["scene"]) == "sample":
            assert f["over_fetch_floor"] == pytest.approx(
                f["runs_ms"][0]
                / ms(name="fetch_floor", kind="sample", width=f["width"], samples=f["samples"], scale=f["scale"]),
                rel=1e-12,
            )


@pytest.mark.slow
def test_bench_quick_measures_every_item_of_the_issue(quick):
    """Every figure the issue asks for, in the quick plan: the AO pass and the whole frame of the
    five AO modes and the fetch floor at 1280x1024, 16 and 64 samples, full and half resolution;
    both blurs and the composite at
    both; the height fields; the halls at both sizes; the frames; peak memory. A peer that is installed runs."""
    report, printed = quick
    have = Counter(
        (f["name"], f["mode"], _kind(f["scene"]), f["width"], f["height"], f["samples"], f["scale"], f["triangles"])
        for f in report["figures"]
    )
    assert max(have.values()) == 1  # nothing measured twice
    want = set()
    for samples in (16, 64):
        for scale in (1.0, 0.5):
            want |= {
                (name, mode, "sample", 1280, 1024, samples, scale, None)
                for mode in bench_figures.AO_MODES
                for name in ("ao", "frame")
            }
            want.add(("fetch_floor", None, "sample", 1280, 1024, samples, scale, None))
    for scale in (1.0, 0.5):
        want |= {
            (name, None, "sample", 1280, 1024, None, scale, None) for name in ("blur_9x9", "blur_13x13", "composite")
        }
    for triangles in (1_000_000, 10_000_000):
        want |= {
            ("geometry", None, "terrain", 1280, 1024, None, None, triangles),
            ("ao", "vector", "terrain", 1280, 1024, 16, 1.0, triangles),
        }
    want.add(("fetch_floor", None, "terrain", 1280, 1024, 16, 1.0, 1_000_000))
    want |= {
        ("geometry", None, "hall", *size, None, None, n)
        for n in (1_000_000, 20_000_000)
        for size in ((1280, 1024), (1024, 768))
    }
    line = _one(report, name="frame", mode="vector", width=1280, kind="line")["triangles"]
    assert 1.45e6 < line < 1.55e6  # not the issue's 1 M triangles, and labelled as what it is:
    assert all(f["scene"].startswith("line_1.5M:") for f in report["figures"] if _kind(f["scene"]) == "line")
    assert f"{line:,} triangles (the issue names a 1 M-triangle line scene)" in printed
    assert bench.Figure("frame", "vector", 1024, 768, 32, 1.0, "line", line).describe().endswith(" 1.5M triangles")
    want |= {
        ("frame", "vector", "line", 1280, 1024, 16, 1.0, line),
        ("frame", "vector", "line", 1024, 768, 32, 1.0, line),
        ("frame", "vector", "line", 1024, 768, 32, 0.5, line),
    }
    for peer in bench_peers.PEERS:
        key = f"{peer}_over_mrcheck_frame"
        if report["ratios"][key] is None:  # only a peer that is not installed may be missing
            assert report["ratios"][key + "_reason"].startswith(bench_peers.NOT_INSTALLED), report["ratios"][
                key + "_reason"
            ]
        else:
            want.add(("frame", peer, "line", 1024, 768, None, None, line))
    assert set(have) == want
    assert set(report["ratios"]) >= set(bench_figures.TARGETS) | set(bench_figures.PEER_TARGETS)
    halls = [f for f in report["figures"] if f["name"] == "geometry" and _kind(f["scene"]) == "hall"]
    assert all(f["stats"]["generated"] == "hall" and f["stats"]["triangles_drawn"] > 0 for f in halls)
    assert report["machine"]["gl_renderer"] and report["peak_rss_mb"] > 100  # numpy, GL, a 20 M-triangle hall
    for f in report["figures"]:  # each figure's peak memory, the bench's or a peer worker's own
        assert 50 < f["peak_rss_mb"] and (f["mode"] in bench_peers.PEERS or f["peak_rss_mb"] <= report["peak_rss_mb"])
        assert f["mode"] not in bench_peers.PEERS or f["stats"]["setup_peak_rss_mb"] > 50  # the peer's set-up
    assert report["peak_rss_per_figure"] and "peak MB" in printed.splitlines()[0]
    pngs = [Path(f["stats"]["png"]) for f in report["figures"] if "png" in f["stats"]]
    assert pngs and all(png.parent == bench_line.peer_folder() and png.exists() for png in pngs)  # one folder, reused
    assert "vector_over_ssao" in printed and "GTX285" in printed


@pytest.mark.slow
def test_the_progress_total_is_the_figures_measured(quick):
    """The plan's count is what a run measures: 80 figures quick, 268 in a full run (2 sizes x
    (4 sample counts x 30 + 6) on the sample cell -- 7 AO modes' passes and frames at 2
    resolutions and 2 floors per count --, 5 on the height fields, 3 halls at 2 sizes, 3
    line-scene frames and 2 peers)."""
    report, _ = quick
    not_run = sum(report["ratios"][f"{peer}_over_mrcheck_frame"] is None for peer in bench_peers.PEERS)
    assert bench_plan.planned_figures(quick=True) == len(report["figures"]) + not_run == 80
    assert bench_plan.planned_figures(quick=False) == 268


@pytest.mark.slow
def test_the_papers_column_is_beside_its_own_method_only(quick):
    """Scheer & Keutel timed their vector method alone (Tables 1 and 2, GTX 285, 1280x1024)."""
    report, _ = quick
    paper = {
        (f["name"], f["mode"], _kind(f["scene"]), f["width"], f["samples"], f["scale"]): f["paper_gtx285_ms"]
        for f in report["figures"]
        if f["paper_gtx285_ms"] is not None
    }
    assert paper == {
        ("ao", "vector", "sample", 1280, 16, 1.0): 12.4,
        ("ao", "vector", "sample", 1280, 16, 0.5): 1.6,
        ("ao", "vector", "sample", 1280, 64, 1.0): 47.0,
        ("ao", "vector", "sample", 1280, 64, 0.5): 6.1,
        ("blur_9x9", None, "sample", 1280, None, 1.0): 2.8,
        ("blur_13x13", None, "sample", 1280, None, 1.0): 3.6,
        ("frame", "vector", "line", 1280, 16, 1.0): 19.6,
    }  # 16 samples, 13x13 blur: Table 2


@pytest.mark.slow
def test_bench_quick_timings_are_plausible(quick):
    """Positive, in milliseconds and not absurdly small: a pass that is not waited for (no
    ctx.finish()) would take microseconds."""
    report, _ = quick
    for f in report["figures"]:
        assert f["unit"] == "ms" and 0 < f["min_ms"] <= f["median_ms"] <= f["max_ms"]
        if f["name"] in ("ao", "fetch_floor", "frame") or f["name"].startswith(("blur", "composite", "geometry")):
            assert f["min_ms"] >= 0.1, f  # a 1280x1024 AO pass cannot take under 0.1 ms, nor a frame
    # a whole frame takes longer than its AO pass alone. The two are timed in different entries, at
    # different moments, and a loaded machine (other processes) slowed single AO passes to 3x their
    # frame (a frame median 535 ms below its AO pass's 1684 ms): so each pair with a wide margin,
    # and all pairs together by their median ratio. A frame that does not wait for its AO pass (no
    # ctx.finish()) takes the time to submit it, a few percent of the pass: it fails both.
    over_ao = []
    for f in report["figures"]:
        if f["name"] == "frame" and _kind(f["scene"]) == "sample":
            ao = _one(
                report,
                name="ao",
                kind="sample",
                mode=f["mode"],
                width=f["width"],
                samples=f["samples"],
                scale=f["scale"],
            )
            over_ao.append(f["min_ms"] / ao["min_ms"])
            assert over_ao[-1] > 0.2, (f, ao)
    # every AO mode x 2 scales x 2 sample counts (7 modes since gtao and vbao: 28)
    assert len(over_ao) == len(bench_figures.AO_MODES) * 2 * 2 and np.median(over_ao) > 0.8, over_ao
    line = {
        (f["width"], f["scale"]): f["median_ms"]
        for f in report["figures"]
        if f["name"] == "frame" and f["mode"] == "vector" and _kind(f["scene"]) == "line"
    }
    assert line[1024, 0.5] < line[1024, 1.0]  # the half-resolution AO frame does less work
    for peer in bench_peers.PEERS:
        if report["ratios"][f"{peer}_over_mrcheck_frame"] is not None:
            assert _one(report, name="frame", mode=peer)["median_ms"] >= 1.0  # 1024x768 with AO, read back


@pytest.mark.slow
def test_a_null_ratio_has_its_reason_next_to_it(quick):
    """A peer that did not run: each of its ratios (the half-resolution one too) is null with
    the peer's reason beside it in ``ratios``, in the top-level ``reasons`` and printed with it."""
    report, _ = quick
    figures = [f for f in _figures(report) if f.mode not in bench_peers.PEERS]
    measured = bench_report.ratios(figures, {"vtk": "not installed: pyvista (test)"})
    ratios = measured["ratios"]
    for key in bench_figures.PEER_RATIOS.values():
        for name in (key, key + "_half_res_ao"):
            assert ratios[name] is None and ratios[name + "_reason"]
    assert ratios["vtk_over_mrcheck_frame_half_res_ao_reason"] == "not installed: pyvista (test)"
    assert ratios["open3d_over_mrcheck_frame_reason"] == "no open3d frame was measured"
    printed = bench_report.format_ratios(measured, {"quick": False, "repeat": 1}).splitlines()
    assert sum("not installed: pyvista (test)" in line for line in printed) == 2
    assert all(not line.strip().startswith("vtk_over_mrcheck_frame_reason") for line in printed)


@pytest.mark.slow
def test_a_ratio_keeps_its_rounds(quick):
    """Each paired ratio keeps its per-round ratios, printed as their spread beside it; a quick
    run says that its verdicts are indicative."""
    report, printed = quick
    assert report["ratios_rounds"]["vector_over_ssao"] == [report["ratios"]["vector_over_ssao"]]
    assert "verdicts from 1 round are indicative" in printed
    figures = _figures(report)
    for f in figures:  # three rounds, the vector pass's second twice as slow and its third twice as fast
        f.times_ms = f.times_ms * 3
    vector = next(
        f
        for f in figures
        if (f.name, f.mode, f.width, f.samples, f.scale, f.triangles) == ("ao", "vector", 1280, 16, 1.0, None)
    )
    vector.times_ms = [vector.times_ms[0], 2 * vector.times_ms[0], 0.5 * vector.times_ms[0]]
    measured = bench_report.ratios(figures)
    r = measured["ratios"]["vector_over_ssao"]
    assert measured["ratios_rounds"]["vector_over_ssao"] == pytest.approx([r, 2 * r, 0.5 * r])
    v = measured["ratios_by_samples"]["16"]["half_over_full"]
    assert measured["ratios_by_samples_rounds"]["16"]["half_over_full"] == pytest.approx([v, v / 2, 2 * v])
    text = bench_report.format_ratios(measured, {"quick": True, "repeat": 3})
    line = next(line for line in text.splitlines() if line.split()[0] == "vector_over_ssao")
    assert f"{r:.3f} (rounds {0.5 * r:.2f}-{2 * r:.2f})" in line
    assert "verdicts from 3 rounds are indicative" in text


@pytest.mark.slow
def test_vector_over_ssao_is_judged_at_every_sample_count(quick):
    """The target is "at equal samples": a miss at 64 samples shows, though 16 meets it; the
    floor and half/full targets are the issue's at 16 samples only, and say so elsewhere."""
    report, printed = quick
    assert report["target_samples"] == {
        "vector_over_ssao": "every",
        "vector_over_fetch_floor": 16,
        "half_over_full": 16,
    }
    for n in report["ratios_by_samples"]:
        assert any(
            line.split()[:2] == ["vector_over_ssao", n] and "target <= 1.20" in line for line in printed.splitlines()
        )
    figures = _figures(report)
    ssao = {(f.samples, f.scale): f for f in figures if f.name == "ao" and f.mode == "ssao" and f.width == 1280}
    vector = {
        (f.samples, f.scale): f
        for f in figures
        if f.name == "ao" and f.mode == "vector" and f.width == 1280 and f.triangles is None
    }
    ssao[16, 1.0].times_ms = [vector[16, 1.0].times_ms[0]]  # vector / ssao = 1.0 at 16 samples
    ssao[64, 1.0].times_ms = [vector[64, 1.0].times_ms[0] / 1.5]  # and 1.5 at 64
    lines = bench_report.format_ratios(bench_report.ratios(figures), report["run"]).splitlines()
    assert next(line for line in lines if line.split()[0] == "vector_over_ssao").endswith(
        "meets at 16; MISSES at 64 samples"
    )
    assert [line.split()[1:3] + [line.split()[-1]] for line in lines if line.split()[0] == "vector_over_ssao"][1:] == [
        ["16", "1.000", "meets"],
        ["64", "1.500", "MISSES"],
    ]
    floor_64 = next(line for line in lines if line.split()[:2] == ["vector_over_fetch_floor", "64"])
    assert floor_64.endswith("(target at 16 only)")


def test_the_hall_cache_is_keyed_by_the_generators_source(tmp_path, monkeypatch):
    """A changed generator makes its halls anew, in a folder of their own; the same one reuses them."""
    import factory_scenes.generator as generator

    made = []

    def generate(preset, outdir, seed=0, target_triangles=None, progress=True):
        outdir.mkdir(parents=True)
        made.append(outdir)
        (outdir / "scene.toml").write_text(f"# hall {len(made)}\n")
        return outdir / "scene.toml"

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    shipped = bench_scenes.HallGenerator(generate, Path(generator.__file__).parent)
    first = bench_scenes.hall_scene_path(shipped, 1000)
    assert bench_scenes.hall_scene_path(shipped, 1000) == first and len(made) == 1
    assert first.parent.name == f"hall_1000_seed0_{shipped.digest()}"
    source = tmp_path / "generator"
    source.mkdir()
    (source / "__init__.py").write_text("PRESETS = {}\n")
    other = bench_scenes.HallGenerator(generate, source)
    before = other.digest()
    (source / "layout.py").write_text("AISLE_M = 3.5\n")  # the generator changes
    assert other.digest() != before
    second = bench_scenes.hall_scene_path(other, 1000)
    assert second != first and len(made) == 2 and second.read_text() == "# hall 2\n" and first.exists()


def test_the_stand_in_for_a_missing_sample_cell_has_a_label_of_its_own(tmp_path, monkeypatch):
    """Else its AO passes would be divided by the height-field section's floor (same label)."""
    monkeypatch.setattr(bench_scenes, "sample_scene_path", lambda: tmp_path / "missing.toml")
    scene, camera_for, label = bench_scenes.sample_scene()
    assert label != scene.name == bench_scenes.terrain_scene(bench_figures.TRIANGLE_COUNTS[0]).name
    assert camera_for((1280, 1024)).width == 1280


def test_a_hung_peer_holds_the_bench_up_two_minutes_at_most():
    assert inspect.signature(PeerWorker.wait_ready).parameters["timeout"].default == bench_peers.START_TIMEOUT_S <= 120
    assert inspect.signature(PeerWorker.frame).parameters["timeout"].default == bench_peers.FRAME_TIMEOUT_S <= 60


def test_bench_help_says_what_quick_leaves_out_and_where_files_go(capsys):
    assert main(["bench", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for said in (
        "1024x768 figures",
        "36- and 128-sample counts",
        "10 M-triangle hall",
        "3 rounds instead of 5",
        "missing folders are created, an existing file is replaced",
        "mrcheck-bench/",
        "mrcheck-bench-peers/",
        "replaced by each run",
    ):
        assert said in text


def _touched(megabytes: int) -> mmap.mmap:
    """Memory the process surely holds: an anonymous mapping of its own, every page written. (Not
    np.ones: after a large free, glibc serves the next allocation from pages it still holds, and
    the resident size need not grow.)"""
    buf = mmap.mmap(-1, megabytes * 2**20)
    np.frombuffer(buf, np.uint8)[:] = 1
    return buf


def test_peak_memory_is_reset_before_an_entry():
    """The peak after a reset is that of what follows, not of what came before it."""
    before = _touched(200)
    high = bench_peers.peak_rss_mb()
    before.close()
    if not bench_peers.reset_peak_rss():
        pytest.skip("/proc/self/clear_refs cannot be written here")
    floor = bench_peers.peak_rss_mb()  # the peak now is what the process holds now
    assert floor < high - 150
    after = _touched(100)
    # measured from the reset, not from ``high``: an earlier test may have left a higher peak than
    # this one made, and the process may hold less now than it did then
    assert bench_peers.peak_rss_mb() > floor + 90
    after.close()


@pytest.mark.slow
def test_bench_writes_the_json_before_printing(quick, tmp_path, monkeypatch):
    """A reader that goes away (`mrcheck bench --json X | head`) costs the printout, not the run."""
    report, _ = quick
    measured = _figures(report)
    monkeypatch.setattr(
        bench,
        "measure_plan",
        lambda quick, repeat, hall, progress: (measured, report["machine"], {}, {"peak_rss_mb": 1.0}),
    )
    monkeypatch.setattr(bench, "scan_reading", lambda quick, repeat: ([], []))  # nor the scan reads
    monkeypatch.setattr(bench, "import_figures", lambda quick, hall: None)  # nor the imports

    class Closed(io.StringIO):
        def write(self, text):
            raise BrokenPipeError("the reader went away")

    out = tmp_path / "new" / "bench.json"
    with contextlib.redirect_stdout(Closed()):
        assert main(["bench", "--json", str(out)]) == 1
    assert json.loads(out.read_text())["figures"] == report["figures"]


# -- peers: the report contract, without timing anything heavy ----------------------------------
VIEW = {"eye": (3.0, -4.0, 3.0), "target": (0.0, 0.0, 0.3), "up": (0.0, 0.0, 1.0), "fov_y_deg": 50.0}


def _box_on_floor():
    return scene_of(box((10.0, 10.0, 0.2), (0.0, 0.0, -0.1)), box((1.0, 1.0, 1.0), (0.0, 0.0, 0.5)))


def _fake_worker(tmp_path, body: str) -> list:
    """A stand-in worker process (a short Python script) for the protocol's failure cases."""
    script = tmp_path / "fake_worker.py"
    script.write_text(textwrap.dedent(body))
    return [sys.executable, str(script)]


READY = (
    'print(json.dumps({"ready": True, "version": "fake 1", "settings": {}, "png": "x.png", '
    '"ao_effect": {}, "setup_ms": 1.0}), flush=True)'
)


def test_peer_not_installed_gives_its_reason(tmp_path, monkeypatch):
    monkeypatch.setattr(bench_client, "importable", lambda peer: f"not installed: {peer} (test)")
    reasons = {}
    assert bench_line.start_peers(None, _box_on_floor(), VIEW, reasons, tmp_path) == []
    assert reasons == {"vtk": "not installed: vtk (test)", "open3d": "not installed: open3d (test)"}
    assert not list(tmp_path.glob("*.npz"))  # the mesh file is gone once the workers have started


def test_peer_worker_that_dies_at_start_gives_a_one_line_reason(tmp_path, monkeypatch):
    command = _fake_worker(
        tmp_path,
        """
        import sys
        sys.stderr.write("loading the peer\\nvkCreateInstance failed: no Vulkan driver\\n")
        sys.exit(3)
    """,
    )

    class Crashing(PeerWorker):
        def __init__(self, peer, mesh, png):
            super().__init__(peer, mesh, png, command=command)

    monkeypatch.setattr(bench_client, "importable", lambda peer: None)
    monkeypatch.setattr(bench_client, "PeerWorker", Crashing)
    reasons = {}
    assert bench_line.start_peers(None, _box_on_floor(), VIEW, reasons, tmp_path) == []
    for peer in ("vtk", "open3d"):
        assert "exit code 3" in reasons[peer] and "no Vulkan driver" in reasons[peer]
        assert "\n" not in reasons[peer]


@pytest.mark.slow
def test_peer_error_answer_and_garbage_are_reasons(tmp_path):
    error = PeerWorker(
        "vtk",
        tmp_path / "m.npz",
        tmp_path / "vtk.png",
        command=_fake_worker(
            tmp_path,
            """
        import json
        print(json.dumps({"error": "ImportError: libvulkan.so.1"}), flush=True)
    """,
        ),
    ).start()
    with pytest.raises(PeerError, match="libvulkan"):
        error.wait_ready(timeout=60)
    garbage = PeerWorker(
        "vtk",
        tmp_path / "m.npz",
        tmp_path / "vtk2.png",
        command=[sys.executable, "-c", "print('FEngine created'); import time; time.sleep(60)"],
    )
    with pytest.raises(PeerError, match="answered"):
        garbage.start().wait_ready(timeout=60)
    silent = PeerWorker(
        "vtk", tmp_path / "m.npz", tmp_path / "vtk3.png", command=[sys.executable, "-c", "import time; time.sleep(60)"]
    )
    with pytest.raises(PeerError, match="no answer within"):
        silent.start().wait_ready(timeout=1)
    assert error.proc is None and garbage.proc is None and silent.proc is None  # stopped, not left running


def test_peer_worker_that_crashes_mid_run_gives_null_and_reason(ctx, tmp_path):
    """A worker that segfaults on its second frame: the bench goes on, the peer has no figure,
    its ratio is null and its reason names the crash."""
    command = _fake_worker(
        tmp_path,
        f"""
        import json, os, signal, sys
        {READY}
        for n, line in enumerate(sys.stdin):
            if n == 1:
                sys.stderr.write("Segmentation fault in the driver\\n"); sys.stderr.flush()
                os.kill(os.getpid(), signal.SIGSEGV)
            print(json.dumps({{"ms": 5.0}}), flush=True)
    """,
    )
    worker = PeerWorker("vtk", tmp_path / "m.npz", tmp_path / "vtk.png", command=command).start()
    worker.wait_ready(timeout=60)
    reasons = {}
    peer = bench_line.PeerStage(ctx, worker, reasons)

    class Ours:  # a stand-in for mrcheck's frame
        def __init__(self):
            self.ctx = ctx

        def timed(self, work):
            work()
            return 10.0

    ours = bench.Figure("frame", "vector", *bench_figures.PEER_SIZE, bench_figures.PEER_SAMPLES, 1.0, "fake", 1)
    theirs = bench.Figure("frame", "vtk", *bench_figures.PEER_SIZE, None, None, "fake", 1)
    entry = [
        (Ours(), bench_timing.Job(ours, lambda: None, lambda: None)),
        (peer, bench_timing.Job(theirs, lambda: None, lambda: None)),
    ]
    figures = bench_timing.measure(entry, repeat=3)
    assert figures == [ours] and ours.times_ms == [10.0] * 3
    assert "exit code -11" in reasons["vtk"] and "Segmentation fault" in reasons["vtk"]
    peer.release()
    assert worker.proc is None
    hits = [f for f in figures if f.mode == "vtk"]
    assert not hits  # so _ratios reports vtk_over_mrcheck_frame as None


@pytest.mark.slow
def test_a_peer_that_cannot_be_imported_is_not_installed_one_that_breaks_fails(tmp_path, monkeypatch):
    """The real worker with stand-ins for pyvista and vtk first ahead on the path: one whose
    import fails (a shared library missing) is not installed; one that imports but is broken
    is a failure, not a reason to skip."""
    mesh = bench_client.write_mesh(
        tmp_path / "mesh.npz", *bench_scenes.flattened_mesh(_box_on_floor()), VIEW, (160, 120)
    )
    for case, body in (("missing", "raise ImportError('libGL.so.1: cannot open shared object file')"), ("broken", "")):
        (tmp_path / case).mkdir()
        for package in ("pyvista", "vtk"):
            (tmp_path / case / f"{package}.py").write_text(body)
    monkeypatch.setenv("PYTHONPATH", str(tmp_path / "missing"))
    with pytest.raises(PeerNotInstalled, match="^not installed: vtk cannot be imported: ImportError: libGL"):
        PeerWorker("vtk", mesh, tmp_path / "vtk.png").start().wait_ready(timeout=60)
    monkeypatch.setenv("PYTHONPATH", str(tmp_path / "broken"))
    with pytest.raises(PeerError, match="AttributeError") as failed:
        PeerWorker("vtk", mesh, tmp_path / "vtk.png").start().wait_ready(timeout=60)
    assert not isinstance(failed.value, PeerNotInstalled)


@pytest.mark.parametrize("peer", bench_peers.PEERS)
def test_peer_worker_renders_with_ao_on(tmp_path, peer):
    """The real worker on a box on a floor: the protocol, the settings it reports, and that its AO
    changes the image (no timing asserted). Skipped only when the peer is not installed here:
    a peer that is installed and fails, fails the test."""
    if why := bench_client.importable(peer):
        pytest.skip(why)
    scene = _box_on_floor()
    mesh = bench_client.write_mesh(tmp_path / "mesh.npz", *bench_scenes.flattened_mesh(scene), VIEW, (160, 120))
    worker = PeerWorker(peer, mesh, tmp_path / f"{peer}.png").start()
    try:
        info = worker.wait_ready()
    except PeerNotInstalled as exc:  # its packages are there but cannot be imported
        pytest.skip(str(exc))
    try:
        assert worker.frame() > 0
        assert worker.frame() > 0
    finally:
        summary = worker.stop()
    assert summary["frames"] == 2 and summary["min_ms"] <= summary["median_ms"] <= summary["max_ms"]
    assert summary["peak_rss_mb"] == worker.peak_rss_mb > 50 and info["setup_peak_rss_mb"] > 50  # its own memory
    assert info["size"] == [160, 120] and info["version"]
    assert (tmp_path / f"{peer}.png").stat().st_size > 0 and (tmp_path / f"{peer}_ao_off.png").exists()
    assert info["ao_effect"]["mean_abs_levels"] > 0  # AO on changes the frame
    if peer == "vtk":
        assert info["settings"]["kernel_size"] == 32 and info["settings"]["msaa_samples"] == 0
    else:
        settings = info["settings"]
        assert settings["ambient_occlusion"] is True and settings["antialiasing"] is False
        assert settings["msaa_samples"] == 1 and settings["shadows"] is False  # what mrcheck renders too
    assert np.isfinite(info["setup_ms"])
