"""Scans in E57 and LAS/LAZ (issue 19): every scan with its pose, colours at their bit depth,
intensity, the CRS, float64 coordinates at map coordinates through to the deviation, chunked
reads with progress, and the bad-input cases that concern scan files (one line naming the file,
exit 1, nothing written).

Real files written by other people's software are in tests/data/scans/formats (README there);
files with poses, many scans or map coordinates are written here with pye57 / laspy."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import laspy
import numpy as np
import pye57
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.errors import MrcheckError
from mrcheck.scene.scans import read_scan

from .conftest import box, scene_of

DATA = Path(__file__).parent / "data" / "scans" / "formats"
MAP = np.array([458658.78, 5438232.79, 113.7])  # UTM-like survey coordinates (issue 19)


def _rotation_z(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _write_e57(path: Path, scans) -> None:
    """An E57 of ``(points, rotation quaternion wxyz or None, translation or None, extra fields)``."""
    with pye57.E57(str(path), mode="w") as e57:
        for i, (points, q, t, extra) in enumerate(scans):
            data = {"cartesianX": points[:, 0], "cartesianY": points[:, 1], "cartesianZ": points[:, 2], **extra}
            e57.write_scan_raw(data, name=f"station {i}", rotation=q, translation=t)


def _write_las(path: Path, points: np.ndarray, scale=0.001, offset=(0.0, 0.0, 0.0), rgb=None) -> None:
    header = laspy.LasHeader(point_format=3 if rgb is not None else 0, version="1.2")
    header.scales, header.offsets = np.full(3, scale), np.asarray(offset, np.float64)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    if rgb is not None:
        las.red, las.green, las.blue = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    las.write(str(path))


# -- E57 -------------------------------------------------------------------------------------
def test_e57_scaled_integers_read_as_float64_metres():
    cloud = read_scan(DATA / "bunnyInt32.e57")
    assert cloud.points.dtype == np.float64 and len(cloud) == 30571
    np.testing.assert_allclose(cloud.points.min(axis=0), [-0.0947, 0.0400, -0.0619], atol=1e-4)
    np.testing.assert_allclose(cloud.points.max(axis=0), [0.0610, 0.1873, 0.0588], atol=1e-4)
    assert [(s.name, s.start, s.count) for s in cloud.scans] == [("bunny", 0, 30571)]
    assert cloud.colours is None and cloud.intensity is None


def test_e57_with_16_bit_colours_and_fields_pye57_refuses():
    path = DATA / "ColourRepresentation.e57"
    with pytest.raises(ValueError, match="Unsupported point fields"):  # what pye57 alone does
        pye57.E57(str(path)).read_scan_raw(0)
    with pytest.warns(Warning, match=r"skipped per-point fields.*las:pointSourceId.*returnCount.*returnIndex"):
        cloud = read_scan(path)
    assert len(cloud) == 153
    np.testing.assert_allclose(cloud.points.min(axis=0), -0.5, atol=1e-3)
    np.testing.assert_allclose(cloud.points.max(axis=0), 0.5, atol=1e-3)
    assert cloud.colours.dtype == np.uint16 and cloud.colours.max() == 65280  # not clipped to 8 bits
    assert len(np.unique(cloud.colours, axis=0)) > 2
    assert set(cloud.skipped_fields) == {"las:pointSourceId", "returnCount", "returnIndex"}


def test_e57_every_scan_with_its_pose_at_map_coordinates(tmp_path):
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-5, 5, (700, 3)), rng.uniform(-5, 5, (300, 3))
    half = np.radians(60) / 2  # 60 degrees about z as a unit quaternion
    q = np.array([np.cos(half), 0.0, 0.0, np.sin(half)])
    _write_e57(tmp_path / "two.e57", [(a, None, None, {}), (b, q, MAP, {})])
    cloud = read_scan(tmp_path / "two.e57")
    assert [(s.name, s.start, s.count) for s in cloud.scans] == [("station 0", 0, 700), ("station 1", 700, 300)]
    np.testing.assert_allclose(cloud.points[:700], a, atol=1e-9)
    want = b @ _rotation_z(60).T + MAP
    assert np.abs(cloud.points[700:] - want).max() < 1e-6  # float64: micrometres at 5e6 m
    np.testing.assert_allclose(cloud.scans[1].pose[:3, 3], MAP)
    # pye57's own reader, whole scans at once, agrees
    theirs = pye57.E57(str(tmp_path / "two.e57")).read_scan(1, ignore_missing_fields=True)
    np.testing.assert_allclose(
        np.stack([theirs[k] for k in ("cartesianX", "cartesianY", "cartesianZ")], 1), cloud.points[700:], atol=1e-6
    )


def test_e57_intensity_and_8_bit_colours_and_invalid_points(tmp_path):
    points = np.random.default_rng(2).uniform(0, 1, (50, 3))
    invalid = np.zeros(50, np.int8)
    invalid[[3, 7]] = 2
    extra = {
        "intensity": np.linspace(0.0, 4.0, 50),
        "colorRed": np.full(50, 255, np.uint8),
        "colorGreen": np.arange(50, dtype=np.uint8),
        "colorBlue": np.zeros(50, np.uint8),
        "cartesianInvalidState": invalid,
    }
    _write_e57(tmp_path / "c.e57", [(points, None, None, extra)])
    cloud = read_scan(tmp_path / "c.e57")
    keep = invalid == 0
    assert len(cloud) == 48
    np.testing.assert_allclose(cloud.points, points[keep])
    np.testing.assert_allclose(cloud.intensity, np.linspace(0.0, 1.0, 50)[keep], atol=1e-6)
    assert (cloud.colours[:, 0] == 65535).all() and (cloud.colours[:, 1] == np.arange(50)[keep] * 257).all()


# -- LAS / LAZ -------------------------------------------------------------------------------
def test_las_and_laz_give_the_same_points_and_16_bit_colours():
    las, laz = read_scan(DATA / "simple.las"), read_scan(DATA / "simple.laz")
    assert len(las) == len(laz) == 1065
    np.testing.assert_array_equal(las.points, laz.points)
    raw = laspy.read(str(DATA / "simple.las"))
    np.testing.assert_array_equal(las.points[:, 0], raw.X * 0.01)  # scale 0.01, offset 0
    # simple.las stores 8-bit colours in the 16-bit fields: read as 16-bit
    np.testing.assert_array_equal(las.colours[:, 0], np.asarray(raw.red) * 257)
    assert las.crs is None and las.units is None


def test_georeferenced_laz_reports_its_crs_and_feet():
    cloud = read_scan(DATA / "autzen_trim.laz")
    assert len(cloud) == 110000
    assert "Lambert_Conformal_Conic" in cloud.crs and cloud.units == "foot"
    raw = laspy.read(str(DATA / "autzen_trim.laz"))
    np.testing.assert_allclose(cloud.points[:, 1], np.asarray(raw.y) * 0.3048, rtol=0, atol=1e-9)
    # --units overrides the CRS's unit
    assert read_scan(DATA / "autzen_trim.laz", units="m").points[:, 1].max() == pytest.approx(849498, abs=1)


def test_las_at_map_coordinates_keeps_millimetres(tmp_path):
    grid = np.random.default_rng(3).integers(-50_000, 50_000, (2000, 3)) / 1000.0  # a 1 mm grid
    _write_las(tmp_path / "map.laz", grid + MAP, scale=0.001, offset=MAP.round())
    cloud = read_scan(tmp_path / "map.laz")
    assert np.abs(cloud.points - (grid + MAP)).max() < 1e-6
    assert np.abs(cloud.points.astype(np.float32) - (grid + MAP)).max() > 0.1  # what float32 would do


def test_chunked_reads_match_one_read_and_show_progress(monkeypatch):
    import mrcheck.scene.scans.e57 as e57_module
    import mrcheck.scene.scans.las as las_module

    whole_laz, whole_e57 = read_scan(DATA / "autzen_trim.laz"), read_scan(DATA / "bunnyInt32.e57")
    for module in (e57_module, las_module):
        monkeypatch.setattr(module, "CHUNK_POINTS", 4096)
    seen = []

    def progress(items, desc, unit):
        items = list(items)
        seen.append((desc, len(items)))
        yield from items

    np.testing.assert_array_equal(read_scan(DATA / "autzen_trim.laz", progress=progress).points, whole_laz.points)
    np.testing.assert_array_equal(read_scan(DATA / "bunnyInt32.e57", progress=progress).points, whole_e57.points)
    assert seen == [("reading autzen_trim.laz", 27), ("reading bunnyInt32.e57", 8)]


# -- scans and the scene in the same float64 coordinates -----------------------------------------
def test_deviation_of_a_laz_against_a_model_at_map_coordinates(tmp_path):
    from mrcheck.apps.deviation import deviation

    # a 2 m box at map coordinates; scan points on its top face and 3 mm above it, on a 1 mm grid
    scene = scene_of(box((2, 2, 2), (0, 0, 0)), offset=MAP)
    rng = np.random.default_rng(4)
    top = np.c_[rng.integers(-900, 900, (3000, 2)) / 1000.0, np.full(3000, 1.0)]
    lifted = top[:1000] + (0, 0, 0.003)
    _write_las(tmp_path / "scan.laz", np.concatenate([top, lifted]) + MAP, offset=MAP.round())
    points = read_scan(tmp_path / "scan.laz").points
    d = deviation(points, scene, tmp_path / "scan.laz").distances
    assert np.abs(d[:3000]).max() < 1e-4
    np.testing.assert_allclose(d[3000:], 0.003, atol=1e-4)


def test_deviation_command_reads_a_laz_and_reports_the_crs(tmp_path, capsys):
    # a block under the airborne scan, placed at its (feet -> metres) map coordinates by the manifest
    centre = read_scan(DATA / "autzen_trim.laz").points.mean(axis=0)
    trimesh.creation.box(extents=(400, 200, 60)).export(tmp_path / "block.stl")
    (tmp_path / "scene.toml").write_text(
        'format = 1\n[[parts]]\nname = "block"\nmesh = "block.stl"\n'
        f'units = "m"\ntranslate = {list(map(float, centre))}\n'
    )
    code = main(
        [
            "deviation",
            str(DATA / "autzen_trim.laz"),
            "--scene",
            str(tmp_path / "scene.toml"),
            "-o",
            str(tmp_path / "out"),
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    report = json.loads((tmp_path / "out" / "parts.json").read_text())
    assert report["crs"].startswith("NAD_1983_HARN") and report["units"] == "foot" and report["points"] == 110000


# -- bad input ---------------------------------------------------------------------------------
def _bad(tmp_path: Path, kind: str) -> Path:
    if kind == "e57 without points":
        with pye57.E57(str(tmp_path / "none.e57"), mode="w"):
            pass
        return tmp_path / "none.e57"
    if kind == "las without points":
        _write_las(tmp_path / "none.las", np.zeros((0, 3)))
        return tmp_path / "none.las"
    if kind == "truncated laz":
        data = (DATA / "autzen_trim.laz").read_bytes()
        (tmp_path / "cut.laz").write_bytes(data[: len(data) // 2])
        return tmp_path / "cut.laz"
    if kind == "truncated e57":
        data = (DATA / "bunnyInt32.e57").read_bytes()
        (tmp_path / "cut.e57").write_bytes(data[: len(data) // 2])
        return tmp_path / "cut.e57"
    source, name = {
        "las named .e57": ("simple.las", "scan.e57"),
        "e57 named .laz": ("bunnyInt32.e57", "scan.laz"),
        "e57 named .xyz": ("bunnyInt32.e57", "scan.xyz"),
        "las named .ply": ("simple.las", "scan.ply"),
    }[kind]
    shutil.copy(DATA / source, tmp_path / name)
    return tmp_path / name


BAD = [
    ("e57 without points", "scan has no points"),
    ("las without points", "scan has no points"),
    ("truncated laz", "truncated or corrupt LAS/LAZ: cannot read past point"),
    ("truncated e57", "cannot read scan"),
    ("las named .e57", "the file's content is LAS/LAZ, not E57 as its .e57 suffix says (rename it to .las or .laz)"),
    ("e57 named .laz", "the file's content is E57, not LAS/LAZ as its .laz suffix says (rename it to .e57)"),
    ("e57 named .xyz", "the file's content is E57, not text"),
    ("las named .ply", "the file's content is LAS/LAZ, not PLY"),
]


@pytest.mark.parametrize("kind, message", BAD, ids=[k for k, _ in BAD])
def test_bad_scan_files(tmp_path, capsys, kind, message):
    scan = _bad(tmp_path, kind)
    with pytest.raises(MrcheckError, match=message.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        read_scan(scan)
    box((1, 1, 1), (0, 0, 0)).export(tmp_path / "box.stl")
    code = main(["deviation", str(scan), "--scene", str(tmp_path / "box.stl"), "-o", str(tmp_path / "out")])
    out, err = capsys.readouterr()
    lines = [line for line in err.strip().splitlines() if not line.startswith("warning:")]
    assert code == 1 and len(lines) == 1 and lines[0].startswith(f"error: {scan}: ") and message in lines[0], err
    assert out == "" and not (tmp_path / "out").exists()


def test_laz_without_a_laz_backend(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(laspy.LazBackend, "detect_available", staticmethod(lambda: ()))
    with pytest.raises(MrcheckError, match="LAZ-compressed but no LAZ backend is installed"):
        read_scan(DATA / "simple.laz")
    assert len(read_scan(DATA / "simple.las")) == 1065  # an uncompressed LAS needs none


# -- the bench's scan figures ----------------------------------------------------------------------
@pytest.mark.slow
def test_bench_scan_figures_read_what_they_wrote(tmp_path):
    from mrcheck.eval.bench.scans import measure_scan_reading, scan_figures_text

    figures = measure_scan_reading(tmp_path, 60_000, 1)
    assert [(f.format, f.points) for f in figures] == [("laz", 60_000), ("e57", 60_000)]
    for f in figures:
        assert f.runs_s[0] > 0 and f.points_per_s == 60_000 / f.runs_s[0]
        assert f.result_mb == pytest.approx(60_000 * 34 / 2**20) and f.peak_rss_mb[0] > f.result_mb
    assert not list(tmp_path.iterdir())  # the synthetic scans are not kept
    assert "M points/s" in scan_figures_text(figures)[0]
