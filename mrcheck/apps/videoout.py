"""An MP4 writer that composes and encodes its frames on a background thread (``mrcheck track``).

Why a thread: on this 2-core machine the tracking loop keeps one core busy (the snap's numpy and
OpenCV work, the GL renders), while the overlay's compose (``cv2.remap`` through the lens and the
blend) and the H.264 encode (FFmpeg through PyAV) release the GIL for most of their time; done
beside the next frame's snap they cost the loop only the hand-over. Measured on the crate walk
(640x480): compose about 15 ms and encode about 35 ms per frame (load 0.7).

A frame is handed over as a *job*: a callable returning the (H, W, 3) uint8 RGB image, so that the
compose runs on the thread too. The queue is short (:data:`QUEUE_FRAMES`): a slow encoder holds
the loop back instead of piling up frames in memory. An error on the thread is raised again in the
caller's thread by the next :meth:`BackgroundVideo.put` or by :meth:`BackgroundVideo.close`.
"""

from __future__ import annotations

import queue
import threading
import time
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import check_size

QUEUE_FRAMES = 2
# x264's "veryfast" preset: its default ("medium") looks 40 frames ahead, so a short video was
# encoded whole at the flush after the last frame (0.3-0.5 s of a 12-frame run at 640x480,
# nothing beside it); veryfast looks 10 ahead and costs about half the CPU time, its files no
# larger on the overlay videos measured
_OPTIONS = {"libx264": {"preset": "veryfast"}}
_STOP = object()


def video_stream(source, video, max_pixels: int):
    """The first video stream of the opened container ``source`` (of the file ``video``), or a
    one-line error: a file without one (an MP4 of audio only), or frames of more than
    ``max_pixels`` pixels (``mrcheck --max-pixels``, from the stream's header before a frame is
    decoded)."""
    if not source.streams.video:
        raise MrcheckError("has no video stream (audio only?)", video)
    stream = source.streams.video[0]
    check_size(stream.codec_context.width, stream.codec_context.height, max_pixels, video, "video frame")
    return stream


def open_writer(path: Path, width: int, height: int, rate):
    """``(container, stream)``: an MP4 of H.264 (MPEG-4 part 2 where FFmpeg lacks an H.264
    encoder), even width and height (yuv420p needs them)."""
    import av

    container = av.open(str(path), "w", format="mp4")
    for codec in ("libx264", "h264", "mpeg4"):
        try:
            stream = container.add_stream(codec, rate=rate, options=_OPTIONS.get(codec, {}))
            break
        except (ValueError, av.error.FFmpegError):  # not in this FFmpeg build
            continue
    else:
        container.close()
        raise MrcheckError("FFmpeg (PyAV) has no H.264 or MPEG-4 encoder", path)
    stream.width, stream.height, stream.pix_fmt = width - width % 2, height - height % 2, "yuv420p"
    return container, stream


class BackgroundVideo:
    """Write frames to ``path`` (MP4) on a thread; ``times_s`` holds its ``compose`` and ``encode``
    seconds (the thread's own, beside the caller's work)."""

    def __init__(self, path: Path, width: int, height: int, rate):
        self.container, self.stream = open_writer(path, width, height, rate)
        self.times_s = {"compose": 0.0, "encode": 0.0}
        self._queue: queue.Queue = queue.Queue(maxsize=QUEUE_FRAMES)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="mrcheck-video-writer", daemon=True)
        self._thread.start()

    def put(self, job) -> None:
        """Queue ``job()`` (returns the frame's RGB image); waits while the queue is full."""
        self._raise_error()
        self._queue.put(job)

    def close(self) -> None:
        """Write the queued frames, flush the encoder and close the file; raises the thread's error."""
        self._queue.put(_STOP)
        self._thread.join()
        try:
            self._raise_error()
            for packet in self.stream.encode():
                self.container.mux(packet)
        finally:
            self.container.close()

    def abort(self) -> None:
        """Stop without flushing (the caller failed); the file is left for the caller to delete."""
        while True:  # empty the queue so that the thread sees the stop at once
            try:
                self._queue.get_nowait()
            except queue.Empty:
                break
        self._queue.put(_STOP)
        self._thread.join()
        self.container.close()

    def _raise_error(self) -> None:
        if self._error is not None:
            raise self._error

    def _run(self) -> None:
        import av

        while True:
            job = self._queue.get()
            if job is _STOP:
                return
            if self._error is not None:
                continue  # drain: the caller sees the error at its next put or close
            try:
                began = time.perf_counter()
                image = np.ascontiguousarray(job()[: self.stream.height, : self.stream.width])
                encoded = time.perf_counter()
                for packet in self.stream.encode(av.VideoFrame.from_ndarray(image, format="rgb24")):
                    self.container.mux(packet)
                self.times_s["compose"] += encoded - began
                self.times_s["encode"] += time.perf_counter() - encoded
            except BaseException as exc:  # noqa: BLE001 -- re-raised in the caller's thread
                self._error = exc


__all__ = ["BackgroundVideo", "open_writer", "video_stream", "QUEUE_FRAMES"]
