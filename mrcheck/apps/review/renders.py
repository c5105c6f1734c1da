"""Renders on demand: one background thread owns the EGL context and the scene's Renderer;
results are cached on disk by (shot, mode, intensity, size) and a stamp of their inputs (the
scene's files, the shot's camera and photo), so a seen view is a file read and a re-export into
the same folder is rendered afresh."""

from __future__ import annotations

import concurrent.futures
import contextlib
import hashlib
import json
import queue
import threading
import time
from pathlib import Path

import cv2
import numpy as np

from mrcheck.apps.names import CACHED_PREFIXES, cached_name, cached_suffix, view_tag
from mrcheck.core.camerafiles import read_photo
from mrcheck.core.images import read_image
from mrcheck.core.output import write_image
from mrcheck.mr.lens import distort_to_photo, distortion_map, padded_camera
from mrcheck.mr.overlay import overlay_images
from mrcheck.mr.shot import cad_edges
from mrcheck.render.renderer import MODES, Renderer, RenderSettings
from mrcheck.scene.manifest import files_stamp

INTENSITIES = (0.5, 1.0, 1.5, 2.0)  # the AO slider's four levels
SAMPLES = 16
EDGE_RGB = (255, 0, 255)
THUMB_WIDTH = 160


def _shot_stamp(shot) -> str:
    """The shot's camera and its photo file (path, size, mtime): what a photo or thumbnail is made of."""
    camera = json.dumps(shot.camera.to_dict(), sort_keys=True)
    return hashlib.sha256(f"{camera}\0{files_stamp([shot.photo])}".encode()).hexdigest()[:12]


def _write_png(path: Path, image: np.ndarray) -> None:
    """Atomic PNG (RGB or RGBA array)."""
    write_image(path, image)


