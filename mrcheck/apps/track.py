"""``mrcheck track VIDEO``: the CAD snapped onto every frame of a video, and the overlay video.

Each frame starts from the previous frames' poses with a constant-velocity prediction (the last
motion applied once more) and is snapped onto the frame's edges
(:func:`mrcheck.mr.edges.refine_pose`: the first frame coarse to fine from ROUGH.json, the
others on one level with a search radius for frame-to-frame motion, the renderer, the scene's
edges and the edges seen reused, and the visible edges found on the frame before's overlay
render instead of a render of their own; the next frame decoded and its gradient pyramid made on
a thread beside this one's snap). A frame whose fit fails or ends with its support below
:data:`LOST_SUPPORT` is snapped once more with a render of its own (:data:`RETRY_OPTIONS`; not
when the frame before was lost too); failing again it is *lost*: its pose is the prediction, not
trusted, the next frame starts from it, and ``poses.jsonl`` says so. Within a lost stretch a
frame still lost is snapped once more coarse to fine from the last good pose, and from the best
supported recent one when that is another (:data:`RELOCALISE_OPTIONS`, when
:func:`mrcheck.apps.trackmotion.relocalise_now` says: after three lost frames, then every
fifth; :func:`~mrcheck.apps.trackmotion.relocalisation_anchors`), so that the track comes back
when the object does; the frame found again starts the next one with the mean motion since the
last good frame. The overlay (vector AO at
half resolution, lens distortion as calibrated) is drawn at every frame's pose, lost ones
included, so that the video shows what the log says; a lost frame whose predicted pose lies
inside a part is written without overlay (its ``reason`` says so).

``poses.jsonl``: one JSON object per frame: ``frame``, ``time_s``, ``R``, ``t``, ``rms_px``,
``support``, ``corner_px`` (the four corners' 1-sigma), ``lost`` (bool), ``reason`` (lost only),
``seconds`` (the snap's time).

Video read and written with PyAV (FFmpeg); the output is H.264 (MPEG-4 part 2 where FFmpeg
lacks an H.264 encoder), written to a temporary file and renamed when complete.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

from threadpoolctl import threadpool_limits

from mrcheck.apps.trackframes import FramePhoto, FrameReader
from mrcheck.apps.trackmotion import predicted, relocalisation_anchors, relocalise_now
from mrcheck.apps.trackresult import FramePose, TrackResult
from mrcheck.apps.videoout import BackgroundVideo, video_stream
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera, read_camera
from mrcheck.core.errors import MrcheckError, warn
from mrcheck.core.images import max_pixels
from mrcheck.core.inputs import check_input
from mrcheck.core.output import check_not_inputs, check_output_path, replace_output, write_text
from mrcheck.core.partials import partial_prefix, remove_stale_partials
from mrcheck.mr.edges import EdgeFitError, EdgeOptions, VisibilityRender, refine_pose, scene_edges
from mrcheck.mr.edges.candidates import CandidateEdges
from mrcheck.mr.lens import distortion_map
from mrcheck.mr.overlay import overlay_images
from mrcheck.mr.registration import fit_camera
from mrcheck.mr.shot import photo_frame
from mrcheck.render.renderer import Renderer
from mrcheck.render.settings import RenderSettings
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

LOST_SUPPORT = 0.25
# frame to frame (after the constant-velocity prediction): one level, the search along the normal,
# 8 px, 800 samples (measured on the crate walk: 0.13 px, 0.4 s per frame at load 9, against
# 0.14 px and 0.75-1.5 s with two levels and 1500 samples); every step kept (descent_only off:
# iteratively reweighted least squares) and 6 iterations: with the cost test of
# Levenberg-Marquardt a frame whose prediction was 2.7 px off kept no step at all (re-matching
# makes the robust cost jump by more than a good step lowers it), the pose stayed at the
# prediction and the walk drifted 5-7 px for 20 frames; measured on ten walks: per-walk median
# 0.07-0.45 px, no frame beyond 1.4 px, against 0.14-0.88 and 13 frames beyond 2 px with 4
# iterations and the cost test (docs/edge-registration.md); the first frame, from ROUGH.json,
# gets the full snap (FIRST_OPTIONS: coarse to fine from up to 48 px off). The visible edges
# are those of the frame before's overlay render for the whole fit (rerender_px inf: no render of
# the snap's own), and the render saved pays for 8 iterations instead of 6; a frame that would be
# lost so is snapped once more with RETRY_OPTIONS. Measured on the six 24-frame cell walks of
# `mrcheck bench --track` against a re-render after 3 px and 6 iterations (four interleaved
# rounds, a process per run): the `robot_cell` walks +2 to +39 % per pair (median +14 to +24 %
# per walk), the `overview` walks -9 to +14 % (medians -4 to +6 %), the crates +5 %; over the
# 144 frames the median error 0.165 -> 0.151 px, the mean 0.242 -> 0.222, frames beyond 1 px
# 6 -> 3, the worst 1.41 -> 1.49 (docs/edge-registration.md)
TRACK_OPTIONS = EdgeOptions(
    search_px=8.0,
    levels=1,
    iterations=8,
    max_samples=800,
    min_support=0.0,
    coarse="normal",
    descent_only=False,
    rerender_px=math.inf,
    restarts=False,
    silhouette=False,  # the outline term (register's default for curved parts) is not measured on video yet
)
# a frame lost with TRACK_OPTIONS, snapped again from its start with a render of its own there and
# the visible edges found again after 3 px of steps (the schedule TRACK_OPTIONS was measured
# against): the frame before's render is a frame's motion old, and where much comes into view or
# goes out of it (the 60-frame `robot_cell` walk, frames 38 and 41) the support it gives falls below
# LOST_SUPPORT; not after a lost frame (see track_frame)
RETRY_OPTIONS = replace(TRACK_OPTIONS, iterations=6, rerender_px=3.0)
# the first frame: 1500 samples instead of register's 3000 (the generated cell from 15-40 px off,
# seeds 0-9 at 640x480: 10 of 10 within 1 px, 0.06-0.37 px, 0.70 s per fit median, against
# 0.06-0.45 px and 0.81 s; the crates the same, they have fewer)
FIRST_OPTIONS = EdgeOptions(min_support=0.0, max_samples=1500, silhouette=False, restarts=False)
# a frame lost within a lost stretch, snapped again from the neighbourhood of the last good pose
# (and of the best supported recent one) when relocalise_now says (mrcheck.apps.trackmotion):
# coarse to fine as from ROUGH.json
RELOCALISE_OPTIONS = FIRST_OPTIONS
# full detail (lod_px 0): the overlay's depth and normals find the next frame's visible edges
# (VisibilityRender), and a simplified mesh moves surfaces off the exact edges' planes
OVERLAY_SETTINGS = RenderSettings(samples=8, ao_scale=0.5, lod_px=0.0)


# ``--outline``: the parts' rendered outlines matched by their colour regions on every frame after
# the first (EdgeOptions.silhouette; register's term for curved parts). Measured (2026-12-08, AMD
# EPYC), frames held within 3 px of 455 with and without it: the real box video from
# tests/test_track_real.py's start (f = 680 px) 454 / 432, from bench --real's clicks 431 / 445,
# with the tutorial's nominal camera 427 / 379; the tea box 39 of 39 either way; the generated
# cell's walks (dozens of parts whose outlines cross) lose 18 of 24 frames each with it, none
# without (bench --track --outline). So: for a few objects filmed in colour, not a hall; off by default.
OUTLINE_OPTIONS = replace(TRACK_OPTIONS, silhouette=True)


def frame_options(index: int, outline: bool = False) -> EdgeOptions:
    """The snap's options of frame ``index`` (0: from ROUGH.json; the reader makes each frame's
    pyramid with them too); ``outline``: ``--outline``'s."""
    if index == 0:
        return FIRST_OPTIONS
    return OUTLINE_OPTIONS if outline else TRACK_OPTIONS


