"""The speed-ups of ``mrcheck deviation`` on 10 M points (docs/discrepancies.md, "Speed and
memory") give the same results as the straightforward code they replaced: the splat z-buffer,
closest points queried in Morton order, the per-column bounding box, and BCF snapshots stored
(not deflated a second time)."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from mrcheck.apps.bcf import BcfTopic, bcf_bytes, topic_guid
from mrcheck.apps.deviation.images import splat
from mrcheck.core.arrays import bounding_box
from mrcheck.scene.model import Scene, make_part
from mrcheck.scene.raycast import build_caster, coherent_order, triangle_soup

from .conftest import box


def _reference_splat(image, uv, depth, colours, radius):
    """Point by point, nearest wins, of equally near ones the first: what a z-buffer means."""
    h, w = image.shape[:2]
    best = np.full((h, w), np.inf)
    for i in range(len(depth)):
        u0, v0 = int(np.rint(uv[i, 0])), int(np.rint(uv[i, 1]))
        for v in range(max(v0 - radius, 0), min(v0 + radius + 1, h)):
            for u in range(max(u0 - radius, 0), min(u0 + radius + 1, w)):
                if depth[i] < best[v, u]:
                    best[v, u], image[v, u] = depth[i], colours[i]
    return image


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_splat_is_a_z_buffer(radius):
    rng = np.random.default_rng(radius)
    n, h, w = 3000, 23, 31
    uv = rng.uniform(-4, 35, (n, 2))
    depth = np.round(rng.normal(size=n), 1)  # many exact ties: the first point wins
    colours = rng.integers(0, 256, (n, 3)).astype(np.uint8)
    ours = splat(np.zeros((h, w, 3), np.uint8), uv, depth, colours, radius)
    assert np.array_equal(ours, _reference_splat(np.zeros((h, w, 3), np.uint8), uv, depth, colours, radius))


def test_splat_of_nothing_in_view_leaves_the_image():
    image = np.full((8, 8, 3), 7, np.uint8)
    splat(image, np.array([[-50.0, 3.0]]), np.array([1.0]), np.array([[255, 0, 0]], np.uint8))
    assert np.all(image == 7)


def _scene() -> Scene:
    parts = []
    for k, (size, at) in enumerate([((20, 20, 0.2), (0, 0, -0.6)), ((1, 1, 1), (0, 0, 0)), ((0.3, 2, 1.5), (3, 1, 0))]):
        mesh = box(size, at)
        parts.append(
            make_part(f"p{k}", "t", np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces), [np.eye(4)])
        )
    return Scene("t", "t", parts)


def test_closest_points_in_morton_order_are_the_unordered_answers():
    import open3d as o3d

    rng = np.random.default_rng(3)
    scene = _scene()
    points = rng.uniform(-6, 6, (20000, 3))
    caster = build_caster(scene, np.zeros(3))
    found = caster.closest_points(points)
    plain = o3d.t.geometry.RaycastingScene()
    plain.add_triangles(*(o3d.core.Tensor(a) for a in triangle_soup(scene, np.zeros(3))))
    direct = plain.compute_closest_points(o3d.core.Tensor(points.astype(np.float32)))
    assert np.array_equal(found.offset, points - direct["points"].numpy().astype(np.float64))
    assert np.array_equal(found.normal, direct["primitive_normals"].numpy().astype(np.float64))
    primitive = direct["primitive_ids"].numpy().astype(np.int64)
    assert np.array_equal(found.instance, np.searchsorted(caster.first, primitive, side="right") - 1)


def test_coherent_order_is_a_permutation_along_space():
    rng = np.random.default_rng(4)
    points = rng.uniform(0, 100, (50000, 3))
    order = coherent_order(points)
    assert np.array_equal(np.sort(order), np.arange(len(points)))
    step = np.linalg.norm(np.diff(points[order], axis=0), axis=1)
    assert np.median(step) < 0.1 * np.median(np.linalg.norm(np.diff(points, axis=0), axis=1))
    assert list(coherent_order(points[:1])) == [0] and len(coherent_order(points[:0])) == 0


def test_bounding_box_is_min_and_max():
    points = np.random.default_rng(5).normal(size=(1001, 3)) * [1, 1e3, 1e-3] + [4.5e5, 5.4e6, 0.0]
    lo, hi = bounding_box(points)
    assert np.array_equal(lo, points.min(axis=0)) and np.array_equal(hi, points.max(axis=0))


def test_bcf_snapshots_are_stored_and_the_xml_deflated():
    png = b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 40
    data = bcf_bytes(
        [
            BcfTopic(
                guid=topic_guid("speed", 1),
                title="t",
                components=[],
                snapshot_png=png,
                camera=None,
                viewpoint_guid="0b3c6a7e-5f0e-4f7e-9c53-1f0d3b9a7c11",
            )
        ]
    )
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        methods = {info.filename.rsplit("/", 1)[-1]: info.compress_type for info in archive.infolist()}
        assert archive.read(next(n for n in archive.namelist() if n.endswith("snapshot.png"))) == png
    assert methods["snapshot.png"] == zipfile.ZIP_STORED
    assert methods["markup.bcf"] == zipfile.ZIP_DEFLATED