class RenderService:
    """``path(shot, kind, mode, intensity)`` -> a cached PNG, rendering it in the worker if needed."""

    def __init__(self, source, cache_dir: Path, samples: int = SAMPLES, antialias: bool = True):
        self.source = source
        self.cache = Path(cache_dir)
        self.samples = samples
        self.antialias = antialias  # part of the renders' cache names: a switch renders afresh
        self._queue: queue.Queue = queue.Queue()
        self._pending: dict = {}
        self._lock = threading.Lock()
        self._maps: dict = {}
        self.timings: list = []  # (key, seconds) of every render made
        self._prune()
        self._thread = threading.Thread(target=self._run, name="mrcheck-review-render", daemon=True)
        self._thread.start()

    def _prune(self) -> None:
        """Remove cached images whose stamps are not the current ones (a re-export, an edited
        scene) and those of shots the review no longer has: only this service's own file names
        (photo_, thumb_, edges_, render_ ... .png), in its own cache folder."""
        if not self.cache.is_dir():
            return
        stamps = {name: _shot_stamp(shot) for name, shot in self.source.shots.items()}
        current = {
            name: (cached_suffix(stamp), cached_suffix(self._cad_stamp(stamp))) for name, stamp in stamps.items()
        }
        for folder in (p for p in self.cache.iterdir() if p.is_dir()):
            suffixes = current.get(folder.name, ())
            for path in folder.glob("*.png"):
                if path.name.startswith(CACHED_PREFIXES) and not path.name.endswith(suffixes):
                    path.unlink(missing_ok=True)
            with contextlib.suppress(OSError):  # empty now: the folder of a vanished shot
                folder.rmdir()

    def _cad_stamp(self, shot_stamp: str) -> str:
        return f"{shot_stamp}_{self.source.scene_stamp}" + ("" if self.antialias else "_noaa")

    def settings(self, height: int, intensity: float = 1.0) -> RenderSettings:
        """The render settings of this review's images (validated for an image ``height`` px high)."""
        return RenderSettings(samples=self.samples, intensity=intensity, seed=0, antialias=self.antialias).validated(
            height
        )

    # -- public --------------------------------------------------------------------------
    def file(self, shot_name: str, kind: str, mode: str = "phong", intensity: float = 1.0) -> Path:
        shot = self.source.shots[shot_name]
        w, _ = shot.served_size
        folder = self.cache / shot_name
        # the photo's stamp of now (a stat): a photo replaced since start-up is not served from
        # the cache, but read afresh (and refused, when it no longer fits its shot); the scene's
        # stamp is that of start-up, when it was loaded once for the renderer
        stamp = _shot_stamp(shot)
        cad = self._cad_stamp(stamp)  # renders and edges depend on the scene and the render settings too
        if kind == "photo":
            path = folder / cached_name("photo", "", w, stamp)
        elif kind == "thumb":
            path = folder / cached_name("thumb", "", THUMB_WIDTH, stamp)
        elif kind == "edges":
            path = folder / cached_name("edges", "", w, cad)
        else:
            path = folder / cached_name("render", view_tag(mode, intensity), w, cad)
        if path.is_file():
            return path
        key = (shot_name, kind, mode, intensity, w)
        with self._lock:
            future = self._pending.get(key)
            if future is None:
                future = concurrent.futures.Future()
                self._pending[key] = future
                self._queue.put((key, path, future))
        future.result(timeout=300)
        return path

    def image(self, shot_name, kind, mode="phong", intensity=1.0) -> np.ndarray:
        return read_image(self.file(shot_name, kind, mode, intensity), "cached render")

    def call(self, fn):
        """``fn(renderer)`` run in the render thread, which owns the EGL context (the review's
        "Add photo": its CAD views, the edge snap, the overlay); returns what it returns."""
        future = concurrent.futures.Future()
        self._queue.put((None, fn, future))
        return future.result(timeout=300)

    def close(self):
        self._queue.put(None)

    # -- the worker ----------------------------------------------------------------------
    def _run(self):
        renderer = None
        while True:
            item = self._queue.get()
            if item is None:
                break
            key, path, future = item
            try:
                if key is None:  # a call (:meth:`call`): ``path`` is the function
                    renderer = renderer or Renderer(self.source.loaded)
                    future.set_result(path(renderer))
                elif not path.is_file():
                    start = time.perf_counter()
                    if key[1] in ("render", "edges") and renderer is None:
                        renderer = Renderer(self.source.loaded)
                    self._make(renderer, key, path)
                    self.timings.append((key, time.perf_counter() - start))
                if key is not None:
                    future.set_result(path)
            except BaseException as exc:  # noqa: BLE001 -- handed to the waiting request
                future.set_exception(exc)
            finally:
                with self._lock:
                    self._pending.pop(key, None)
        if renderer is not None:
            renderer.release()

    def _photo(self, shot):
        camera = shot.served_camera()
        photo = read_photo(shot.photo, shot.camera, max_pixels=self.source.max_pixels)
        if (camera.width, camera.height) != (shot.camera.width, shot.camera.height):
            photo = cv2.resize(photo, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
        return camera, photo

    def _make(self, renderer, key, path):
        shot_name, kind, mode, intensity, _ = key
        shot = self.source.shots[shot_name]
        camera, photo = self._photo(shot)
        if kind == "photo":
            _write_png(path, photo)
            return
        if kind == "thumb":
            h = max(1, round(THUMB_WIDTH * camera.height / camera.width))
            _write_png(path, cv2.resize(photo, (THUMB_WIDTH, h), interpolation=cv2.INTER_AREA))
            return
        if shot_name not in self._maps:
            self._maps[shot_name] = distortion_map(camera)
        maps = self._maps[shot_name]
        render_camera, offset = padded_camera(camera, maps)
        results = renderer.render(render_camera, [mode], self.settings(camera.height, intensity))
        if kind == "edges":
            mask = cad_edges(results.depth, render_camera.fx).astype(np.float32)
            cover = np.minimum(distort_to_photo(mask, maps, offset, photo.shape[:2]) * 2.0, 1.0)
            rgba = np.zeros(photo.shape[:2] + (4,), np.uint8)
            rgba[..., :3] = EDGE_RGB
            rgba[..., 3] = np.rint(cover * 255).astype(np.uint8)
            _write_png(path, rgba)
            return
        virtual = overlay_images(photo, {mode: results[mode].image}, camera, 0.0, offset=offset, maps=maps)[mode]
        _write_png(path, virtual)


__all__ = ["RenderService", "INTENSITIES", "MODES", "SAMPLES"]