def retry_options(outline: bool = False) -> EdgeOptions | None:
    """The retry's options (:data:`RETRY_OPTIONS`, with ``--outline`` its outlines on)."""
    if RETRY_OPTIONS is None or not outline:
        return RETRY_OPTIONS
    return replace(RETRY_OPTIONS, silhouette=True)


def snap_frame(
    scene,
    camera: Camera,
    grey,
    start: Camera,
    renderer,
    edges,
    options: EdgeOptions = TRACK_OPTIONS,
    candidates: CandidateEdges | None = None,
    seed: VisibilityRender | None = None,
    pyramid: list | None = None,
) -> tuple:
    """``(camera at the pose, fit or None, reason)`` of one frame (``grey``; in colour when
    ``options`` sample outlines) from ``start``; ``candidates``:
    the :class:`~mrcheck.mr.edges.candidates.CandidateEdges` kept from the frames before;
    ``seed``: the frame before's overlay render (its visible edges); ``pyramid``: the frame's
    gradient pyramid made beforehand (see ``refine_pose``)."""
    try:
        fit = refine_pose(
            scene,
            camera,
            grey,
            initial=start,
            options=options,
            renderer=renderer,
            edges=edges,
            candidates=candidates,
            seed=seed,
            pyramid=pyramid,
        )
    except EdgeFitError as exc:
        return start, None, str(exc)
    if fit.support < LOST_SUPPORT:
        return start, fit, f"support {fit.support:.0%} below {LOST_SUPPORT:.0%}"
    return fit.camera, fit, ""


