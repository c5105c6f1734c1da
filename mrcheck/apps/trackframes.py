"""The frames of ``mrcheck track``'s video, decoded and made into the snap's gradient pyramid one
frame ahead on a thread (:class:`FrameReader`), each as a :class:`FramePhoto`."""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.mr.edges import EdgeOptions, photo_pyramid


@dataclass
class FramePhoto:
    """A decoded frame: its RGB image, time, grey photo and the snap's gradient pyramid of it."""

    rgb: np.ndarray
    time_s: float
    grey: np.ndarray
    pyramid: list


class FrameReader:
    """The video's frames, each decoded, made grey and turned into the snap's gradient pyramid
    (:func:`~mrcheck.mr.edges.photo_pyramid`) one frame ahead on a thread. Why: FFmpeg's decode
    and OpenCV's filters release the GIL, so the next frame's 15 ms of them (the cell's walks:
    decode 4-6 ms, pyramid 10) run on the second core beside this frame's snap (mostly numpy on
    one core) instead of before the next one (measured: docs/edge-registration.md, Figures).
    ``options_for(k)``: the snap's options for frame k (their pyramid levels and filters).
    ``times_s``: the thread's ``decode`` and ``photo`` seconds; an error on the thread (a corrupt
    frame) is raised by :meth:`next`."""

    def __init__(self, frames, options_for: Callable[[int], EdgeOptions]):
        self._frames = frames
        self._options_for = options_for
        self.times_s = {"decode": 0.0, "photo": 0.0}
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mrcheck-video-reader")
        self._read_count = 0
        self._next = self._pool.submit(self._read)

    def _read(self) -> FramePhoto | None:
        began = time.perf_counter()
        frame = next(self._frames, None)
        if frame is None:
            return None
        options = self._options_for(self._read_count)
        self._read_count += 1
        rgb = frame.to_ndarray(format="rgb24")
        decoded = time.perf_counter()
        self.times_s["decode"] += decoded - began
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        photo = FramePhoto(rgb, float(frame.time or 0.0), grey, photo_pyramid(grey, options))
        self.times_s["photo"] += time.perf_counter() - decoded
        return photo

    def next(self) -> FramePhoto | None:
        """The next frame (None after the last); the one after it is started on the thread."""
        photo = self._next.result()
        self._next = self._pool.submit(self._read) if photo is not None else None
        return photo

    def close(self) -> None:
        """Wait for the thread (the video is closed after this)."""
        self._pool.shutdown(wait=True)


__all__ = ["FramePhoto", "FrameReader"]
