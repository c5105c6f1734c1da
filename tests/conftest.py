"""Shared fixtures: one headless GL context per test session, and small scene builders.

Which tests are marked ``slow`` (left out of the fast loop, ``./bootstrap.sh test -m "not slow"``;
CI runs them all): a test is slow when one of its cases takes 1 s or more here (set-up, call and
tear-down, in a full run with ``--durations=0`` on the 2-core machine under its usual load), and
so is every test of a module fixture that takes that long (the fixture's set-up would otherwise
move to the next test). That takes in the browser tests, the ones that run the command line or
workers in subprocesses, and the multi-seed evaluations. A whole module that is slow says so
with ``pytestmark = pytest.mark.slow``. A new test over 1 s gets the mark; every run prints the
15 slowest (``--durations=15``) to show which.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mrcheck.render.gl import create_context
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, make_part


@pytest.fixture(scope="session", autouse=True)
def lod_cache(tmp_path_factory):
    """Levels of detail are cached on disk: in a fresh folder per session, never the user's."""
    folder = tmp_path_factory.mktemp("lod-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MRCHECK_CACHE_DIR", str(folder))
        yield folder


@pytest.fixture(scope="session")
def ctx():
    context = create_context()
    yield context
    context.release()


def box(size, centre) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=size, transform=trimesh.transformations.translation_matrix(centre))


def scene_of(*meshes, offset=(0.0, 0.0, 0.0), name="test") -> Scene:
    """A scene of trimesh meshes (metres), each a part, all moved by ``offset``."""
    T = np.eye(4)
    T[:3, 3] = offset
    parts = [
        make_part(f"part{i}", name, np.asarray(m.vertices, np.float64), np.asarray(m.faces), T)
        for i, m in enumerate(meshes)
    ]
    return Scene(name, name, parts)


def render_ao(ctx, scene, camera, mode, **settings) -> np.ndarray:
    """(H, W) float32 AO of one mode, unblurred unless ``blur=True`` is passed."""
    settings.setdefault("blur", False)
    result = Renderer(scene, ctx=ctx).render(camera, [mode], RenderSettings(**settings), want_ao=True)
    return result[mode].ao


def render_depth(ctx, scene, camera) -> np.ndarray:
    """(H, W) depth at the pixel centres (single-sampled: an anti-aliased frame's edge pixels hold
    the majority surface of their samples)."""
    renderer = Renderer(scene, ctx=ctx)
    return renderer.render(camera, ["phong"], RenderSettings(antialias=False)).depth