def track_video(
    video,
    scene,
    intrinsics: Camera,
    initial: Camera,
    output,
    poses_path,
    alpha: float = 0.5,
    progress=None,
    outline: bool = False,
) -> TrackResult:
    """Track ``video`` (a path) from the pose of ``initial``; write the overlay video ``output``
    and ``poses_path`` (JSON lines) atomically; ``progress(done, total)`` after every frame;
    ``outline``: ``--outline`` (:data:`OUTLINE_OPTIONS`).

    One renderer (GL context, uploaded scene) and one set of the scene's edges serve the whole
    video; the overlay's compose and encode run on a thread (:class:`BackgroundVideo`) beside the
    next frame's snap, and the lens map of the first frame is made on a thread beside its snap."""
    # numpy's OpenBLAS on one thread: its idle threads spin on the second core after every
    # matrix product, where llvmpipe's rasteriser and the video encoder run (measured on a
    # 60-frame cell walk: 23 s of CPU in 13-14 s wall with the default two threads, 15 s in 12 s
    # with one, the poses identical; see docs/edge-registration.md)
    with threadpool_limits(limits=1, user_api="blas"):
        return _track_video(video, scene, intrinsics, initial, output, poses_path, alpha, progress, outline)


def _track_video(video, scene, intrinsics, initial, output, poses_path, alpha, progress, outline) -> TrackResult:
    import av

    result = TrackResult()
    start_time = time.perf_counter()
    renderer = loop = tmp_video = None
    try:
        with av.open(str(video)) as source:
            stream = video_stream(source, video, max_pixels())
            total = stream.frames or 0
            # the first frame is decoded and its pyramid made beside the start-up below
            reader = FrameReader(source.decode(stream), frame_options)
            try:
                edges = scene_edges(scene)
                renderer = Renderer(scene)
                remove_stale_partials(Path(output).parent, ".track-")  # a killed run's video
                handle, name = tempfile.mkstemp(
                    suffix=".mp4", dir=Path(output).parent, prefix=partial_prefix(".track-")
                )
                os.close(handle)  # the encoder opens the file by its name
                tmp_video = Path(name)
                loop = _Loop(result, scene, intrinsics, initial, renderer, edges, alpha, outline)
                while True:
                    began = time.perf_counter()
                    photo = reader.next()
                    if photo is None:
                        break
                    loop.add("decode wait", began)
                    loop.frame(photo, video, tmp_video, stream.average_rate or 25)
                    if len(result.frames) == 1:
                        result.first_s = time.perf_counter() - start_time
                    if progress:
                        progress(len(result.frames), total)
            finally:
                reader.close()
            if loop.writer is None:
                raise MrcheckError("the video has no frames", video)
            loop.close()
            for stage, seconds in reader.times_s.items():
                result.times_s[f"{stage} (thread)"] = seconds
        write_text(poses_path, "".join(json.dumps(f.to_dict()) + "\n" for f in result.frames))
        replace_output(tmp_video, output)
    except av.error.FFmpegError as exc:
        raise MrcheckError(f"cannot read the video: {exc}", video) from None
    finally:
        if loop is not None:
            loop.abort()
        if renderer is not None:
            renderer.release()
        if tmp_video is not None and tmp_video.exists():
            tmp_video.unlink()
    result.seconds = time.perf_counter() - start_time
    return result


