"""A baseline folder: ``baseline.json`` (the manifest) and, per view, one PNG per mode and the
id buffer (``VIEW_ids.npz``). This module is the one reader and writer of both.

baseline.json holds what a check must reproduce: the mrcheck version, the GL renderer, the
render settings, the size, the modes, the scene and its content stamp
(:func:`mrcheck.scene.manifest.files_stamp`), and per view its camera (so a check renders the
agreed view even after the scene's viewpoints are edited) and the SHA-256 of each image's pixels.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import read_image
from mrcheck.core.jsonfile import read_json
from mrcheck.core.output import write_bytes, write_image, write_text
from mrcheck.render.settings import RenderSettings

MANIFEST = "baseline.json"
FORMAT = 1  # the manifest's format; a newer one is refused with a message


@dataclass(frozen=True)
class BaselineView:
    """One agreed view: its name, camera and each mode's image file and pixel hash."""

    name: str
    camera: Camera
    images: dict[str, str]  # mode -> file name in the baseline folder
    hashes: dict[str, str]  # mode -> SHA-256 of the (H, W, 3) uint8 pixels

    @property
    def ids_file(self) -> str:
        return f"{self.name}_ids.npz"


@dataclass(frozen=True)
class Baseline:
    """What ``regress record`` wrote (``folder``: where baseline.json is)."""

    folder: Path
    mrcheck_version: str
    gl_renderer: str
    scene: str  # the scene as recorded (absolute path)
    scene_stamp: str
    modes: tuple[str, ...]
    width: int
    height: int
    settings: RenderSettings
    views: tuple[BaselineView, ...]


@dataclass(frozen=True)
class IdBuffer:
    """Which element every pixel shows: ``ids`` (H, W) int32 index into ``labels`` (-1 = none),
    ``depth`` (H, W) float32 camera-space depth (0 = none), ``labels`` (N, 4) str: part name,
    instance id (an IFC GlobalId for imported scenes), element name, IFC class."""

    ids: np.ndarray
    depth: np.ndarray
    labels: np.ndarray


def pixel_hash(image: np.ndarray) -> str:
    """SHA-256 of the pixels, not of the PNG (an encoder's version changes the file, not the image)."""
    image = np.ascontiguousarray(image, np.uint8)
    return hashlib.sha256(b"%d,%d;" % image.shape[:2] + image.tobytes()).hexdigest()


def image_file(view: str, mode: str) -> str:
    return f"{view}_{mode}.png"


def manifest_dict(baseline: Baseline) -> dict:
    return {
        "format": FORMAT,
        "mrcheck_version": baseline.mrcheck_version,
        "gl_renderer": baseline.gl_renderer,
        "scene": baseline.scene,
        "scene_stamp": baseline.scene_stamp,
        "modes": list(baseline.modes),
        "width": baseline.width,
        "height": baseline.height,
        "settings": dataclasses.asdict(baseline.settings),
        "views": [
            {"name": v.name, "camera": v.camera.to_dict(), "images": v.images, "hashes": v.hashes}
            for v in baseline.views
        ],
    }


def baseline_writes(baseline: Baseline, images: dict, id_buffers: dict) -> list:
    """The writes of a baseline (callables for :func:`mrcheck.core.output.write_all_or_none`):
    every image, every id buffer, then baseline.json last (a folder without it is no baseline)."""
    folder = baseline.folder
    writes = []
    for view in baseline.views:
        for mode, name in view.images.items():
            writes.append(lambda p=folder / name, im=images[view.name, mode]: write_image(p, im))
        writes.append(lambda p=folder / view.ids_file, b=id_buffers[view.name]: write_id_buffer(p, b))
    text = json.dumps(manifest_dict(baseline), indent=1) + "\n"
    writes.append(lambda: write_text(folder / MANIFEST, text))
    return writes


def write_id_buffer(path: Path, buffer: IdBuffer) -> Path:
    data = io.BytesIO()
    np.savez_compressed(data, ids=buffer.ids, depth=buffer.depth, labels=buffer.labels)
    return write_bytes(path, data.getvalue())


def read_baseline(folder) -> Baseline:
    """The baseline in ``folder`` (its baseline.json), or a one-line error naming the file."""
    folder = Path(folder).resolve()  # compared with the report folder, and printed, as a whole path
    path = folder / MANIFEST
    if not folder.is_dir():
        raise MrcheckError("baseline folder not found", folder)
    data = read_json(path, "baseline")
    try:
        if data.get("format") != FORMAT:
            raise ValueError(f"format {data.get('format')!r} is not {FORMAT} (recorded by another mrcheck?)")
        views = tuple(
            BaselineView(
                str(v["name"]),
                Camera.from_dict(v["camera"], path),
                {str(k): str(f) for k, f in v["images"].items()},
                {str(k): str(h) for k, h in v["hashes"].items()},
            )
            for v in data["views"]
        )
        return Baseline(
            folder,
            str(data["mrcheck_version"]),
            str(data["gl_renderer"]),
            str(data["scene"]),
            str(data["scene_stamp"]),
            tuple(str(m) for m in data["modes"]),
            int(data["width"]),
            int(data["height"]),
            RenderSettings(**data["settings"]),
            views,
        )
    except MrcheckError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise MrcheckError(f"malformed baseline: {type(exc).__name__}: {exc}", path) from None


def read_view_image(baseline: Baseline, view: BaselineView, mode: str) -> np.ndarray:
    """A view's baseline image, refused when its pixels are not the ones recorded (re-encoded
    lossily, edited, or a Git LFS pointer checked out without LFS)."""
    path = baseline.folder / view.images[mode]
    image = read_image(path, what="baseline image")
    if pixel_hash(image) != view.hashes.get(mode):
        raise MrcheckError(
            f"baseline image's pixels differ from their hash in {MANIFEST} (edited?); record again", path
        )
    return image


def check_files(baseline: Baseline) -> None:
    """Every file baseline.json names is there: a missing one fails before any render."""
    for view in baseline.views:
        for name in [*view.images.values(), view.ids_file]:
            if not (baseline.folder / name).is_file():
                raise MrcheckError(f"baseline file {name} named in {MANIFEST} is missing", baseline.folder / name)


def read_id_buffer(path) -> IdBuffer:
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            return IdBuffer(data["ids"], data["depth"], data["labels"])
    except FileNotFoundError:
        raise MrcheckError("baseline id buffer not found", path) from None
    except (OSError, KeyError, ValueError) as exc:
        raise MrcheckError(f"unreadable baseline id buffer ({exc})", path) from None


__all__ = [
    "Baseline",
    "BaselineView",
    "IdBuffer",
    "MANIFEST",
    "baseline_writes",
    "check_files",
    "image_file",
    "pixel_hash",
    "read_baseline",
    "read_id_buffer",
    "read_view_image",
]
