"""``mrcheck track``'s background video writer (mrcheck.apps.videoout): frames composed and encoded
on a thread, in order, and an error there raised in the caller's thread, no file left half-used."""

from __future__ import annotations

import threading

import av
import numpy as np
import pytest

from mrcheck.apps.track import TrackResult
from mrcheck.apps.videoout import BackgroundVideo


def _frame(k: int) -> np.ndarray:
    image = np.zeros((48, 64, 3), np.uint8)
    image[:, 4 * k : 4 * k + 8] = 255  # a bright bar moving right: the order is visible
    return image


def test_frames_are_written_in_order_on_another_thread(tmp_path):
    path = tmp_path / "out.mp4"
    writer = BackgroundVideo(path, 64, 48, 10)
    threads = []

    def job(k):
        threads.append(threading.current_thread())
        return _frame(k)

    for k in range(8):
        writer.put(lambda k=k: job(k))
    writer.close()
    assert threads and all(t is not threading.main_thread() for t in threads)
    assert writer.times_s["compose"] >= 0 and writer.times_s["encode"] > 0
    with av.open(str(path)) as video:
        frames = [f.to_ndarray(format="rgb24") for f in video.decode(video=0)]
    assert len(frames) == 8
    bars = [int(np.argmax(f[24, :, 0].astype(int))) for f in frames]
    assert bars == sorted(bars) and bars[-1] > bars[0]


def test_an_error_on_the_thread_is_raised_by_close(tmp_path):
    writer = BackgroundVideo(tmp_path / "out.mp4", 64, 48, 10)
    writer.put(lambda: _frame(0))

    def broken():
        raise ValueError("compose failed")

    writer.put(broken)
    with pytest.raises(ValueError, match="compose failed"):
        try:
            for k in range(20):  # a later put may raise it already
                writer.put(lambda k=k: _frame(k % 10))
        except ValueError:
            writer.abort()  # what track_video does when a put fails
            raise
        writer.close()


def test_the_stage_line_lists_the_stages_largest_first():
    result = TrackResult(times_s={"decode": 0.1, "snap match": 0.9, "overlay render": 0.5, "tiny": 0.001})
    line = result.stage_line()
    assert line.index("snap match 0.90") < line.index("overlay render 0.50") < line.index("decode 0.10")
    assert "tiny" not in line