class _Loop:
    """The per-frame work of :func:`track_video` and what the frames share (camera, lens map,
    writer, the stage clock in ``result.times_s``)."""

    def __init__(self, result, scene, intrinsics, initial, renderer, edges, alpha, outline=False):
        self.result, self.scene, self.intrinsics, self.initial = result, scene, intrinsics, initial
        self.renderer, self.edges, self.alpha, self.outline = renderer, edges, alpha, outline
        # the edges seen, kept from frame to frame (not from the first frame's fit: its sample
        # spacing is that of FIRST_OPTIONS' 1500 samples, about twice the candidates to test)
        self.candidates = CandidateEdges(edges)
        self.camera = self.maps = self.writer = None
        self.seed = None  # the last overlay's depth and normals (VisibilityRender), for the next snap
        self._maps_job = None
        self.times = result.times_s

    def add(self, stage: str, began: float) -> float:
        now = time.perf_counter()
        self.times[stage] = self.times.get(stage, 0.0) + now - began
        return now

    def frame(self, photo: FramePhoto, video, tmp_video, rate) -> None:
        rgb = photo.rgb
        if self.camera is None:
            self.camera, rescaled = fit_camera(self.intrinsics, rgb.shape[1], rgb.shape[0], video)
            for warning in rescaled:  # intrinsics of another video mode: their K is a guess at this size
                warn(warning.replace("photo is", "video is", 1), video)
            # the lens map (0.35-0.4 s at 640x480) is made beside the first frame's snap
            self._maps_job = ThreadPoolExecutor(max_workers=1)
            self._maps = self._maps_job.submit(distortion_map, self.camera)
            self.writer = BackgroundVideo(tmp_video, rgb.shape[1], rgb.shape[0], rate)
        pose = track_frame(
            self.result.frames,
            self.scene,
            self.camera,
            photo,
            self.initial,
            self.renderer,
            self.edges,
            len(self.result.frames),
            candidates=self.candidates if self.result.frames else None,
            seed=self.seed,
            outline=self.outline,
        )
        self.seed = None
        for stage, seconds in pose.times_s.items():
            self.times[f"snap {stage}"] = self.times.get(f"snap {stage}", 0.0) + seconds
        self.result.frames.append(pose)
        began = time.perf_counter()
        if self._maps_job is not None:
            self.maps = self._maps.result()
            self._maps_job.shutdown()
            self._maps_job = None
            began = self.add("lens map (wait)", began)
        try:
            frame, view, offset, maps = photo_frame(
                self.renderer, pose.camera, ["vector"], OVERLAY_SETTINGS, self.maps, want_normals=True
            )
        except MrcheckError as exc:
            if not pose.lost:
                raise
            # a lost frame's pose is a prediction, which may lie inside a part (measured: a walk
            # towards the roof coasted into a ceiling pipe): the frame is written without overlay
            # and the log says so, instead of the whole run ending there
            pose.reason += f"; no overlay drawn ({exc.problem})"
            began = self.add("overlay render", began)
            self.writer.put(lambda: rgb)
            self.add("writer wait", began)
            return
        began = self.add("overlay render", began)
        # the next frame's snap finds its visible edges on this render (one render less per frame)
        self.seed = VisibilityRender(view, frame.depth, frame.normals)
        renders, camera, alpha = {"vector": frame["vector"].image}, self.camera, self.alpha
        self.writer.put(lambda: overlay_images(rgb, renders, camera, alpha, offset=offset, maps=maps)["vector"])
        self.add("writer wait", began)

    def close(self) -> None:
        began = time.perf_counter()
        writer, self.writer = self.writer, None
        writer.close()
        self.add("writer close", began)
        for stage, seconds in writer.times_s.items():
            self.times[f"{stage} (thread)"] = seconds

    def abort(self) -> None:
        if self._maps_job is not None:
            self._maps_job.shutdown(wait=True)
            self._maps_job = None
        if self.writer is not None:
            self.writer.abort()
            self.writer = None


