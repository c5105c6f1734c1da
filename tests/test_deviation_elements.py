"""``mrcheck deviation --per-element``: the per-instance tolerance status on simulated scans of
shifted variants of the sample cell (mrcheck.eval.scansim), its pieces, and its outputs."""

from __future__ import annotations

import csv
import io
import json
import math
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mrcheck.apps.deviation.distances import closest_surface
from mrcheck.apps.deviation.elements import STATUSES, element_status, fit_offsets, grouped_quantile
from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval.deviation_eval import score_seed
from mrcheck.eval.scansim import clutter_parts, scanner_stations, shifted_variant, simulate_scan
from mrcheck.scene.model import Part, Scene, load_scene

from .test_bcf import validate_bcfzip


@pytest.fixture(scope="module")
def sample():
    return load_scene(sample_scene_path())


@pytest.fixture(scope="module")
def simulated(sample):
    """Seed 0: 30 % of the movable instances moved 5-50 mm, 12 clutter boxes, 4 stations."""
    variant, shifts = shifted_variant(sample, 0.3, 0.005, 0.05, 0)
    scanned = replace(variant, parts=variant.parts + clutter_parts(variant, 12, 0))
    stations = scanner_stations(scanned, 4, 0)
    return simulate_scan(scanned, stations, 300_000, 0), shifts


@pytest.mark.slow
def test_small_shifts_are_found_at_a_10_mm_tolerance(sample):
    """The issue's figure at test size, pooled over seeds 0 and 1 (the first two; docs/discrepancies.md
    has more): F1 >= 0.95 for 5-50 mm shifts at a 10 mm tolerance."""
    scores = [score_seed(sample, seed, tolerance_mm=10.0, rays=500_000) for seed in (0, 1)]
    tp, fp, fn = (sum(getattr(s, k) for s in scores) for k in ("tp", "fp", "fn"))
    assert tp + fn >= 20, "the variants must move elements beyond the tolerance"
    f1 = 2 * tp / (2 * tp + fp + fn)
    assert f1 >= 0.95, (f1, [s.misses for s in scores])


@pytest.mark.slow
def test_the_same_scan_gives_the_same_table_and_no_nan(sample, simulated):
    scan, _ = simulated
    runs = []
    for _ in range(2):
        surface = closest_surface(sample, scan.points, normals=True)
        runs.append(element_status(surface, sample, scan.points, 10.0, scanners=scan.stations))
    assert runs[0] == runs[1]
    for row in runs[0]:
        for value in (row.coverage, row.median_mm, row.p95_abs_mm, row.offset_norm_mm, row.residual_mm):
            assert value is None or math.isfinite(value)


def test_simulation_is_reproducible(sample):
    a = simulate_scan(sample, scanner_stations(sample, 2, 5), 20_000, 5)
    b = simulate_scan(sample, scanner_stations(sample, 2, 5), 20_000, 5)
    assert np.array_equal(a.points, b.points) and 2.0 <= min(a.noise_mm) and max(a.noise_mm) <= 5.0


def _box() -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], np.float32)
    f = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ],
        np.uint32,
    )
    return v, f


def test_offset_of_a_moved_box_and_no_data_for_an_unscanned_one():
    v, f = _box()
    T = np.stack([np.eye(4), np.eye(4)])
    T[1, :3, 3] = (5.0, 0.0, 0.0)
    scene = Scene("boxes", Path("boxes"), [Part("box", Path("box"), v, f, T)])
    rng = np.random.default_rng(1)
    # the first box's five open faces (not its bottom), moved by (+30, -15, 0) mm, 2 mm noise
    pts = rng.uniform(-0.5, 0.5, (6000, 3))
    face = rng.integers(0, 5, 6000)
    axis, side = np.array([0, 0, 1, 1, 2])[face], np.array([-0.5, 0.5, -0.5, 0.5, 0.5])[face]
    pts[np.arange(6000), axis] = side
    pts += (0.03, -0.015, 0.0) + rng.normal(0, 0.002, pts.shape)
    surface = closest_surface(scene, pts, normals=True)
    rows = element_status(surface, scene, pts, 10.0)
    moved, unscanned = rows
    assert moved.status == "out of tolerance" and unscanned.status == "not enough data"  # no scanner positions
    assert np.allclose(moved.offset_mm, (30.0, -15.0, 0.0), atol=1.5)
    assert unscanned.points == 0 and unscanned.median_mm is None and unscanned.offset_mm is None
    assert 0.7 < moved.coverage <= 1.0  # the bottom rests on nothing but is still "open": see docs


