"""The numpy reader of binary PLY scans (mrcheck.scene.scans.ply): the same points as Open3D's
reader, the cases it leaves to Open3D, and truncated files refused."""

from pathlib import Path

import numpy as np
import open3d as o3d
import pytest

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.scans import read_scan
from mrcheck.scene.scans.ply import read_binary_ply


def _cloud(n=5000, seed=0, colours=True):
    rng = np.random.default_rng(seed)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(rng.uniform(-50, 50, (n, 3)) + [4.5e5, 5.4e6, 100.0]))
    if colours:
        cloud.colors = o3d.utility.Vector3dVector(rng.uniform(0, 1, (n, 3)))
        cloud.normals = o3d.utility.Vector3dVector(rng.normal(size=(n, 3)))
    return cloud


@pytest.mark.parametrize("colours", [False, True])
def test_same_points_as_open3d(tmp_path, colours):
    path = tmp_path / "scan.ply"
    assert o3d.io.write_point_cloud(str(path), _cloud(colours=colours))
    ours = read_binary_ply(path)
    assert ours is not None and ours.dtype == np.float64 and ours.shape == (5000, 3)
    assert np.array_equal(ours, np.asarray(o3d.io.read_point_cloud(str(path)).points))


def _write(path: Path, header: str, body: bytes) -> Path:
    path.write_bytes(header.encode("ascii") + body)
    return path


def test_float32_big_endian_with_extra_properties(tmp_path):
    rng = np.random.default_rng(1)
    rows = np.zeros(100, dtype=[("intensity", ">u2"), ("x", ">f4"), ("y", ">f4"), ("z", ">f4"), ("red", "u1")])
    for name in "xyz":
        rows[name] = rng.uniform(-10, 10, 100)
    header = (
        "ply\r\nformat binary_big_endian 1.0\r\ncomment made by hand\r\nelement vertex 100\r\n"
        "property ushort intensity\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
        "property uchar red\r\nelement face 0\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
    )
    points = read_binary_ply(_write(tmp_path / "scan.ply", header, rows.tobytes()))
    expected = np.column_stack([rows[n].astype(np.float64) for n in "xyz"])
    assert np.array_equal(points, expected)


@pytest.mark.parametrize(
    "header",
    [
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        "ply\nformat binary_little_endian 1.0\nelement face 0\nproperty list uchar int vertex_indices\n"
        "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n",
    ],
)
def test_other_cases_left_to_open3d(tmp_path, header):
    assert read_binary_ply(_write(tmp_path / "scan.ply", header, b"\0" * 12)) is None


def test_truncated_is_an_error(tmp_path):
    path = tmp_path / "scan.ply"
    assert o3d.io.write_point_cloud(str(path), _cloud(colours=False))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(MrcheckError, match="corrupt or truncated"):
        read_binary_ply(path)
    with pytest.raises(MrcheckError, match="corrupt or truncated"):
        read_scan(path)


def test_read_scan_in_millimetres(tmp_path):
    path = tmp_path / "scan.ply"
    cloud = _cloud(colours=False)
    assert o3d.io.write_point_cloud(str(path), cloud)
    assert np.array_equal(read_scan(path, "mm").points, np.asarray(cloud.points) * 0.001)
