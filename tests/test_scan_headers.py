"""Scan headers as other writers make them: E57 header numbers as Integer, ScaledInteger or
Float nodes (E57 8.4 allows each wherever a number is stored: colour and intensity limits, the
pose), and a LAS header whose scale is 0 (every point at the offset), which is refused."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pye57
import pye57.e57
import pytest
from pye57 import libe57

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.scans import read_scan

SCALE = 1e-6  # of the ScaledInteger header numbers written here


class _HeaderNodes:
    """libe57 as pye57's writer sees it, but every header number (a FloatNode or IntegerNode
    made with a value only, as pye57 writes the header; the point prototype gives limits too)
    becomes a node of ``kind``: "scaled" (ScaledIntegerNode) or "integer" (IntegerNode where
    the value is whole)."""

    def __init__(self, kind: str):
        self.kind = kind

    def __getattr__(self, name):
        return getattr(libe57, name)

    def _header(self, image_file, value):
        if self.kind == "scaled":
            raw = int(round(float(value) / SCALE))
            return libe57.ScaledIntegerNode(image_file, raw, -(2**62), 2**62, SCALE, 0.0)
        if float(value) == int(value):
            return libe57.IntegerNode(image_file, int(value))
        return libe57.FloatNode(image_file, float(value))

    def FloatNode(self, image_file, value, *limits):  # noqa: N802 -- libe57's name
        return libe57.FloatNode(image_file, value, *limits) if limits else self._header(image_file, value)

    def IntegerNode(self, image_file, value, *limits):  # noqa: N802 -- libe57's name
        return libe57.IntegerNode(image_file, value, *limits) if limits else self._header(image_file, value)


def _write(path: Path, kind: str, monkeypatch) -> tuple[np.ndarray, np.ndarray]:
    """One scan with intensity, 8-bit colours and a pose (90 degrees about z, a translation),
    its header numbers as ``kind`` nodes; (points in the file's frame, intensity)."""
    rng = np.random.default_rng(3)
    points = rng.uniform(0, 2, (40, 3))
    data = {
        "cartesianX": points[:, 0],
        "cartesianY": points[:, 1],
        "cartesianZ": points[:, 2],
        "intensity": np.linspace(0.0, 8.0, 40),
        "colorRed": np.full(40, 255, np.uint8),
        "colorGreen": np.arange(40, dtype=np.uint8),
        "colorBlue": np.zeros(40, np.uint8),
    }
    half = np.radians(90) / 2
    with monkeypatch.context() as patch:
        patch.setattr(pye57.e57, "libe57", _HeaderNodes(kind))
        with pye57.E57(str(path), mode="w") as e57:
            e57.write_scan_raw(
                data,
                name="station",
                rotation=np.array([np.cos(half), 0, 0, np.sin(half)]),
                translation=np.array([10.0, 20.0, 3.0]),
            )
    turned = np.stack([-points[:, 1], points[:, 0], points[:, 2]], axis=1) + [10, 20, 3]
    return turned, data["intensity"]


def _node_type(path: Path, *names) -> str:
    e57 = pye57.E57(str(path))
    node = e57.data3d[0]
    for name in names:
        node = node[name]
    return type(node).__name__


@pytest.mark.parametrize("kind, node", [("scaled", "ScaledIntegerNode"), ("integer", "IntegerNode")])
def test_e57_header_numbers_of_every_node_type(tmp_path, monkeypatch, kind, node):
    path = tmp_path / f"{kind}.e57"
    want, intensity = _write(path, kind, monkeypatch)
    assert _node_type(path, "colorLimits", "colorRedMaximum") == node  # the file is written that way
    assert _node_type(path, "intensityLimits", "intensityMaximum") == node
    cloud = read_scan(path)
    np.testing.assert_allclose(cloud.points, want, atol=1e-5)
    np.testing.assert_allclose(cloud.intensity, intensity / 8.0, atol=1e-5)
    assert (cloud.colours[:, 0] == 65535).all() and (cloud.colours[:, 1] == np.arange(40) * 257).all()


def test_e57_pose_as_scaled_integers(tmp_path, monkeypatch):
    path = tmp_path / "pose.e57"
    want, _ = _write(path, "scaled", monkeypatch)
    assert _node_type(path, "pose", "translation", "x") == "ScaledIntegerNode"
    cloud = read_scan(path)
    np.testing.assert_allclose(cloud.scans[0].pose[:3, 3], [10, 20, 3], atol=1e-6)
    np.testing.assert_allclose(cloud.points, want, atol=1e-5)


def _las(path: Path, scale) -> Path:
    header = laspy.LasHeader(point_format=0, version="1.2")
    header.offsets = np.zeros(3)
    header.scales = np.asarray(scale, np.float64)
    las = laspy.LasData(header)
    las.X, las.Y, las.Z = np.arange(5), np.arange(5) * 2, np.arange(5) * 3  # the integer records
    las.write(str(path))
    return path


@pytest.mark.parametrize("scale", [(0.0, 0.001, 0.001), (0.001, 0.001, 0.0), (0.001, float("nan"), 0.001)])
def test_las_with_a_zero_or_not_finite_scale_is_refused(tmp_path, scale):
    path = _las(tmp_path / "flat.las", scale)
    with pytest.raises(MrcheckError, match=r"flat\.las.*scale") as caught:
        read_scan(path)
    assert "\n" not in str(caught.value)


def test_las_with_a_negative_scale_still_reads(tmp_path):
    # a negative scale mirrors an axis: unusual but a real coordinate, not a collapse
    cloud = read_scan(_las(tmp_path / "mirror.las", (-0.5, 1.0, 1.0)))
    np.testing.assert_allclose(cloud.points[:, 0], -0.5 * np.arange(5))


def test_deviation_refuses_a_las_with_scale_zero(tmp_path, capsys):
    import trimesh

    from mrcheck.cli import main

    scan = _las(tmp_path / "flat.las", (0.0, 0.0, 0.0))
    trimesh.creation.box(extents=(1, 1, 1)).export(tmp_path / "box.stl")
    code = main(["deviation", str(scan), "--scene", str(tmp_path / "box.stl"), "-o", str(tmp_path / "out")])
    out, err = capsys.readouterr()
    lines = [line for line in err.strip().splitlines() if not line.startswith("warning:")]
    assert code == 1 and len(lines) == 1 and lines[0].startswith(f"error: {scan}: LAS header has an unusable scale")
    assert "median" not in out + err and not (tmp_path / "out").exists()
