"""Scale and translation invariance, through real mesh files and manifests.

* The vector method's quasi-normalisation (paper section 3, NOTES 3) makes its AO the same
  for a scene in metres, in millimetres declared as such, and in millimetres with the unit
  forgotten (then the camera is in the same raw units), with unchanged parameters.
* Camera-relative rendering makes a scene 1e6 m from the origin render like one at the origin.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mrcheck.core.camera import Camera
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import load_scene

W, H = 256, 192
SETTINGS = RenderSettings(samples=16, blur=False, radius_px=8.0)


def _cell() -> trimesh.Trimesh:
    """A floor, a wall, crates and a pipe: creases and curvature, in metres."""
    T = trimesh.transformations.translation_matrix
    pieces = [
        trimesh.creation.box((12, 12, 0.2), T((0, 0, -0.1))),
        trimesh.creation.box((12, 0.3, 4), T((0, 4, 2))),
        trimesh.creation.box((1.2, 0.8, 1.0), T((-1, 2, 0.5))),
        trimesh.creation.box((0.6, 0.6, 0.6), T((-0.6, 2.1, 1.3))),
        trimesh.creation.box((0.5, 2.0, 2.5), T((2.0, 1.5, 1.25))),
        trimesh.creation.cylinder(
            0.15,
            10,
            sections=24,
            transform=T((0, 3.5, 3.0)) @ trimesh.transformations.rotation_matrix(np.pi / 2, (0, 1, 0)),
        ),
    ]
    return trimesh.util.concatenate(pieces)


def _write_obj(path, vertices, faces):
    # OBJ is text: coordinates keep all float64 digits (1e6 m + millimetres needs > 7 digits)
    with open(path, "w") as f:
        f.writelines(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in vertices)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)


def _manifest(folder, mesh, units=None, translate=None):
    lines = ["format = 1", "[[parts]]", 'name = "cell"', f'mesh = "{mesh}"']
    if units:
        lines.append(f'units = "{units}"')
    if translate is not None:
        lines.append(f"translate = [{', '.join(repr(float(v)) for v in translate)}]")
    path = folder / f"{mesh}.{units or 'raw'}.{'moved' if translate is not None else 'here'}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _camera(scale=1.0, offset=(0.0, 0.0, 0.0)) -> Camera:
    eye = np.array([-4.0, -5.0, 1.7]) * scale + offset
    target = np.array([0.0, 2.5, 0.8]) * scale + offset
    return Camera.from_look_at(eye, target, (0, 0, 1), 60, W, H)


def _render(ctx, manifest, camera, modes=("vector",)):
    results = Renderer(load_scene(manifest), ctx=ctx).render(camera, list(modes), SETTINGS, want_ao=True)
    return results


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("invariance")
    cell = _cell()
    v, f = np.asarray(cell.vertices), np.asarray(cell.faces)
    _write_obj(folder / "cell_m.obj", v, f)
    _write_obj(folder / "cell_mm.obj", v * 1000.0, f)
    _write_obj(folder / "cell_far.obj", v + np.array([1e6, 1e6, 0.0]), f)
    return folder


def test_vector_ao_is_the_same_in_metres_declared_mm_and_undeclared_mm(ctx, meshes):
    reference = _render(ctx, _manifest(meshes, "cell_m.obj", "m"), _camera())["vector"].ao
    declared = _render(ctx, _manifest(meshes, "cell_mm.obj", "mm"), _camera())["vector"].ao
    # the unit forgotten: the scene is 1000x larger in raw units, and so is the camera's pose
    undeclared = _render(ctx, _manifest(meshes, "cell_mm.obj"), _camera(scale=1000.0))["vector"].ao
    assert (reference < 0.9).mean() > 0.02  # there is AO to compare
    assert np.abs(declared - reference).mean() < 0.01
    assert np.abs(undeclared - reference).mean() < 0.01


def test_ssao_depends_on_the_unit_when_it_is_forgotten(ctx, meshes):
    # the contrast that motivates the normalisation: a world radius of 0.2 means 0.2 mm now
    reference = _render(ctx, _manifest(meshes, "cell_m.obj", "m"), _camera(), ["ssao"])["ssao"].ao
    undeclared = _render(ctx, _manifest(meshes, "cell_mm.obj"), _camera(scale=1000.0), ["ssao"])["ssao"].ao
    assert np.abs(undeclared - reference).mean() > 0.01


@pytest.mark.parametrize("how", ["manifest translate", "coordinates in the file"])
def test_translation_by_a_million_metres_changes_nothing(ctx, meshes, how):
    offset = np.array([1e6, 1e6, 0.0])
    here = _render(ctx, _manifest(meshes, "cell_m.obj", "m"), _camera(), ["phong", "vector", "ssao"])
    if how == "manifest translate":
        manifest = _manifest(meshes, "cell_m.obj", "m", translate=offset)
    else:
        manifest = _manifest(meshes, "cell_far.obj", "m")
    moved = _render(ctx, manifest, _camera(offset=offset), ["phong", "vector", "ssao"])
    for mode in ("vector", "ssao"):
        assert np.abs(moved[mode].ao - here[mode].ao).mean() < 0.005, mode
    for mode in ("phong", "vector", "ssao"):
        diff = np.abs(moved[mode].image.astype(float) - here[mode].image.astype(float)) / 255.0
        assert diff.mean() < 0.005, mode


def _terrain(n: int):
    """(vertices, faces) of an n x n grid of bumps, 2 n^2 triangles over 40 x 40 m, in metres."""
    x, y = np.meshgrid(np.linspace(-20, 20, n + 1), np.linspace(0, 40, n + 1))
    z = 0.3 * np.sin(x * 1.3) * np.cos(y * 0.9) + 0.2 * np.sin(x * 7.0 + y * 5.0)
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    i = np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]
    quads = np.stack([i, i + 1, i + n + 2, i + n + 1], axis=-1).reshape(-1, 4)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return vertices, faces


@pytest.mark.slow
def test_ten_million_triangles_far_from_the_origin_render_like_at_the_origin(ctx):
    from mrcheck.scene.model import Scene, make_part

    vertices, faces = _terrain(2237)  # 10.0 M triangles
    assert len(faces) >= 10_000_000
    offset = np.array([1e6, -2e6, 300.0])
    results = {}
    for name, shift in (("here", np.zeros(3)), ("far", offset)):
        # the far copy's coordinates themselves are at 1e6 m (float64), as a site CAD export would be
        part = make_part("terrain", "terrain", vertices + shift, faces, np.eye(4), units="m")
        renderer = Renderer(Scene(name, name, [part]), ctx=ctx)
        results[name] = renderer.render(_camera(offset=shift), ["vector"], SETTINGS, want_ao=True)["vector"]
        assert renderer.geometry.last_stats["triangles_drawn"] == len(faces)
        renderer.geometry.release()
    assert (results["here"].ao < 0.95).mean() > 0.01
    assert np.abs(results["far"].ao - results["here"].ao).mean() < 0.005
    assert np.abs(results["far"].image.astype(float) - results["here"].image.astype(float)).mean() / 255 < 0.005
