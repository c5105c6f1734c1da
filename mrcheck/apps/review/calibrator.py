"""The review's "Calibrate this camera" (issue 42): the page sends a video frame of the device's
camera every half second or so; the board is looked for in each (:meth:`Board.detect`) and its
corners kept as a view when it is found and the view differs enough from those kept; "Solve"
calibrates from them as ``mrcheck calibrate`` does (:func:`mrcheck.mr.calibration.calibrate_views`:
outlier views rejected) and makes the camera Live's (:mod:`.livecamera`, which saves it).

Frames are never stored: each is decoded, searched and dropped; only the corners of a kept view
stay, in memory. One calibration per server: a new start (the page's "Calibrate") resets it.

A near-duplicate view adds nothing but weight (a still camera would fill the set with one view,
and Zhang's method needs the board seen at different tilts). A view is kept only when, against
every view kept, its board's centre moved by more than :data:`MIN_SHIFT` of the image diagonal,
or its size (square root of the area its corners cover) changed by more than :data:`MIN_SCALE`,
or its plane turned by more than :data:`MIN_TURN_DEG` (the board's normal, from its pose with a
guessed camera: the guess skews the angle a little, but the same view gives the same angle).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import decode_image, max_pixels
from mrcheck.mr.boards import Board, parse_board
from mrcheck.mr.calibration import DEFAULT_MIN_VIEWS, calibrate_views, poorly_determined

MAX_VIEWS = 40  # kept at most: 40 varied views determine a camera well; more only slow the solve
MIN_SHIFT = 0.05  # of the image diagonal: 40 px at 640x480, far above a still camera's jitter (< 1 px)
MIN_SCALE = 0.1  # log of the size ratio: the board 10 % nearer or farther
MIN_TURN_DEG = 8.0  # the board's plane turned: a held board wobbles by a degree or two
GUESSED_FOV_DEG = 65.0  # horizontal field of view of the guessed camera (a tablet's rear camera: 60-70 deg)


@dataclass(frozen=True)
class Footprint:
    """Where a view's board lies in the image: its centre (in image diagonals), its size and its normal."""

    centre: np.ndarray
    size: float
    normal: np.ndarray

    def differs(self, other: "Footprint") -> bool:
        turn = math.degrees(math.acos(min(1.0, abs(float(self.normal @ other.normal)))))
        return (
            float(np.linalg.norm(self.centre - other.centre)) > MIN_SHIFT
            or abs(math.log(self.size / other.size)) > MIN_SCALE
            or turn > MIN_TURN_DEG
        )


def footprint(obj: np.ndarray, img: np.ndarray, width: int, height: int) -> Footprint:
    """The :class:`Footprint` of a view (object and image points as :meth:`Board.detect` gives them)."""
    diagonal = math.hypot(width, height)
    hull = cv2.convexHull(img.astype(np.float32))
    size = math.sqrt(max(cv2.contourArea(hull), 1e-6)) / diagonal
    f = width / (2 * math.tan(math.radians(GUESSED_FOV_DEG) / 2))
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1]], np.float64)
    ok, rvec, _ = cv2.solvePnP(obj.astype(np.float64), img.astype(np.float64), K, None, flags=cv2.SOLVEPNP_IPPE)
    normal = cv2.Rodrigues(rvec)[0][:, 2] if ok else np.array([0.0, 0.0, 1.0])
    return Footprint(img.mean(axis=0) / diagonal, size, normal)


