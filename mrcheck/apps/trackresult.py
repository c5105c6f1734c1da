"""The records of ``mrcheck track``: each frame's pose (:class:`FramePose`, a line of
``poses.jsonl``) and the whole run (:class:`TrackResult`); made by :mod:`mrcheck.apps.track`,
read by the review's live session and the benches."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mrcheck.core.camera import Camera


@dataclass
class FramePose:
    """The pose of one frame and how it was found (see the module docstring)."""

    frame: int
    time_s: float
    camera: Camera
    rms_px: float | None
    support: float
    corner_px: list
    lost: bool
    reason: str = ""
    seconds: float = 0.0
    times_s: dict = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        out = {
            "frame": self.frame,
            "time_s": round(self.time_s, 4),
            "R": self.camera.R.tolist(),
            "t": self.camera.t.tolist(),
            "rms_px": None if self.rms_px is None else round(self.rms_px, 4),
            "support": round(self.support, 4),
            "corner_px": [round(v, 3) for v in self.corner_px],
            "lost": self.lost,
            "seconds": round(self.seconds, 3),
        }
        if self.lost:
            out["reason"] = self.reason
        return out


@dataclass
class TrackResult:
    """``frames``: every frame's :class:`FramePose`; ``seconds``: wall time of the whole run;
    ``first_s``: of it, the time until the first frame was handed to the writer (the start-up
    and the first frame's full snap from the rough pose);
    ``times_s``: seconds per stage over the run (``decode wait``, ``snap <stage>`` of
    :attr:`mrcheck.mr.edges.EdgeFit.times_s`, ``overlay render``, ``writer wait``; ``decode
    (thread)`` and ``photo (thread)`` ran on the reader's thread, ``compose (thread)`` and
    ``encode (thread)`` on the writer's, beside the others)."""

    frames: list = field(default_factory=list)
    seconds: float = 0.0
    first_s: float = 0.0
    times_s: dict = field(default_factory=dict)

    @property
    def lost(self) -> list:
        return [f.frame for f in self.frames if f.lost]

    @property
    def fps(self) -> float:
        return len(self.frames) / self.seconds if self.seconds > 0 else math.inf

    @property
    def fps_after_first(self) -> float:
        """Frames per second after the first frame (the tracking rate; nan for a single frame)."""
        later = self.seconds - self.first_s
        return (len(self.frames) - 1) / later if len(self.frames) > 1 and later > 0 else math.nan

    def summary_line(self) -> str:
        rate = f"{self.fps:.2f} frames/s"
        if len(self.frames) > 1:
            rate += f"; {self.fps_after_first:.2f} after the first frame, which took {self.first_s:.2f} s"
        return (
            f"tracked {len(self.frames)} frames in {self.seconds:.2f} s ({rate}); "
            f"lost: {', '.join(map(str, self.lost)) or 'none'}"
        )

    def stage_line(self) -> str:
        """The stages' seconds, largest first."""
        stages = sorted(self.times_s.items(), key=lambda kv: -kv[1])
        return "time per stage (s): " + ", ".join(f"{k} {v:.2f}" for k, v in stages if v >= 0.005)

    def lost_lines(self) -> list[str]:
        return [
            f"  frame {f.frame} lost ({f.reason}): its pose is the prediction, not trusted"
            for f in self.frames
            if f.lost
        ]


__all__ = ["FramePose", "TrackResult"]
