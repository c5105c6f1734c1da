"""The review's render session (issue 42): the page moves a camera through the CAD from a shot's
pose; this server renders what that camera sees and answers with the image. The model never
leaves the server: the page receives JPEG frames only.

One WebSocket per page (``/api/view``, :mod:`.routes.view`). The page sends a JSON request per
camera it wants (``id``, ``shot``, world-to-camera ``R`` and ``t``, ``mode``, ``intensity``,
``quality``); the server answers each frame it renders with a JSON header (``id``, the size,
``ms``) followed by the JPEG as a binary message. **Only the newest request is served**: requests
that arrive while a frame renders replace each other, so a moving view never builds a queue and
the answer is always the latest camera's. ``quality``:

* ``move``: half the shot's served size, 8 samples, no anti-aliasing, one AO frame: what keeps
  the view responsive while the planner drags;
* ``rest``: the served size, the review's samples and anti-aliasing, and ``accumulate`` AO frames
  (progressive AO, :attr:`mrcheck.render.renderer.RenderSettings.accumulate`): the converged frame
  the page asks for once the view has stopped.

The camera's intrinsics and lens are the shot's (served size), so at the shot's pose the frame is
the review's own render of that shot, and away from it the photo can fade out over the same lens.
Rendering runs on the review's render thread (:meth:`.renders.RenderService.call`), which owns the
GL context.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.review.newest import NewestOnly, json_message
from mrcheck.apps.review.renders import INTENSITIES
from mrcheck.core.camera import Camera
from mrcheck.mr.lens import distort_to_photo, distortion_map, padded_camera
from mrcheck.render.renderer import MODES, RenderSettings
from mrcheck.render.settings import REST_ACCUMULATE

QUALITIES = ("move", "rest")
MOVE_SCALE, MOVE_SAMPLES = 0.5, 8
DEFAULT_ACCUMULATE = REST_ACCUMULATE  # AO frames of a frame at rest (--accumulate)
JPEG_QUALITY = 88


@dataclass(frozen=True)
class ViewRequest:
    """One camera the page wants rendered (see the module docstring)."""

    id: int
    shot: str
    R: np.ndarray
    t: np.ndarray
    mode: str = "vector"
    intensity: float = 1.0
    quality: str = "rest"


def parse_request(message, shots) -> ViewRequest:
    """The request in ``message`` (a decoded JSON object), checked; ValueError saying what is
    wrong. ``R`` is made the nearest rotation (a page's float arithmetic drifts from one)."""
    if not isinstance(message, dict):
        raise ValueError("a request is a JSON object")
    shot = message.get("shot")
    if shot not in shots:
        raise ValueError(f"no shot named {shot!r}")
    mode, quality = message.get("mode", "vector"), message.get("quality", "rest")
    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r} (use {', '.join(MODES)})")
    if quality not in QUALITIES:
        raise ValueError(f"quality must be one of {', '.join(QUALITIES)}, got {quality!r}")
    intensity = message.get("intensity", 1.0)
    if intensity not in INTENSITIES:
        raise ValueError(f"intensity must be one of {', '.join(map(str, INTENSITIES))}")
    ident = message.get("id", 0)
    if not isinstance(ident, int) or isinstance(ident, bool):
        raise ValueError("id must be an integer")
    R, t = _pose(message.get("R"), message.get("t"))
    return ViewRequest(ident, shot, R, t, mode, float(intensity), quality)


def _pose(R, t) -> tuple[np.ndarray, np.ndarray]:
    try:
        R = np.array(R, np.float64).reshape(3, 3)
        t = np.array(t, np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ValueError("R must be 3x3 and t 3 numbers") from None
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
        raise ValueError("R and t must be finite")
    u, s, vt = np.linalg.svd(R)
    if not np.allclose(s, 1.0, atol=1e-3) or np.linalg.det(u @ vt) < 0:
        raise ValueError("R is not a rotation (its rows must be orthonormal, determinant +1)")
    return u @ vt, t


class ViewRenderer:
    """Renders :class:`ViewRequest` frames for one review (its source and render service)."""

    def __init__(self, source, renders, accumulate: int = DEFAULT_ACCUMULATE):
        self.source, self.renders, self.accumulate = source, renders, accumulate
        self._maps: dict = {}  # (shot, width, height) -> lens map (the intrinsics' only)

    def camera(self, request: ViewRequest) -> Camera:
        """The request's camera: the shot's served intrinsics and lens (half size when moving)."""
        camera = self.source.shots[request.shot].served_camera()
        if request.quality == "move":
            w, h = (max(16, round(v * MOVE_SCALE)) for v in (camera.width, camera.height))
            camera = camera.resized(w, h)
        return camera.with_pose(request.R, request.t)

    def settings(self, request: ViewRequest, height: int) -> RenderSettings:
        moving = request.quality == "move"
        return RenderSettings(
            samples=MOVE_SAMPLES if moving else self.renders.samples,
            intensity=request.intensity,
            seed=0,
            antialias=self.renders.antialias and not moving,
            accumulate=1 if moving else self.accumulate,
        ).validated(height)

    def frame(self, request: ViewRequest) -> tuple[dict, bytes]:
        """(header, JPEG bytes) of ``request``, rendered on the render thread."""
        began = time.perf_counter()
        camera = self.camera(request)
        key = (request.shot, camera.width, camera.height)
        if key not in self._maps:
            self._maps[key] = distortion_map(camera)
        maps = self._maps[key]
        render_camera, offset = padded_camera(camera, maps)
        settings = self.settings(request, camera.height)
        frame = self.renders.call(lambda renderer: renderer.render(render_camera, [request.mode], settings))
        image = distort_to_photo(frame[request.mode].image, maps, offset, (camera.height, camera.width))
        ok, jpeg = cv2.imencode(
            ".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]
        )
        assert ok, "JPEG encoding failed"
        ms = (time.perf_counter() - began) * 1000.0
        header = {
            "type": "frame",
            "id": request.id,
            "quality": request.quality,
            "width": camera.width,
            "height": camera.height,
            "ms": round(ms, 1),
            "accumulate": settings.accumulate,
        }
        return header, jpeg.tobytes()


def view_session(renderer: ViewRenderer, shots) -> NewestOnly:
    """One page's render session (module docstring): its requests parsed, the newest rendered."""

    def parse(message: dict) -> ViewRequest:
        if "text" not in message:
            raise ValueError("a request is a JSON text message")
        return parse_request(json_message(message["text"]), shots)

    return NewestOnly(parse, renderer.frame)


__all__ = ["ViewRequest", "ViewRenderer", "view_session", "parse_request", "QUALITIES", "DEFAULT_ACCUMULATE"]
