"""Test videos for ``mrcheck track``: a camera walked along a path over a scene, every frame a
photo made by another renderer than mrcheck's (:func:`mrcheck.eval.edgephotos.synthetic_photo`:
Open3D ray casts with sun, sky, shadows, albedo noise, sensor noise and blur, the camera's lens
distortion), written with PyAV, and the true camera of every frame to measure the track against.

The paths (:data:`MOTIONS`, per frame ``k``; moves in world axes, turns about the camera's
axes) are a hand-held walk's size at 10 frames/s:

* ``side``: 4 cm along world x and 0.2 degrees of pan per frame;
* ``forward``: 5 cm times the view direction's level part (forward, level) and 0.15 degrees
  of tilt per frame;
* ``left``: the other way and rising (-3 cm x, +2 cm y, +1 cm z), panning 0.15 and rolling
  0.1 degrees per frame.

The first frame's rough pose is the true one with its rotation turned by 0.43 degrees, its
``t`` kept (1.1-1.8 px median on the scene points of the bench's walks; the snap from 15-40 px
off is the registration's own tests and ``bench --edges``).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.output import replace_output
from mrcheck.eval.edgephotos import scene_points, synthetic_photo
from mrcheck.scene.model import Scene

MOTIONS = ("side", "forward", "left")
RATE = 10  # the test videos' frames per second
_ROUGH_TURN = (0.004, -0.006, 0.002)  # the first frame's rough pose: this rotation (radians) off


@dataclass
class Walk:
    """A test video: ``video`` its path, ``camera`` the intrinsics (and lens) it was taken with,
    ``rough`` the first frame's start pose, ``truths`` every frame's true camera, ``points``
    (n, 3) world points on the CAD surfaces seen from the first frame (to measure errors on)."""

    name: str
    video: Path
    camera: Camera
    rough: Camera
    truths: list
    points: np.ndarray


def walk_camera(camera: Camera, motion: str, k: int) -> Camera:
    """The camera of frame ``k`` of the path ``motion`` (one of :data:`MOTIONS`) from ``camera``."""
    if motion == "side":
        turn, move = (0.0, np.radians(0.2) * k, 0.0), np.array([0.04 * k, 0.0, 0.0])
    elif motion == "forward":  # along the view, level, tilting down
        turn, move = (np.radians(0.15) * k, 0.0, 0.0), 0.05 * k * camera.R[2] * np.array([1.0, 1.0, 0.0])
    elif motion == "left":  # the other way, panning, rolling and rising
        turn, move = (0.0, -np.radians(0.15) * k, np.radians(0.1) * k), np.array([-0.03 * k, 0.02 * k, 0.01 * k])
    else:
        raise ValueError(f"unknown motion {motion!r} (use {', '.join(MOTIONS)})")
    R = cv2.Rodrigues(np.array(turn, np.float64))[0] @ camera.R
    return camera.with_pose(R, -R @ (camera.center + move))


def write_video(path: Path, photos) -> None:
    """Grey ``photos`` ((H, W) uint8, an iterable) as an MPEG-4 part 2 video at :data:`RATE`
    frames/s and 8 Mbit/s (every FFmpeg build has that encoder; the track reads what FFmpeg reads)."""
    import av

    with av.open(str(path), "w") as container:
        stream = None
        for grey in photos:
            if stream is None:
                stream = container.add_stream("mpeg4", rate=RATE)
                stream.width, stream.height = grey.shape[1], grey.shape[0]
                stream.pix_fmt, stream.bit_rate = "yuv420p", 8_000_000
            rgb = np.ascontiguousarray(np.repeat(grey[..., None], 3, axis=2))
            for packet in stream.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                container.mux(packet)
        if stream is not None:
            for packet in stream.encode():
                container.mux(packet)


def make_walk(
    scene: Scene,
    camera: Camera,
    motion: str,
    frames: int,
    folder: Path,
    name: str | None = None,
    progress=None,
    key: bytes = b"",
) -> Walk:
    """The walk ``motion`` of ``frames`` frames from ``camera`` over ``scene`` (no clutter, no
    part left out: the track's figures are its speed and drift) as ``folder/NAME-Nf-DIGEST.mp4``;
    ``progress(done, total)`` after every photo. The video is kept: made again only when its
    digest changes (of ``key``, the scene's name, the camera, the path and the sources of the
    photos, the scenes and this module; the walk's older videos are deleted then), so that a
    second run times the track, not Open3D.
    ``key``: what else the scene depends on (its files' contents)."""
    name = name or f"{scene.name}-{motion}"
    truths = [walk_camera(camera, motion, k) for k in range(frames)]

    def photos():
        for k, truth in enumerate(truths):
            yield synthetic_photo(scene, truth, 0, clutter=0, leave_out=False)[0]
            if progress:
                progress(k + 1, frames)

    stem = f"{name}-{frames}f"
    video = Path(folder) / f"{stem}-{_digest(scene, camera, motion, frames, key)}.mp4"
    if not video.exists():
        video.parent.mkdir(parents=True, exist_ok=True)
        handle, tmp = tempfile.mkstemp(suffix=".mp4", dir=video.parent, prefix=f".{name}.")
        os.close(handle)
        try:
            write_video(Path(tmp), photos())
            replace_output(tmp, video)  # whole or not at all: a broken run leaves no half video
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        for stale in video.parent.glob(f"{stem}-*.mp4"):  # made by other code or for another scene
            if stale != video:
                stale.unlink()
    rough = truths[0].with_pose(cv2.Rodrigues(np.array(_ROUGH_TURN))[0] @ truths[0].R, truths[0].t)
    return Walk(name, video, camera.with_pose(np.eye(3), np.zeros(3)), rough, truths, scene_points(scene, camera))


def _digest(scene: Scene, camera: Camera, motion: str, frames: int, key: bytes) -> str:
    from mrcheck.eval import edgephotos, edgescenes

    h = hashlib.sha256(key + scene.name.encode() + motion.encode() + str(frames).encode())
    for array in (camera.K, camera.R, camera.t, camera.dist, np.array([camera.width, camera.height])):
        h.update(np.ascontiguousarray(array, np.float64).tobytes())
    for module in (edgephotos, edgescenes):
        h.update(Path(module.__file__).read_bytes())
    h.update(Path(__file__).read_bytes())
    return h.hexdigest()[:12]


__all__ = ["Walk", "MOTIONS", "RATE", "walk_camera", "write_video", "make_walk"]
