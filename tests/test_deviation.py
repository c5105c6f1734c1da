"""``mrcheck deviation``: a real scan against its mesh, a synthetic as-built scan, bad input, a shot.

The real data: one laser range scan of the Stanford bunny (bun000) and the reconstructed mesh,
which share a frame (tests/data/scans/bunny/README.md). The synthetic scan is sampled from an
as-built variant of the sample cell, whose discrepancies.json says what moved.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import open3d as o3d
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path
from mrcheck.scene.asbuilt import make_asbuilt
from mrcheck.scene.model import load_scene

from .mr_helpers import make_camera, render_photo

BUNNY = Path(__file__).parent / "data" / "scans" / "bunny"
SCAN, MESH = BUNNY / "bun000.ply", BUNNY / "bun_zipper_res3_from_opencv.ply"
NOISE = 0.002  # m, of the synthetic scan


def _run(capsys, *args):
    code = main(["deviation", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


def _bunny_points() -> np.ndarray:
    rows = [line.split() for line in SCAN.read_text().splitlines()]
    return np.array([r for r in rows if len(r) == 3], np.float64)


@pytest.mark.slow
def test_bunny_scan_against_its_mesh(tmp_path, capsys):
    out = tmp_path / "out"
    code, stdout, err = _run(capsys, SCAN, "--scene", MESH, "-o", out)
    assert code == 0, err
    report = json.loads((out / "parts.json").read_text())
    d = np.load(out / "deviations.npy")
    assert d.dtype == np.float32 and d.shape == (40256,)  # the range-grid lines are not points
    median = float(np.median(np.abs(d)))
    print(f"bunny bun000 vs mesh: median |d| {median * 1000:.3f} mm")
    assert 0.1e-3 < median < 0.6e-3  # the data's README: about 0.3 mm
    assert report["median_abs"] == pytest.approx(median, rel=1e-5)
    (part,) = report["parts"]
    assert part["points"] == 40256 and part["rank"] == 1
    for name in ("parts.md", "deviation_top.png", "deviation_side.png"):
        assert (out / name).is_file()
    assert "deviation_overlay.png" not in {p.name for p in out.iterdir()}


@pytest.fixture(scope="module")
def asbuilt_scan(tmp_path_factory):
    """A PLY scan (2 mm noise) sampled from every instance of an as-built sample cell, and its
    discrepancy list."""
    folder = tmp_path_factory.mktemp("asbuilt")
    make_asbuilt(sample_scene_path(), folder / "variant", seed=0)
    built = load_scene(folder / "variant" / "scene.toml")
    rng = np.random.default_rng(1)
    points = []
    for part in built.parts:
        mesh = trimesh.Trimesh(part.vertices.astype(np.float64), part.faces, process=False)
        for k, T in enumerate(part.transforms):
            area = mesh.area * abs(np.linalg.det(T[:3, :3])) ** (2.0 / 3.0)
            count = int(np.clip(area * 1000, 2000, 20000))  # small parts still get a few thousand
            local, _ = trimesh.sample.sample_surface(mesh, count, seed=int(rng.integers(1 << 31)))
            points.append(local @ T[:3, :3].T + T[:3, 3])
    points = np.concatenate(points)
    points += rng.normal(0.0, NOISE, points.shape)
    scan = folder / "scan.ply"
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    assert o3d.io.write_point_cloud(str(scan), cloud)  # binary PLY: the Open3D reader
    report = json.loads((folder / "variant" / "discrepancies.json").read_text())
    return scan, report, len(points)


@pytest.mark.slow
def test_synthetic_asbuilt_scan_finds_the_moved_parts(asbuilt_scan, tmp_path, capsys):
    scan, truth, count = asbuilt_scan
    assert 100_000 < count < 1_000_000
    out = tmp_path / "out"
    code, _, err = _run(capsys, scan, "--scene", sample_scene_path(), "-o", out)
    assert code == 0, err
    parts = json.loads((out / "parts.json").read_text())["parts"]
    by_id = {p["id"]: p for p in parts}
    assert np.load(out / "deviations.npy").shape == (count,)
    moved = [c["id"] for c in truth["discrepancies"] if c["kind"] == "moved" and c["magnitude"] >= 0.05]
    assert moved
    for ident in moved:
        row = by_id[ident]
        print(f"moved {ident}: rank {row['rank']}, median |d| {row['median_abs'] * 1000:.1f} mm")
        assert row["rank"] <= 5 or row["median_abs"] > 0.01
    changed = {c["id"] for c in truth["discrepancies"]}
    # the structure (floor, walls) is never changed, but the points of *added* objects standing on
    # the floor are closest to it: judge only the parts that can be judged
    structure = {e["part"] for e in truth["excluded_parts"]}
    unchanged = [p for p in parts if p["id"] not in changed and p["part"] not in structure and p["points"]]
    assert len(unchanged) > 40
    worst = max(p["median_abs"] for p in unchanged)
    print(f"unchanged instances: worst median |d| {worst * 1000:.2f} mm")
    assert worst < 0.005
    md = (out / "parts.md").read_text()
    assert md.count("\n| ") == len(parts) + 1 and moved[0] in md


@pytest.mark.slow
def test_units_option_scales_the_scan(tmp_path, capsys):
    scan = tmp_path / "bunny_mm.xyz"
    np.savetxt(scan, _bunny_points() * 1000.0)
    code, _, err = _run(capsys, scan, "--scene", MESH, "--units", "mm", "-o", tmp_path / "out")
    assert code == 0, err
    assert 0.1e-3 < json.loads((tmp_path / "out" / "parts.json").read_text())["median_abs"] < 0.6e-3


def _bad(tmp_path, kind) -> Path:
    path = tmp_path / "scan.xyz"
    if kind == "missing":
        return tmp_path / "nothing.xyz"
    if kind == "empty":
        path.write_text("")
    elif kind == "no points":
        path.write_text("# a comment\n0\n1 2\n")
    elif kind == "nan":
        points = _bunny_points()[:1000]
        points[10, 1] = np.nan
        np.savetxt(path, points)
    elif kind == "garbage":
        path.write_text("x y z\n1 2 3\n")
    elif kind == "unsupported":
        path = tmp_path / "scan.rcp"  # Autodesk ReCap: not read
        path.write_bytes(b"RCP")
    elif kind == "millimetres":
        np.savetxt(path, _bunny_points() * 1000.0)
    elif kind == "far":
        np.savetxt(path, _bunny_points() + [1000.0, 0.0, 0.0])
    elif kind in ("truncated ply", "truncated pcd"):
        # a binary file cut short: Open3D only prints a warning and returns the cloud, the
        # unread points left as garbage
        import open3d as o3d

        path = tmp_path / f"scan.{kind[-3:]}"
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(_bunny_points()))
        o3d.io.write_point_cloud(str(path), cloud, write_ascii=False)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2 + 3])
    return path


@pytest.mark.slow
@pytest.mark.parametrize(
    "kind, message",
    [
        ("missing", "scan file not found"),
        ("empty", "scan file is empty"),
        ("no points", "scan has no points"),
        ("nan", "1 points with NaN"),
        ("garbage", "not a text x y z point file"),
        ("unsupported", "unsupported scan format .rcp"),
        ("millimetres", "the scan looks like millimetres; pass --units mm"),
        ("far", "m away from the scene: wrong units or not registered"),
        ("truncated ply", "cannot read scan, corrupt or truncated"),
        ("truncated pcd", "cannot read scan, corrupt or truncated"),
    ],
)
def test_bad_scans(tmp_path, capsys, kind, message):
    out = tmp_path / "out"
    code, stdout, err = _run(capsys, _bad(tmp_path, kind), "--scene", MESH, "-o", out)
    assert code == 1
    lines = err.strip().splitlines()
    assert lines[-1].startswith("error: ") and message in lines[-1], err
    assert len([line for line in lines if not line.startswith("warning:")]) == 1
    assert not out.exists() and stdout == ""


def test_scan_in_the_box_but_off_the_surfaces(tmp_path, capsys):
    """A small cluster inside the scene's box, far from every surface compared with its size."""
    points = np.random.default_rng(0).normal(0.0, 0.001, (500, 3)) + [0.0, 3.0, 4.0]  # mid-air in the cell
    scan = tmp_path / "cluster.xyz"
    np.savetxt(scan, points)
    code, _, err = _run(capsys, scan, "--scene", sample_scene_path(), "-o", tmp_path / "out")
    assert code == 1 and "m away from the scene" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_shot_overlay_with_legend(ctx, asbuilt_scan, tmp_path, capsys):
    scan, _, count = asbuilt_scan
    scene = load_scene(sample_scene_path())
    vp = scene.viewpoints["overview"]
    camera = make_camera(320, 240, 260.0, dist=(-0.12, 0.02, 0.0, 0.0, 0.0), eye=vp["eye"], target=vp["target"])
    photo = render_photo(ctx, scene, camera)
    cv2.imwrite(str(tmp_path / "photo.png"), photo[..., ::-1])
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps({**camera.to_dict(), "photo": "photo.png"}))
    out = tmp_path / "out"
    code, _, err = _run(capsys, scan, "--scene", sample_scene_path(), "--shot", shot, "-o", out)
    assert code == 0, err
    for name in ("deviation_overlay.png", "deviation_render.png"):
        image = cv2.imread(str(out / name))[..., ::-1]
        assert image.shape[0] == 240 and image.shape[1] > 320  # the photo + the legend panel
        legend = image[:, 320:].reshape(-1, 3).astype(int)
        assert np.any((legend[:, 0] > 150) & (legend[:, 2] < 80))  # the red end of the bar
        assert np.any((legend[:, 2] > 150) & (legend[:, 0] < 80))  # the blue end
        assert np.any(np.abs(image[:, :320].astype(int) - photo).sum(axis=2) > 60)  # splats drawn


