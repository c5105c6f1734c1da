"""The bench's scenes: the synthetic height field, the sample cell (or its stand-in), the
generated halls (cached under the temporary directory) and the shipped ``line`` scene."""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckWarning
from mrcheck.core.resources import sample_scene_path, shipped_scene
from mrcheck.eval.bench.figures import (
    BLOCK_HALF_WIDTH,
    BLOCK_PITCH,
    BLOCK_RAMP,
    HALL_SEED,
    LINE_SCENE,
    SAMPLE_VIEW,
    TERRAIN_EXTENT,
    TERRAIN_EYE,
    TERRAIN_FOV,
    TERRAIN_TARGET,
    TRIANGLE_COUNTS,
    millions,
)
from mrcheck.scene import robots
from mrcheck.scene.model import Scene, load_scene, make_part


def _terrain_heights(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Heights (metres) of the synthetic field: blocks of hashed height on rolling ground."""
    ix, iy = np.floor(x / BLOCK_PITCH), np.floor(y / BLOCK_PITCH)
    dx, dy = np.abs(x - (ix + 0.5) * BLOCK_PITCH), np.abs(y - (iy + 0.5) * BLOCK_PITCH)
    block = 0.5 + 2.0 * ((np.sin(ix * 12.9898 + iy * 78.233) * 43758.5453) % 1.0)  # 0.5..2.5 m per cell
    inside = np.clip((BLOCK_HALF_WIDTH - np.maximum(dx, dy)) / BLOCK_RAMP + 0.5, 0.0, 1.0)
    return block * inside + 0.3 * np.sin(0.35 * x) * np.cos(0.27 * y)


def terrain_scene(triangles: int) -> Scene:
    """A height field of about ``triangles`` triangles (a square grid, two per cell), in memory."""
    n = max(1, int(round(np.sqrt(triangles / 2.0))))
    t = np.linspace(-TERRAIN_EXTENT / 2.0, TERRAIN_EXTENT / 2.0, n + 1)
    x, y = np.meshgrid(t, t)
    vertices = np.column_stack([x.ravel(), y.ravel(), _terrain_heights(x, y).ravel()])
    del x, y
    i = np.arange(n, dtype=np.uint32)
    a = (i[None, :] + i[:, None] * np.uint32(n + 1)).ravel()  # lower-left corner of every cell
    faces = np.empty((2 * n * n, 3), np.uint32)
    faces[0::2, 0], faces[0::2, 1], faces[0::2, 2] = a, a + 1, a + n + 2
    faces[1::2, 0], faces[1::2, 1], faces[1::2, 2] = a, a + n + 2, a + n + 1
    name = f"terrain_{millions(len(faces))}"
    part = make_part(name, "<synthetic>", vertices, faces, np.eye(4), color=(0.7, 0.7, 0.7), units="m")
    return Scene(name, "<synthetic>", [part])


def terrain_camera(size) -> Camera:
    return Camera.from_look_at(TERRAIN_EYE, TERRAIN_TARGET, (0.0, 0.0, 1.0), TERRAIN_FOV, *size)


def sample_scene() -> tuple[Scene, Callable[[tuple], Camera], str]:
    """The sample cell and its overview camera, or the 1 M height field if the cell is missing."""
    path = sample_scene_path()
    if path.exists():
        scene = load_scene(path)
        return scene, lambda size: scene.camera(SAMPLE_VIEW, *size), f"{scene.name}:{SAMPLE_VIEW}"
    warnings.warn(
        f"{path} not found; timing a synthetic height field instead of the sample cell", MrcheckWarning, stacklevel=2
    )
    scene = terrain_scene(TRIANGLE_COUNTS[0])
    # not the height-field section's label: figures (the floors) are matched by their scene
    return scene, terrain_camera, f"{scene.name}:stand-in"


@dataclass(frozen=True)
class HallGenerator:
    """The generator of the bench's halls, given by the command line (mrcheck does not import
    ``factory_scenes`` below it): ``generate(preset, folder, seed=, target_triangles=, progress=)``
    and the folder of its Python source, whose hash keys the cache of generated halls."""

    generate: Callable
    source: Path
    # the generator's IFC writer, write_ifc(scene, path, seed, description), for the import
    # figures (None: the bench measures no IFC import)
    write_ifc: Callable | None = None

    def digest(self) -> str:
        """A hash of the generator's source and of the robots module whose arms it places: the
        halls are cached by it, so that a changed generator is benchmarked on halls it made."""
        digest = hashlib.sha256()
        for path in sorted(Path(self.source).glob("*.py")) + [Path(robots.__file__)]:
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
        return digest.hexdigest()[:12]


def hall_scene_path(hall: HallGenerator, triangles: int, seed: int = HALL_SEED) -> Path:
    """scene.toml of the generated hall at ``triangles``, generated once per (budget, seed,
    generator source) into ``<tmp>/mrcheck-bench/`` (a finished scene is moved into place whole,
    so a crash leaves none)."""
    cache = Path(tempfile.gettempdir()) / "mrcheck-bench"
    final = cache / f"hall_{triangles}_seed{seed}_{hall.digest()}"
    if not (final / "scene.toml").exists():
        cache.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=final.name + ".", dir=cache))
        hall.generate("hall", work / "scene", seed=seed, target_triangles=triangles, progress=False)
        try:
            os.replace(work / "scene", final)
        except OSError:  # another run finished first
            if not (final / "scene.toml").exists():
                raise
        shutil.rmtree(work, ignore_errors=True)
    return final / "scene.toml"


def hall_ifc_path(hall: HallGenerator, triangles: int, seed: int = HALL_SEED) -> Path:
    """The generated hall at ``triangles`` written as IFC4 (``scene generate --format ifc``),
    once per (budget, seed, generator source), beside the hall's scene.toml."""
    manifest = hall_scene_path(hall, triangles, seed)
    final = manifest.parent / "hall.ifc"
    if not final.exists():
        from mrcheck.scene.model import load_scene

        work = final.with_name(f".hall.ifc.{os.getpid()}")
        hall.write_ifc(load_scene(manifest), work, seed, f"mrcheck bench hall {triangles} seed {seed}")
        os.replace(work, final)
    return final


def line_scene_path() -> Path:
    return shipped_scene(LINE_SCENE)


def flattened_mesh(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Every instance of every part in world space, as one (V, 3) float32 / (F, 3) int32 mesh."""
    vertices, faces, offset = [], [], 0
    for part in scene.parts:
        local = np.asarray(part.vertices, np.float64)
        for T in part.transforms:
            vertices.append((local @ T[:3, :3].T + T[:3, 3]).astype(np.float32))
            faces.append(np.asarray(part.faces, np.int64) + offset)
            offset += len(local)
    return np.concatenate(vertices), np.concatenate(faces).astype(np.int32)


__all__ = [
    "HallGenerator",
    "hall_scene_path",
    "line_scene_path",
    "sample_scene",
    "terrain_scene",
    "terrain_camera",
    "flattened_mesh",
]