def _cubes(centres) -> Scene:
    v, f = _box()
    T = np.stack([np.eye(4)] * len(centres))
    T[:, :3, 3] = centres
    return Scene("cubes", Path("cubes"), [Part("cube", Path("cube"), v, f, T)])


def test_scanner_positions_tell_occluded_from_not_found():
    """Four 1 m cubes planned; the scanner (at their mid-height, the origin side) sees A and B;
    C stands right behind A; D is not built. With the scanner's position: A and B installed,
    C occluded (no evidence either way), D not found (its visible surface has no points);
    without it D has no data to tell (not enough data) and C, open to the outside, too."""
    planned = _cubes([(3.0, 0.0, 0.5), (0.0, 3.0, 0.5), (6.0, 0.0, 0.5), (0.0, -3.0, 0.5)])
    built = _cubes([(3.0, 0.0, 0.5), (0.0, 3.0, 0.5), (6.0, 0.0, 0.5)])
    station = np.array([[0.0, 0.0, 0.5]])
    scan = simulate_scan(built, station, 200_000, 0)
    surface = closest_surface(planned, scan.points, normals=True)
    a, b, c, d = element_status(surface, planned, scan.points, 10.0, scanners=station)
    assert (a.status, b.status, c.status, d.status) == ("installed", "installed", "occluded", "not found"), (
        a,
        b,
        c,
        d,
    )
    assert c.visible_samples == 0 and d.visible_samples > 0 and d.points < 20
    blind = [r.status for r in element_status(surface, planned, scan.points, 10.0)]
    assert blind[:2] == ["installed", "installed"] and blind[2:] == ["not enough data", "not enough data"], blind


@pytest.mark.slow
def test_the_cli_reads_the_scanner_position_from_the_e57_and_says_not_found_and_occluded(tmp_path, capsys):
    """The cubes above through ``mrcheck deviation --per-element`` with the scan in an E57 whose
    scan pose is the scanner's position: the same four statuses in elements.csv and the counts
    in the console line."""
    import pye57
    import trimesh

    centres = [(3.0, 0.0, 0.5), (0.0, 3.0, 0.5), (6.0, 0.0, 0.5), (0.0, -3.0, 0.5)]
    station = np.array([0.0, 0.0, 0.5])
    scan = simulate_scan(_cubes(centres[:3]), station[None], 200_000, 0)
    local = scan.points - station
    with pye57.E57(str(tmp_path / "scan.e57"), mode="w") as e57:
        data = {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]}
        e57.write_scan_raw(data, name="station 0", rotation=np.array([1.0, 0, 0, 0]), translation=station)
    trimesh.Trimesh(*_box(), process=False).export(tmp_path / "cube.ply")
    instances = ", ".join(f"{{ translate = [{x}, {y}, {z}] }}" for x, y, z in centres)
    manifest = 'format = 1\nname = "cubes"\n\n[[parts]]\nname = "cube"\nmesh = "cube.ply"\nunits = "m"\n'
    (tmp_path / "scene.toml").write_text(manifest + f"instances = [{instances}]\n")
    out = tmp_path / "out"
    args = ["deviation", str(tmp_path / "scan.e57"), "--scene", str(tmp_path / "scene.toml"), "--per-element"]
    assert main([*args, "--tolerance-mm", "10", "-o", str(out)]) == 0
    with open(out / "elements.csv", newline="") as f:
        statuses = [r["status"] for r in csv.DictReader(f)]
    assert statuses == ["installed", "installed", "occluded", "not found"], statuses
    assert "2 installed, 1 not found, 0 not enough data, 1 occluded" in capsys.readouterr().err