def track_frame(
    previous,
    scene,
    camera,
    photo: FramePhoto,
    initial,
    renderer,
    edges,
    index,
    candidates=None,
    seed=None,
    timed=False,
    outline=False,
) -> FramePose:
    """Frame ``index``'s pose from the frames before (``previous``: their :class:`FramePose`;
    ``initial``: the start pose of frame 0): the snap from the constant-velocity prediction, the
    retry and the relocalisation of the module docstring. ``candidates``: the edges seen so far
    (:class:`~mrcheck.mr.edges.candidates.CandidateEdges`, not for frame 0); ``seed``: the frame
    before's overlay render (:class:`~mrcheck.mr.edges.VisibilityRender`) or None; ``timed``:
    predict by the frames' times (``photo.time_s``: frames at irregular intervals); ``outline``:
    ``--outline`` (:data:`OUTLINE_OPTIONS`). What the review's live session runs on every frame
    from the browser, too."""
    start = (
        camera.with_pose(initial.R, initial.t) if not previous else predicted(previous, photo.time_s if timed else None)
    )

    def snap(options, begin, cands=None, seed=None, pyramid=None):
        image = photo.rgb if options.reads_colour else photo.grey
        return snap_frame(scene, camera, image, begin, renderer, edges, options, cands, seed, pyramid=pyramid)

    began = time.perf_counter()
    pose, fit, reason = snap(frame_options(index, outline), start, candidates, seed, photo.pyramid)
    times = _fit_times(fit, {})
    # not within a lost stretch: there both snaps start from the same coasting prediction (on the
    # 60-frame `robot_cell` walk sideways, 25 frames of a bare wall, the retries cost a fifth of the run)
    retry = retry_options(outline)
    if reason and index > 0 and not previous[-1].lost and retry is not None:
        pose, fit, reason = snap(retry, start, candidates, pyramid=photo.pyramid)
        times = _fit_times(fit, times)
    if index > 0 and relocalise_now(previous):
        # also when the snap held: from the coasted prediction it may hold on other edges (the
        # better supported of the two is kept); its own pyramid (the reader's has TRACK_OPTIONS'
        # one level) and no candidates (their spacing is TRACK_OPTIONS')
        for what, again in relocalisation_anchors(previous, camera.with_pose(initial.R, initial.t)):
            pose2, fit2, reason2 = snap(RELOCALISE_OPTIONS, again)
            times = _fit_times(fit2, times)
            if not reason2 and (reason or fit2.support > fit.support):
                pose, fit, reason = pose2, fit2, reason2
            elif reason:
                reason += f"; relocalised from {what}: {reason2 or 'less support'}"
    corners = list(fit.uncertainty.corner_px) if fit is not None else []
    rms, support = (None, 0.0) if fit is None else (fit.rms_px, fit.support)
    return FramePose(
        index, photo.time_s, pose, rms, support, corners, bool(reason), reason, time.perf_counter() - began, times
    )


def _fit_times(fit, times: dict) -> dict:
    """``times`` (stage -> seconds) plus the stages of ``fit`` (None: a fit that raised)."""
    for stage, seconds in fit.times_s.items() if fit is not None else ():
        if stage != "total":
            times[stage] = times.get(stage, 0.0) + seconds
    return times


def track_command(
    video, scene, intrinsics, initial, output, poses=None, alpha=0.5, progress=None, outline=False
) -> TrackResult:
    """``mrcheck track``: check the inputs, track, write OUT.mp4 and poses.jsonl (default: beside
    the video output, ``OUT.poses.jsonl``); ``outline``: ``--outline``."""
    output = check_output_path(output, (".mp4",), "video")
    poses = Path(poses) if poses else output.with_suffix(".poses.jsonl")
    check_not_inputs(
        [output, poses],
        [("the video", video), ("--intrinsics", intrinsics), ("--initial", initial), ("the scene", scene_files(scene))],
    )
    check_input(video, "video")
    check_input(scene, "scene", folder_ok=True)
    if not 0.0 <= alpha <= 1.0:
        raise MrcheckError(f"--alpha must be in [0, 1], got {alpha}")
    return track_video(
        video,
        load_scene(scene),
        read_camera(intrinsics),
        load_camera(initial),
        output,
        poses,
        alpha=alpha,
        progress=progress,
        outline=outline,
    )


__all__ = [
    "FramePose",
    "track_frame",
    "frame_options",
    "retry_options",
    "OUTLINE_OPTIONS",
    "TrackResult",
    "predicted",
    "snap_frame",
    "track_video",
    "track_command",
    "LOST_SUPPORT",
    "TRACK_OPTIONS",
    "RETRY_OPTIONS",
    "FIRST_OPTIONS",
    "RELOCALISE_OPTIONS",
]
