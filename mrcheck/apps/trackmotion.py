"""Where a video frame's snap starts: the constant-velocity prediction, and when a frame lost
within a lost stretch is snapped again from the last good pose (relocalisation).

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


def predicted(previous: list) -> Camera:
    """Constant velocity: the last pose moved once more by the motion between the last two; a
    frame found again after a lost stretch moves by the mean motion per frame since the last good
    frame before the stretch (the lost frames' poses are guesses, not motion)."""
    last = previous[-1].camera
    if len(previous) < 2:
        return last
    if previous[-2].lost and not previous[-1].lost:
        good = [f for f in previous[:-1] if not f.lost]
        if not good:
            return last
        return _mean_motion(good[-1], previous[-1])
    before = previous[-2].camera
    dR = last.R @ before.R.T  # X_cam' = dR X_cam + dt between the two frames
    dt = last.t - dR @ before.t
    return last.with_pose(dR @ last.R, dR @ last.t + dt)


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


def last_good(previous: list, initial: Camera) -> Camera:
    """The pose of the last frame not lost (``initial``'s before any)."""
    for f in reversed(previous):
        if not f.lost:
            return f.camera
    return initial


__all__ = ["RELOCALISE_AFTER", "RELOCALISE_EVERY", "predicted", "lost_run", "relocalise_now", "last_good"]