def test_shot_errors_come_first(tmp_path, capsys):
    code, _, err = _run(capsys, SCAN, "--scene", MESH, "--shot", tmp_path / "none.json", "-o", tmp_path / "out")
    assert code == 1 and "none.json" in err and not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_small_scan_close_to_the_scene_is_not_refused_as_unregistered(tmp_path, capsys):
    """The "not registered" check compared the median |d| with the scan's own diagonal only: one
    real bunny point 1.2 mm off the mesh (a diagonal of 0) was "0.00122 m away from the scene"."""
    one = tmp_path / "one.xyz"
    np.savetxt(one, _bunny_points()[:1])
    code, _, err = _run(capsys, one, "--scene", MESH, "-o", tmp_path / "out")
    assert code == 0, err
    d = np.load(tmp_path / "out" / "deviations.npy")
    assert d.shape == (1,) and 1.0e-3 < abs(d[0]) < 1.5e-3
    # a small patch (2 cm across) 10 cm above the sample cell's floor: a deviation, not a lost scan
    rng = np.random.default_rng(0)
    patch = np.column_stack((rng.uniform(-0.01, 0.01, (50, 2)) + [3.0, 5.0], np.full(50, 0.10)))
    scene = load_scene(sample_scene_path())
    from mrcheck.apps.deviation import signed_distances

    assert np.median(np.abs(signed_distances(scene, patch)[0])) > 0.06  # > twice its own diagonal
    np.savetxt(tmp_path / "patch.xyz", patch)
    code, _, err = _run(capsys, tmp_path / "patch.xyz", "--scene", sample_scene_path(), "-o", tmp_path / "out2")
    assert code == 0, err


@pytest.mark.slow
@pytest.mark.parametrize("separator", [",", ", ", ";"])
def test_xyz_with_commas_or_semicolons_reads_as_with_spaces(tmp_path, capsys, separator):
    """x,y,z lines (CloudCompare's ASCII export) were "lines with fewer than 3 values"."""
    points = _bunny_points()[:2000]
    path = tmp_path / "comma.xyz"
    np.savetxt(path, points, delimiter=separator, fmt="%.7g")
    code, _, err = _run(capsys, path, "--scene", MESH, "-o", tmp_path / "out")
    assert code == 0, err
    assert "warning" not in err
    assert np.load(tmp_path / "out" / "deviations.npy").shape == (2000,)


@pytest.mark.slow
def test_xyz_with_decimal_commas_is_refused_not_misread(tmp_path, capsys):
    path = tmp_path / "decimal.xyz"
    path.write_text("".join(f"{x:.4f};{y:.4f};{z:.4f}\n".replace(".", ",") for x, y, z in _bunny_points()[:100]))
    code, _, err = _run(capsys, path, "--scene", MESH, "-o", tmp_path / "out")
    assert code == 1 and err.strip().endswith("decimal commas are not supported)"), err