def test_unconstrained_direction_gets_no_offset():
    # points on planes facing +x only: y and z cannot be told, their components stay 0
    owner = np.zeros(100, np.int64)
    normal = np.tile([1.0, 0.0, 0.0], (100, 1)).astype(np.float32)
    t, _ = fit_offsets(owner, normal, np.full(100, 0.02), 1, 0.01)
    assert np.allclose(t[0], (0.02, 0.0, 0.0), atol=1e-6)


def test_points_without_a_finite_normal_constrain_nothing():
    # a scan point exactly at a mesh vertex of a degenerate face has a NaN normal: that instance's
    # normal matrix was NaN and eigh stopped with "Eigenvalues did not converge"
    owner = np.array([0, 0, 0, 1, 1, 1])
    normal = np.tile([1.0, 0.0, 0.0], (6, 1))
    normal[0] = np.nan
    d = np.full(6, 0.02)
    d[4] = np.nan
    t, r = fit_offsets(owner, normal, d, 2, 0.01)
    assert np.isfinite(t).all()
    assert np.isnan(r[[0, 4]]).all() and np.isfinite(r[[1, 2, 3, 5]]).all()
    all_nan = np.full((3, 3), np.nan)
    t, _ = fit_offsets(np.zeros(3, np.int64), all_nan, np.full(3, np.nan), 1, 0.01)
    assert np.array_equal(t, np.zeros((1, 3)))  # no data: no offset
    huge = np.full(3, 1e300)  # finite, but the normal matrix's sums overflow to inf
    with np.errstate(over="ignore", invalid="ignore"):
        t, _ = fit_offsets(np.zeros(3, np.int64), np.tile([1e200, 0.0, 0.0], (3, 1)), huge, 1, 0.01)
    assert np.isfinite(t).all()


def test_grouped_quantile_matches_numpy():
    rng = np.random.default_rng(3)
    owner = rng.integers(0, 5, 1000)
    values = rng.uniform(-0.1, 0.1, 1000)
    got = grouped_quantile(owner, values, 6, 0.5, 0.1)
    for k in range(5):
        mine = np.sort(values[owner == k])
        assert got[k] == pytest.approx(mine[(len(mine) - 1) // 2], abs=1e-9)
    assert np.isnan(got[5])


@pytest.mark.slow
def test_cli_writes_the_table_picture_and_bcf(sample, simulated, tmp_path, capsys):
    import open3d as o3d

    scan, shifts = simulated
    path = tmp_path / "scan.ply"
    o3d.io.write_point_cloud(str(path), o3d.geometry.PointCloud(o3d.utility.Vector3dVector(scan.points)))
    out = tmp_path / "out"
    code = main(
        [
            "deviation",
            str(path),
            "--scene",
            str(sample_scene_path()),
            "--per-element",
            "--tolerance-mm",
            "10",
            "-o",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert code == 0, err
    assert "out of tolerance" in err
    doc = json.loads((out / "elements.json").read_text())
    ids = [p.instance_ids[k] for p in sample.parts for k in range(len(p.transforms))]
    assert [e["id"] for e in doc["elements"]] == ids and doc["tolerance_mm"] == 10.0
    with open(out / "elements.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["id"] for r in rows] == ids and all(r["status"] in STATUSES for r in rows)
    out_ids = {r["id"] for r in rows if r["status"] == "out of tolerance"}
    moved = {s.id for s in shifts if math.hypot(*s.vector[:2]) > 0.012}  # clearly beyond 10 mm
    assert len(moved & out_ids) >= 0.8 * len(moved)
    from mrcheck.apps.bcf import read_bcf_bytes

    data = (out / "elements.bcfzip").read_bytes()
    assert validate_bcfzip(data)
    assert {t.components[0].tool_id for t in read_bcf_bytes(data)} == out_ids
    # the status picture once at the root, each topic a crop of it around its element
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        names = archive.namelist()
    assert [n for n in names if n.endswith(".jpg") and "/" not in n] == ["status.jpg"]
    assert sum(n.endswith("/snapshot.jpg") for n in names) == len(out_ids)
    import cv2

    picture = cv2.imread(str(out / "elements.png"))
    assert picture is not None and picture.shape[1] > 1024  # the view and the legend beside it
