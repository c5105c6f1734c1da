"""The edge registration's sample selection and coarse stage (issue 20): which
CAD edges a photo can show (:func:`mrcheck.mr.edges.model.salient`), the oriented chamfer map
and the search over the view direction (:mod:`mrcheck.mr.edges.chamfer`), and the outermost
edge for contours (:func:`mrcheck.mr.edges.photo.search`)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.mr.edges import chamfer, model, photo, search, solver
from mrcheck.mr.edges.fitter import render_depth
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import Scene, make_part


def _scene(*boxes):
    parts = []
    for name, extents, centre in boxes:
        mesh = trimesh.creation.box(extents=extents)
        T = np.eye(4)
        T[:3, 3] = centre
        parts.append(
            make_part(
                name, Path(name), np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces), T[None], units="m"
            )
        )
    return Scene("s", Path("s"), parts)


def _salient_share(scene, camera):
    """Per instance: the share of its visible edge samples that :func:`model.salient` keeps."""
    edges = model.scene_edges(scene)
    renderer = Renderer(scene)
    try:
        depth, normals = render_depth(renderer, camera, with_normals=True)
    finally:
        renderer.release()
    samples = model.sample_edges(edges, camera, 1.0)
    samples = model.subset(samples, model.visible(samples, camera, depth))
    uv, n, local = model.pinhole_samples(camera, samples, depth.shape)
    keep, outside = model.salient(uv, n, local, depth, normals, camera.K)
    return {name: float(keep[samples.group == g].mean()) for g, name in enumerate(edges.group_names)}, keep, outside


def test_wires_are_not_salient_and_a_crate_is():
    """A 5 mm wire 4 m away (under a pixel wide: a photo blurs it away) gives no sample; a crate's
    outline and creases do. Before, every visible mesh edge was a candidate (the generated
    cell's fence wires took most of the samples and the fit followed them)."""
    scene = _scene(("crate", (1.0, 0.8, 0.8), (0, 0, 0.4)), ("wire", (3.0, 0.005, 0.005), (0, -0.8, 1.2)))
    camera = Camera.from_look_at([1.5, -4.0, 2.0], [0, 0, 0.4], [0, 0, 1], 45.0, 320, 240)
    share, keep, outside = _salient_share(scene, camera)
    assert share["wire"] == 0.0, share
    assert share["crate"] > 0.5, share
    # the outline's samples know their background side; creases are 0
    assert np.any(outside[keep] != 0) and np.any(outside[keep] == 0)


def test_a_column_just_before_a_wall_is_a_contour():
    """A 40 cm column 20 cm before a wall 12 m away: its sides are contours (a depth jump of under
    2 %, which a relative depth threshold missed; the plane test sees it)."""
    scene = _scene(("wall", (8.0, 0.2, 4.0), (0, 0.3, 2.0)), ("column", (0.4, 0.4, 4.0), (0, 0.0, 2.0)))
    camera = Camera.from_look_at([0.0, -12.0, 2.0], [0, 0, 2.0], [0, 0, 1], 40.0, 640, 480)
    share, _, _ = _salient_share(scene, camera)
    assert share["column"] > 0.5, share


def _square_photo(shift=(0.0, 0.0)):
    image = np.full((120, 160), 0.3, np.float32)
    x0, y0 = 50 + shift[0], 40 + shift[1]
    cv2.rectangle(image, (int(x0), int(y0)), (int(x0) + 50, int(y0) + 40), 0.8, -1)
    return image


class _Square:
    """What :func:`search.search_pose` needs of a fit: a square's edge samples 5 m ahead of a
    160x120 camera, and the start pose."""

    def __init__(self):
        self.camera = Camera.from_look_at([0.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0, 0, 1], 50.0, 160, 120)
        corners = np.array([[-0.8, 5.0, -0.6], [0.8, 5.0, -0.6], [0.8, 5.0, 0.6], [-0.8, 5.0, 0.6]])
        t = np.linspace(0, 1, 40, endpoint=False)[:, None]
        sides = [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        points = np.vstack([a + t * (b - a) for a, b in sides])
        tangents = np.vstack([np.tile((b - a) / np.linalg.norm(b - a), (40, 1)) for a, b in sides])
        n = len(points)
        self.samples = model.Samples(points, tangents, np.zeros(n, np.int64), np.repeat(np.arange(4), 40))
        self.state = solver.PoseState.of(self.camera, corners.mean(axis=0))


@pytest.mark.slow
def test_the_pose_search_finds_a_square_moved_by_twelve_pixels():
    """The photo shows the square 12 px right and 5 px up of where the start pose puts it: the
    search moves the pose so that the samples land within a pixel of the photo's square."""
    square = _Square()
    uv = square.camera.project(square.samples.points)
    lo, hi = uv.min(axis=0) + (12, -5), uv.max(axis=0) + (12, -5)
    image = np.full((120, 160), 0.3, np.float32)
    cv2.rectangle(image, tuple(np.rint(lo).astype(int)), tuple(np.rint(hi).astype(int)), 0.8, -1)
    report = search.search_pose(square.state, square.camera, square.samples, chamfer.chamfer_map(image, 1.0), 24.0)
    moved = report.pose.camera(square.camera).project(square.samples.points) - uv
    assert np.allclose(np.median(moved, axis=0), (12, -5), atol=1.0), np.median(moved, axis=0)
    assert report.cost < 1.0 < report.start_cost and abs(report.moved_px - 13.0) < 1.5


@pytest.mark.slow
def test_the_pose_search_offers_distinct_alternates_of_another_basin():
    """Two squares side by side in the photo, 30 px apart: the search takes one and offers the
    other basin as an alternate, each at least 2 px of median motion from the choice and from
    each other, and polished onto a square (exact chamfer cost near 0)."""
    square = _Square()
    uv = square.camera.project(square.samples.points)
    image = np.full((120, 160), 0.3, np.float32)
    for dx in (-15, 15):
        lo, hi = uv.min(axis=0) + (dx, 0), uv.max(axis=0) + (dx, 0)
        cv2.rectangle(image, tuple(np.rint(lo).astype(int)), tuple(np.rint(hi).astype(int)), 0.8, -1)
    cmap = chamfer.chamfer_map(image, 1.0)
    report = search.search_pose(square.state, square.camera, square.samples, cmap, 40.0)
    poses = [report.pose, *report.alternates()]
    assert 1 <= len(report.alternates()) <= search.POLISHED
    shifts = [np.median(p.camera(square.camera).project(square.samples.points) - uv, axis=0) for p in poses]
    for i in range(len(shifts)):
        for j in range(i):
            assert np.linalg.norm(shifts[i] - shifts[j]) >= 2.0, shifts
    assert any(abs(s[0] + 15) < 1.5 for s in shifts) and any(abs(s[0] - 15) < 1.5 for s in shifts), shifts


def test_the_search_level_is_the_one_about_320_px_wide_but_not_the_finest():
    assert search.search_level([640, 320, 160]) == 1
    assert search.search_level([1280, 640, 320, 160]) == 2
    assert search.search_level([320, 160]) == 1  # the fine stage needs a coarser level
    assert search.search_level([200]) == 0


def test_a_contour_takes_the_outermost_strong_edge():
    """A bright object with a dark printed border 4 px inside its outline: the outline's sample
    (background to the right, +x) takes the outline at x = 100, not the nearer print at 96; a
    crease (outside 0) keeps the nearest."""
    image = np.full((60, 200), 0.2, np.float32)
    image[:, :100] = 0.8
    image[:, 95:97] = 0.3  # the print
    level = photo.pyramid(image, 1)[0]
    uv = np.array([[96.5, 30.0], [96.5, 30.0]])
    normals = np.array([[1.0, 0.0], [1.0, 0.0]])
    found = photo.search(level, uv, normals, 8, outside=np.array([1.0, 0.0]))
    assert abs(uv[0, 0] + found.offset[0] - 99.5) < 0.6, found.offset
    assert abs(found.offset[1]) < 1.5, found.offset
