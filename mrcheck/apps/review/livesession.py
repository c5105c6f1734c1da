"""The live check's server side (issue 42): a camera's video frames tracked as they arrive.

One WebSocket per page (``/api/live``, :mod:`.routes.view`). The page first sends
``{"type": "start", "shot": NAME}`` (:class:`LiveStart`): the track uses that shot's intrinsics
and lens (at the served size; a frame of another size is resized to it; Live's own intrinsics
at their size when the review has them, :mod:`.livecamera`) and starts

* at the shot's pose (the camera should start roughly where the shot was taken), or
* with ``"viewpoint": VIEW``, at the scene's named viewpoint (then snaps onto the frame's
  edges, as ``track`` does from ``--initial``), or
* with ``"markers": true``, at the pose the markers of the review's marker map
  (``--marker-map``) give, as ``register --markers`` solves it. Until markers are seen, each
  frame is answered as lost and ``"waiting": true`` with no layer; after a lost frame the markers
  are looked for again, and a frame that shows them restarts the track from their pose.

A start from clicks is the page's: a frozen frame goes through "Add photo" (the shot's
intrinsics) and Live starts again from the shot it saves. Then every video frame as a binary message: its capture
time in seconds (8 bytes, a little-endian float64: frames the server takes come at irregular
intervals, and the constant-velocity prediction scales the motion by the time between them)
followed by the JPEG; the newest waiting frame is tracked when the one before is done
(:mod:`.newest`: no queue builds up behind a slow frame). Each tracked frame is answered with a
JSON header ``{"type": "pose", "frame", "time" (the frame's own), "R", "t", "support", "rms_px", "lost", "reason", "ms",
"width", "height"}`` and the CAD layer at that pose (vector AO in the lens's geometry, JPEG),
which the page blends over its own video at the video's rate. Tracking is ``mrcheck track``'s per-frame step
(:func:`mrcheck.apps.track.track_frame`: constant-velocity prediction, snap, retry,
relocalisation from the last good pose and the best supported recent one after a lost
stretch), on the review's render thread.
Frames are never stored: each is decoded, tracked and dropped.
"""

from __future__ import annotations

import base64
import binascii
import struct
import time
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.review.newest import NewestOnly, json_message
from mrcheck.apps.track import OVERLAY_SETTINGS, FramePose, frame_options, track_frame
from mrcheck.apps.trackframes import FramePhoto
from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import decode_image, max_pixels
from mrcheck.mr.edges import VisibilityRender, photo_pyramid, scene_edges
from mrcheck.mr.edges.candidates import CandidateEdges
from mrcheck.mr.lens import distort_to_photo, distortion_map
from mrcheck.mr.registration import register_markers
from mrcheck.mr.shot import photo_frame

KEEP_FRAMES = 100  # frame records kept: the prediction and relocalisation look back this far at most
JPEG_QUALITY = 85


@dataclass(frozen=True)
class LiveStart:
    """Where a live track starts (the module docstring): the shot whose intrinsics it uses and,
    instead of that shot's pose, a named viewpoint's or the markers'."""

    shot: str
    viewpoint: str | None = None
    markers: bool = False


def parse_start(start, source, marker_map) -> LiveStart:
    """The start message as a :class:`LiveStart`; ValueError saying what is wrong with it."""
    if not isinstance(start, dict) or start.get("type") != "start" or start.get("shot") not in source.shots:
        raise ValueError('start with {"type": "start", "shot": NAME}, NAME a shot of this review')
    if set(start) - {"type", "shot", "viewpoint", "markers"}:
        raise ValueError(
            f"unknown start keys: {', '.join(sorted(set(start) - {'type', 'shot', 'viewpoint', 'markers'}))}"
        )
    viewpoint, markers = start.get("viewpoint"), start.get("markers", False)
    if viewpoint is not None and viewpoint not in source.loaded.viewpoints:
        known = ", ".join(sorted(source.loaded.viewpoints)) or "none"
        raise ValueError(f"no viewpoint named {viewpoint!r} (the scene has: {known})")
    if not isinstance(markers, bool) or (markers and viewpoint is not None):
        raise ValueError('"markers" is true or false, and not given with "viewpoint"')
    if markers and marker_map is None:
        raise ValueError("this review has no marker map: start it with --marker-map MAP.json")
    return LiveStart(start["shot"], viewpoint, markers)


