"""Which camera Live tracks with (issue 42): one place that :class:`.livesession.LiveTracker` and
the freeze ask.

* ``--live-intrinsics CAM.json`` (any camera file :func:`mrcheck.core.camerafiles.read_camera`
  reads: our JSON or OpenCV's YAML, with distortion): source ``"file"``. It wins over a
  calibrated camera at start.
* Else the camera the page's "Calibrate" last solved (:mod:`.calibrator`), kept in
  ``review-camera/camera.json`` beside the review database, loaded again at the next start:
  source ``"calibrated"``. A solve in the page makes it Live's camera even over
  ``--live-intrinsics``: the planner asked for it just now.
* Else each shot's own intrinsics at its served size, as before there were any: source None.

With intrinsics of its own, Live takes them at their own width and height (the page sends its
frames at that size, ``GET /api/live/camera``) and only the pose from the shot it starts at.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

from mrcheck.apps.names import LIVE_CAMERA, REVIEW_CAMERA
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_camera, write_camera
from mrcheck.core.errors import MrcheckError, warn

FILE, CALIBRATED = "file", "calibrated"


@dataclass(frozen=True)
class LiveIntrinsics:
    """Live's own intrinsics: the camera (no pose), where it came from (FILE or CALIBRATED) and its file."""

    camera: Camera
    source: str
    path: Path


def calibrated_path(db_path: Path) -> Path:
    """The camera "Calibrate" saves: ``review-camera/camera.json`` beside the review database."""
    return Path(db_path).parent / REVIEW_CAMERA / LIVE_CAMERA


def read_intrinsics(path) -> LiveIntrinsics:
    """``--live-intrinsics``: the camera file read (MrcheckError naming it when it cannot be)."""
    return LiveIntrinsics(read_camera(path), FILE, Path(path))


class LiveCamera:
    """Live's intrinsics (module docstring); thread-safe (routes run on a thread pool)."""

    def __init__(self, db_path: Path, given: LiveIntrinsics | None = None):
        self.path = calibrated_path(db_path)
        self.lock = threading.Lock()
        self.found = self._saved()  # the calibrated camera at start, whether or not it is used
        self.current = given or self.found

    def _saved(self) -> LiveIntrinsics | None:
        if not self.path.is_file():
            return None
        try:
            return LiveIntrinsics(read_camera(self.path), CALIBRATED, self.path)
        except MrcheckError as exc:  # a damaged file must not stop the review: Calibrate writes a new one
            warn(f"{exc.problem}; not used (Calibrate again to replace it)", self.path)
            return None

    def intrinsics(self) -> LiveIntrinsics | None:
        with self.lock:
            return self.current

    def for_shot(self, shot) -> Camera:
        """The camera Live tracks with from ``shot``: its own intrinsics at the shot's pose, else
        the shot's served camera."""
        own = self.intrinsics()
        served = shot.served_camera()
        return served if own is None else own.camera.with_pose(served.R, served.t)

    def save(self, camera: Camera, extra: dict) -> LiveIntrinsics:
        """A calibrated camera written (atomically, intrinsics only, ``extra`` as ``mrcheck
        calibrate`` writes it) and made Live's."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_camera(self.path, camera, extra, pose=False)
        saved = LiveIntrinsics(camera, CALIBRATED, self.path)
        with self.lock:
            self.current = saved
        return saved

    def describe(self) -> dict:
        """What ``GET /api/live/camera`` answers: the size frames are sent at (None: the shot's) and the source."""
        own = self.intrinsics()
        if own is None:
            return {"width": None, "height": None, "source": None}
        return {"width": own.camera.width, "height": own.camera.height, "source": own.source}

    def lines(self) -> list:
        """What the server says at start about Live's camera."""
        own = self.current
        if own is None:
            return ["live: each shot's own intrinsics (Calibrate in the page, or --live-intrinsics CAM.json)"]
        size = f"{own.camera.width}x{own.camera.height}, fx {own.camera.fx:.1f}"
        if own.source == FILE:
            beaten = f"; it wins over the calibrated {self.found.path}" if self.found else ""
            return [f"live: intrinsics of --live-intrinsics {own.path} ({size}){beaten}"]
        return [f"live: intrinsics calibrated in the page, {own.path} ({size}); --live-intrinsics would win"]


__all__ = ["LiveCamera", "LiveIntrinsics", "calibrated_path", "read_intrinsics", "FILE", "CALIBRATED"]
