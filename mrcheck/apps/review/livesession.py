"""The live check's server side (issue 42): a camera's video frames tracked as they arrive.

One WebSocket per page (``/api/live``, :mod:`.routes.view`). The page first sends
``{"type": "start", "shot": NAME}``: the track starts at that shot's pose, with its intrinsics
and lens (at the served size; a frame of another size is resized to it; Live's own intrinsics
at their size when the review has them, :mod:`.livecamera`), so the camera should
start roughly where the shot was taken. Then every video frame as a binary message: its capture
time in seconds (8 bytes, a little-endian float64: frames the server takes come at irregular
intervals, and the constant-velocity prediction scales the motion by the time between them)
followed by the JPEG; the newest waiting frame is tracked when the one before is done
(:mod:`.newest`: no queue builds up behind a slow frame). Each tracked frame is answered with a
JSON header ``{"type": "pose", "frame", "time" (the frame's own), "R", "t", "support", "rms_px", "lost", "reason", "ms",
"width", "height"}`` and the CAD layer at that pose (vector AO in the lens's geometry, JPEG),
which the page blends over its own video at the video's rate. Tracking is ``mrcheck track``'s per-frame step
(:func:`mrcheck.apps.track.track_frame`: constant-velocity prediction, snap, retry,
relocalisation from the last good pose after a lost stretch), on the review's render thread.
Frames are never stored: each is decoded, tracked and dropped.
"""

from __future__ import annotations

import base64
import binascii
import struct
import time

import cv2
import numpy as np

from mrcheck.apps.review.newest import NewestOnly, json_message
from mrcheck.apps.track import OVERLAY_SETTINGS, FramePose, frame_options, track_frame
from mrcheck.apps.trackframes import FramePhoto
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import decode_image, max_pixels
from mrcheck.mr.edges import VisibilityRender, photo_pyramid, scene_edges
from mrcheck.mr.edges.candidates import CandidateEdges
from mrcheck.mr.lens import distort_to_photo, distortion_map
from mrcheck.mr.shot import photo_frame

KEEP_FRAMES = 100  # frame records kept: the prediction and relocalisation look back this far at most
JPEG_QUALITY = 85


class LiveTracker:
    """The track of one live session: the frames' poses so far and what the next frame reuses
    (the edges seen, the last overlay's depth and normals)."""

    def __init__(self, source, shot_name: str, live_camera=None):
        shot = source.shots[shot_name]
        # the shot's pose; the intrinsics Live is given (:mod:`.livecamera`), else the shot's
        camera = shot.served_camera() if live_camera is None else live_camera.for_shot(shot)
        self.scene, self.camera = source.loaded, camera
        self.initial = self.camera
        self.frames: list[FramePose] = []
        self.edges = scene_edges(self.scene)
        self.candidates = CandidateEdges(self.edges)
        self.seed: VisibilityRender | None = None
        self.maps = distortion_map(self.camera)
        self.count = 0

    def step(self, renderer, jpeg: bytes, time_s: float) -> tuple[dict, bytes]:
        """Track one frame taken at ``time_s`` (``renderer``: the render thread's); (header, CAD
        layer JPEG)."""
        began = time.perf_counter()
        rgb = _decoded(jpeg, self.camera)
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
        return _header(pose, self.camera, (time.perf_counter() - began) * 1000.0), layer

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


def _header(pose: FramePose, camera, ms: float) -> dict:
    return {
        "type": "pose",
        "frame": pose.frame,
        "time": pose.time_s,
        "R": pose.camera.R.tolist(),
        "t": pose.camera.t.tolist(),
        "support": round(pose.support, 4),
        "rms_px": None if pose.rms_px is None else round(pose.rms_px, 3),
        "lost": pose.lost,
        "reason": pose.reason,
        "ms": round(ms, 1),
        "width": camera.width,
        "height": camera.height,
    }


def live_session(source, renders, live_camera=None) -> NewestOnly:
    """One page's live session (module docstring); ``live_camera``: :class:`.livecamera.LiveCamera`."""
    tracker: list[LiveTracker] = []

    def parse(message: dict):
        if "text" in message:
            start = json_message(message["text"])
            if not isinstance(start, dict) or start.get("type") != "start" or start.get("shot") not in source.shots:
                raise ValueError('start with {"type": "start", "shot": NAME}, NAME a shot of this review')
            tracker[:] = [LiveTracker(source, start["shot"], live_camera)]
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


__all__ = ["LiveTracker", "live_session", "frozen_image"]