class Calibrator:
    """The server's one calibration session (module docstring); thread-safe."""

    def __init__(self, board: str | None = None):
        self.default_board = board  # --board, what the page offers first
        self.lock = threading.Lock()
        self.board: Board | None = None
        self.views: dict = {}  # name -> (object points, image points)
        self.footprints: list[Footprint] = []
        self.size: tuple | None = None
        self.session = 0  # a new start makes a frame searched under the old one count for nothing
        self.frames = 0

    def start(self, spec: str) -> dict:
        """A new calibration with the board ``spec`` (MrcheckError for a bad SPEC)."""
        board = parse_board(spec)
        with self.lock:
            self.board, self.views, self.footprints, self.size = board, {}, [], None
            self.session += 1
            self.frames = 0
            return self._state()

    def state(self) -> dict:
        with self.lock:
            return self._state()

    def _state(self) -> dict:
        return {
            "board": self.board.spec if self.board else self.default_board,
            "started": self.board is not None,
            "views": len(self.views),
            "needed": DEFAULT_MIN_VIEWS,
            "max": MAX_VIEWS,
            "width": self.size and self.size[0],
            "height": self.size and self.size[1],
        }

    def frame(self, data: bytes) -> dict:
        """One video frame (JPEG or PNG) searched for the board: {found, kept, reason, corners,
        ...state}. MrcheckError when no calibration was started or the frame is no image."""
        with self.lock:
            board, session = self.board, self.session
        if board is None:
            raise MrcheckError("start a calibration (POST api/calibrate/start with the board) before sending frames")
        grey = decode_image(data, what="the frame (a JPEG or PNG image)", grey=True, max_pixels=max_pixels())
        height, width = grey.shape
        found = board.detect(grey)  # the slow part (up to 0.5 s without a board), outside the lock
        del grey  # frames are never stored
        with self.lock:
            if session != self.session:
                return {"found": False, "kept": False, "reason": "a new calibration was started", **self._state()}
            self.frames += 1
            kept, reason = self._keep(found, width, height)
            corners = [] if found is None else np.round(found[1], 1).tolist()
            return {"found": found is not None, "kept": kept, "reason": reason, "corners": corners, **self._state(),
                    "frame_width": width, "frame_height": height}  # fmt: skip

    def _keep(self, found, width: int, height: int) -> tuple[bool, str]:
        if found is None:
            return False, "board not found"
        if self.size is not None and self.size != (width, height):
            return False, (
                f"the frame is {width}x{height} but the views kept are {self.size[0]}x{self.size[1]}: "
                "one camera at one size; Calibrate again to start over"
            )
        if len(self.views) >= MAX_VIEWS:
            return False, f"{MAX_VIEWS} views kept, the most: Solve"
        new = footprint(*found, width, height)
        if not all(new.differs(old) for old in self.footprints):
            return False, "like a view kept: move, turn or tilt the board (or the camera)"
        self.views[f"view-{len(self.views) + 1}"] = found
        self.footprints.append(new)
        self.size = (width, height)
        return True, "kept"

    def solve(self, live_camera) -> dict:
        """The camera of the views kept (outliers rejected), saved and made Live's
        (:meth:`.livecamera.LiveCamera.save`); MrcheckError when there are too few views."""
        with self.lock:
            board, views, size = self.board, dict(self.views), self.size
        if board is None or len(views) < DEFAULT_MIN_VIEWS:
            raise MrcheckError(
                f"{len(views)} views kept, need at least {DEFAULT_MIN_VIEWS}: show the board at more places and tilts"
            )
        solved = calibrate_views(views, size, board, DEFAULT_MIN_VIEWS)
        extra = {
            "rms": solved.rms,
            "per_view_errors": solved.per_view_errors,
            "rejected_views": list(solved.rejected),
            "std": solved.std,
            "board": board.spec,
        }
        saved = live_camera.save(solved.camera, extra)
        camera = solved.camera
        return {
            "rms_px": round(solved.rms, 4),
            **{k: round(float(getattr(camera, k)), 3) for k in ("fx", "fy", "cx", "cy")},
            "dist": [round(float(d), 6) for d in camera.dist],
            "std": {
                k: (round(v, 3) if isinstance(v, float) else [round(d, 6) for d in v]) for k, v in solved.std.items()
            },
            "views": len(views),
            "rejected": list(solved.rejected),
            "width": camera.width,
            "height": camera.height,
            "path": str(saved.path),
            "warning": poorly_determined(camera, solved.std),
        }


__all__ = ["Calibrator", "Footprint", "footprint", "MAX_VIEWS"]
