"""Where a video frame's snap starts: the constant-velocity prediction, and when and from where a
frame lost within a lost stretch is snapped again (relocalisation).

The frames are :class:`mrcheck.apps.track.FramePose` records (``frame``, ``camera``, ``lost``).
"""

from __future__ import annotations

import cv2

from mrcheck.core.camera import Camera

# relocalisation within a lost stretch: after RELOCALISE_AFTER lost frames in a row, and every
# RELOCALISE_EVERY frames after that, a frame still lost from the coasting prediction is snapped
# once more coarse to fine (mrcheck.apps.track.RELOCALISE_OPTIONS: the chamfer search up to 48 px)
# from the last good pose, where an object that left the view or was covered is most likely to
# come back; not sooner: a frame or two lost on a walk (a blank frame) is caught by the prediction
RELOCALISE_AFTER = 3
RELOCALISE_EVERY = 5
# the relocalisation also starts from the best-supported of the last RECENT_GOOD good frames (see
# relocalisation_anchors): 2.4 s of a 25 frames/s video
RECENT_GOOD = 60
MAX_STRETCH = 4.0  # a timed prediction moves on at most this many times the last frame-to-frame motion


def predicted(previous: list, time_s: float | None = None) -> Camera:
    """Constant velocity: the last pose moved once more by the motion between the last two; a
    frame found again after a lost stretch moves by the mean motion per frame since the last good
    frame before the stretch (the lost frames' poses are guesses, not motion). ``time_s``: the
    new frame's time, for frames that come at irregular intervals (a live camera's, of which the
    server takes what it has time for): the motion is then scaled by the time since the last
    frame over the time between the last two (at most :data:`MAX_STRETCH`)."""
    last = previous[-1].camera
    if len(previous) < 2:
        return last
    if previous[-2].lost and not previous[-1].lost:
        good = [f for f in previous[:-1] if not f.lost]
        if not good:
            return last
        return _mean_motion(good[-1], previous[-1])
    before = previous[-2].camera
    gap = None if time_s is None else previous[-1].time_s - previous[-2].time_s
    if gap is not None and gap > 0:
        return _moved(before, last, min(max((time_s - previous[-1].time_s) / gap, 0.0), MAX_STRETCH))
    dR = last.R @ before.R.T  # X_cam' = dR X_cam + dt between the two frames
    dt = last.t - dR @ before.t
    return last.with_pose(dR @ last.R, dR @ last.t + dt)


def _moved(a: Camera, b: Camera, share: float) -> Camera:
    """``b``'s pose moved on by ``share`` times the motion from ``a`` to it (rotation angle and
    camera centre travel scaled)."""
    dR = cv2.Rodrigues(cv2.Rodrigues(b.R @ a.R.T)[0] * share)[0]
    R = dR @ b.R
    return b.with_pose(R, -R @ (b.center + share * (b.center - a.center)))


def _mean_motion(first, last) -> Camera:
    """``last``'s pose moved by the mean motion per frame from ``first`` to it: the rotation's
    angle and the camera centre's travel split evenly over the frames between."""
    frames = last.frame - first.frame
    a, b = first.camera, last.camera
    rvec = cv2.Rodrigues(b.R @ a.R.T)[0] / frames
    dR = cv2.Rodrigues(rvec)[0]
    R = dR @ b.R
    centre = b.center + (b.center - a.center) / frames
    return b.with_pose(R, -R @ centre)


def lost_run(previous: list) -> int:
    """How many frames at the end of ``previous`` are lost in a row."""
    run = 0
    for f in reversed(previous):
        if not f.lost:
            break
        run += 1
    return run


def relocalise_now(previous: list) -> bool:
    """Whether this frame, if lost from its prediction, is snapped again from the last good pose
    (see :data:`RELOCALISE_AFTER`)."""
    run = lost_run(previous)
    return run >= RELOCALISE_AFTER and (run - RELOCALISE_AFTER) % RELOCALISE_EVERY == 0


def relocalisation_anchors(previous: list, initial: Camera) -> list[tuple[str, Camera]]:
    """``(what, pose)`` pairs a relocalisation starts from: the last good pose (``initial``'s
    before any) and, when another of the last :data:`RECENT_GOOD` good frames had more support,
    the best supported of them (the latest of equals). Why the second: a frame that ends with
    little support above the lost threshold is kept, yet may hold the wrong place (measured on the
    real box video with the tutorial's nominal camera and ``--outline``: frame 215 kept at 31 %
    support, its pose mostly out of view, and every relocalisation from it found "only 23 visible
    CAD edge samples" for the remaining 240 frames; the best supported recent frame, 70-90 %
    before the slide, brought them back: 7 frames lost instead of 256). The last good pose stays
    the first: on a walk it lies nearest to where the camera is now."""
    good = [f for f in previous if not f.lost][-RECENT_GOOD:]
    if not good:
        return [("the start", initial)]
    last = good[-1]
    best = max(reversed(good), key=lambda f: f.support)
    out = [("the last good pose", last.camera)]
    if best.support > last.support:
        out.append((f"frame {best.frame}'s pose (the best supported of the last {len(good)} good)", best.camera))
    return out


__all__ = [
    "MAX_STRETCH",
    "RELOCALISE_AFTER",
    "RELOCALISE_EVERY",
    "RECENT_GOOD",
    "predicted",
    "lost_run",
    "relocalise_now",
    "relocalisation_anchors",
]