class LiveTracker:
    """The track of one live session: the frames' poses so far and what the next frame reuses
    (the edges seen, the last overlay's depth and normals)."""

    def __init__(self, source, start: LiveStart, marker_map=None, live_camera=None):
        shot = source.shots[start.shot]
        # the shot's pose; the intrinsics Live is given (:mod:`.livecamera`), else the shot's
        camera = shot.served_camera() if live_camera is None else live_camera.for_shot(shot)
        self.scene, self.camera = source.loaded, camera
        self.initial = self.camera
        if start.viewpoint is not None:
            view = self.scene.camera(start.viewpoint)
            self.initial = self.camera.with_pose(view.R, view.t)
        self.marker_map = marker_map if start.markers else None
        self.waiting = start.markers  # for the first frame that shows markers
        self.frames: list[FramePose] = []
        self.edges = scene_edges(self.scene)
        self.candidates = CandidateEdges(self.edges)
        self.seed: VisibilityRender | None = None
        self.maps = distortion_map(self.camera)
        self.count = 0

    def step(self, renderer, jpeg: bytes, time_s: float) -> tuple[dict, bytes]:
        """Track one frame taken at ``time_s`` (``renderer``: the render thread's); (header, CAD
        layer JPEG, or no bytes while waiting for markers)."""
        began = time.perf_counter()
        rgb = _decoded(jpeg, self.camera)
        if self.marker_map is not None and (self.waiting or (self.frames and self.frames[-1].lost)):
            reason = self._restart_from_markers(rgb)
            if self.waiting:
                self.count += 1
                ms = (time.perf_counter() - began) * 1000.0
                return _header(self.count - 1, time_s, self.camera, ms, reason=reason), b""
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        index = len(self.frames)
        photo = FramePhoto(rgb, time_s, grey, photo_pyramid(grey, frame_options(index)))
        pose = track_frame(
            self.frames,
            self.scene,
            self.camera,
            photo,
            self.initial,
            renderer,
            self.edges,
            index,
            candidates=self.candidates if self.frames else None,
            seed=self.seed,
            timed=True,
        )
        pose.frame = self.count
        self.count += 1
        self.frames = [*self.frames, pose][-KEEP_FRAMES:]
        layer = self._layer(renderer, pose)
        ms = (time.perf_counter() - began) * 1000.0
        return _header(pose.frame, pose.time_s, self.camera, ms, pose), layer

    def _restart_from_markers(self, rgb: np.ndarray) -> str:
        """The markers' pose as the new start when the frame shows them (the track begins again
        there); else why not."""
        try:
            shot = register_markers(rgb, self.camera, self.marker_map)
        except MrcheckError as exc:
            return f"waiting for markers: {exc.problem}"
        self.initial = self.camera.with_pose(shot.camera.R, shot.camera.t)
        self.frames, self.seed, self.waiting = [], None, False
        return ""

    def _layer(self, renderer, pose: FramePose) -> bytes:
        """The CAD at the frame's pose in the lens's geometry; its depth and normals seed the next
        frame's visible edges (as ``track``'s overlay does)."""
        frame, view, offset, self.maps = photo_frame(
            renderer, pose.camera, ["vector"], OVERLAY_SETTINGS, self.maps, want_normals=True
        )
        self.seed = VisibilityRender(view, frame.depth, frame.normals)
        image = distort_to_photo(frame["vector"].image, self.maps, offset, (self.camera.height, self.camera.width))
        ok, data = cv2.imencode(
            ".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]
        )
        assert ok, "JPEG encoding failed"
        return data.tobytes()


def _decoded(jpeg: bytes, camera) -> np.ndarray:
    """The frame as RGB at the camera's size; ValueError for what is no image or too large (the
    pixel limit checked on the header, before anything is decoded)."""
    try:
        image = decode_image(jpeg, what="the frame (a JPEG or PNG image)", max_pixels=max_pixels())
    except MrcheckError as exc:
        raise ValueError(exc.problem) from None
    if image.shape[:2] != (camera.height, camera.width):
        image = cv2.resize(image, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    return image


def frozen_image(encoded: str, camera) -> np.ndarray:
    """The RGB frame of a freeze (base64 JPEG or PNG) at the camera's size; ValueError else."""
    try:
        data = base64.b64decode(encoded, validate=True)
    except (binascii.Error, ValueError):
        raise ValueError("image must be base64") from None
    return _decoded(data, camera)


def _header(
    frame: int, time_s: float, camera: Camera, ms: float, pose: FramePose | None = None, reason: str = ""
) -> dict:
    """The answer to a frame: its tracked ``pose``, or without one (before the markers were seen)
    lost and waiting at ``camera``'s pose with the ``reason``."""
    posed = pose.camera if pose is not None else camera
    return {
        "type": "pose",
        "frame": frame,
        "time": time_s,
        "R": posed.R.tolist(),
        "t": posed.t.tolist(),
        "support": 0.0 if pose is None else round(pose.support, 4),
        "rms_px": None if pose is None or pose.rms_px is None else round(pose.rms_px, 3),
        "lost": True if pose is None else pose.lost,
        "waiting": pose is None,
        "reason": reason if pose is None else pose.reason,
        "ms": round(ms, 1),
        "width": camera.width,
        "height": camera.height,
    }


def live_session(source, renders, marker_map=None, live_camera=None) -> NewestOnly:
    """One page's live session (module docstring); ``marker_map``: the review's (``--marker-map``);
    ``live_camera``: :class:`.livecamera.LiveCamera`."""
    tracker: list[LiveTracker] = []

    def parse(message: dict):
        if "text" in message:
            start = parse_start(json_message(message["text"]), source, marker_map)
            tracker[:] = [LiveTracker(source, start, marker_map, live_camera)]
            return None
        if not tracker:
            raise ValueError('send {"type": "start", "shot": NAME} before the frames')
        data = message["bytes"]
        if len(data) < 9:
            raise ValueError("a frame is 8 bytes of its time (float64) and then the image")
        (time_s,) = struct.unpack("<d", data[:8])
        if not np.isfinite(time_s):
            raise ValueError("a frame's time must be a finite number of seconds")
        return tracker[0], data[8:], time_s

    def work(request) -> tuple[dict, bytes]:
        live, jpeg, time_s = request
        return renders.call(lambda renderer: live.step(renderer, jpeg, time_s))

    return NewestOnly(parse, work)


__all__ = ["LiveStart", "LiveTracker", "parse_start", "live_session", "frozen_image"]
