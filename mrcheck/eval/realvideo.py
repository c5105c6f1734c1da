"""``track`` on the shared real videos (part of ``mrcheck bench --real``).

* The box video (``box_video/box.mp4``, Apache-2.0; 455 frames): examples/box's scene, the
  tutorial's nominal intrinsics (fx 1578.48, fy 1771.81, cx 320, cy 240: not the real camera,
  none is published); the start solved (``cv2.solvePnP``, SQPnP then Levenberg-Marquardt) from
  5 box corners marked by eye on frame 0 (``tests/data/box_video_clicks.json``; no clicks are
  published; the sixth visible corner is under the hand). Tracked again as ``box_video_f680``
  with the camera fitted to such clicks (``tests/data/track/box_video/camera.json``: square
  pixels, f = 680 px, the principal point at the centre), since the nominal one does not fit
  this video (the clicks 3.5-7.4 px off).
* The tea box (``teabox/teabox.mp4``, GPL-2.0+; 39 frames): the ``.cao`` cuboid, the
  calibrated intrinsics of ``teabox.xml``; the start from the 4 points of ``teabox.init``
  marked by eye on frame 0 (``tests/data/teabox_clicks.json``).

Per frame the outline distance is the median distance (px) from samples every 2 px along the
projected cuboid's silhouette (the convex hull of its 8 projected corners) to the nearest Canny
edge (thresholds 50/150) of the frame whose gradient runs within about 34 deg of the outline's
normal (an oriented chamfer distance: without the orientation, the printed box's texture puts
an edge within 3 px of almost any outline): a fit to the photo's edges, not to a ground truth
(there is none). A frame counts as held when ``track`` did not mark it lost and its outline distance is
at most :data:`OUTLINE_PX`.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from mrcheck.apps.track import track_command
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_camera, write_camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import write_text
from mrcheck.eval.realdata import cao_points, cuboid_corners, cuboid_faces, nearest_rotation

OUTLINE_PX = 3.0
ANGLE_BINS = 8
QUICK_FRAMES = 5
BOX_K = ((1578.48, 0.0, 320.0), (0.0, 1771.81, 240.0), (0.0, 0.0, 1.0))
TEA_K = ((839.21470, 0.0, 325.66776), (0.0, 839.44555, 243.69727), (0.0, 0.0, 1.0))
_REPO = Path(__file__).resolve().parents[2]
FITTED_BOX_CAMERA = _REPO / "tests" / "data" / "track" / "box_video" / "camera.json"


@dataclass
class VideoRun:
    """One tracked video: ``frames`` tracked, ``lost`` (track's own verdict), ``held`` (not
    lost and outline within :data:`OUTLINE_PX`), ``outline_px`` per frame, ``click_rms_px`` the
    start's reprojection RMS on the clicks; ``error`` when track raised (then no frames)."""

    video: str
    frames: int
    lost: int
    held: int
    fps: float
    click_rms_px: float
    outline_px: list = field(default_factory=list)
    error: str = ""


def read_clicks(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) pixels and (n, 3) world points of a ``{"points": [{"pixel", "world"}]}`` file."""
    points = json.loads(Path(path).read_text())["points"]
    return np.array([p["pixel"] for p in points], np.float64), np.array([p["world"] for p in points], np.float64)


def start_from_clicks(camera: Camera, pixels: np.ndarray, world: np.ndarray) -> tuple[Camera, float]:
    """The pose solved from the clicks (re-orthonormalised) and its RMS reprojection (px)."""
    ok, rvec, tvec = cv2.solvePnP(world, pixels, camera.K, None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise MrcheckError("solvePnP found no pose from the clicks")
    rvec, tvec = cv2.solvePnPRefineLM(world, pixels, camera.K, None, rvec, tvec)
    start = camera.with_pose(nearest_rotation(cv2.Rodrigues(rvec)[0]), tvec.ravel())
    rms = float(np.sqrt(np.mean(np.sum((start.project(world) - pixels) ** 2, axis=1))))
    return start, rms


def outline_samples(camera: Camera, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) samples every 2 px along the projected cuboid's silhouette (the convex hull of its
    8 projected corners) and (n,) the angle of each sample's outline normal in [0, pi)."""
    hull = cv2.convexHull(camera.project(corners).astype(np.float32)).reshape(-1, 2).astype(np.float64)
    samples, normals = [], []
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        n = max(int(np.linalg.norm(b - a) / 2.0), 1)
        samples.append(a + (b - a) * np.arange(n)[:, None] / n)
        normals.append(np.full(n, np.arctan2(b[0] - a[0], -(b[1] - a[1])) % np.pi))
    return np.concatenate(samples), np.concatenate(normals)


def oriented_distances(grey: np.ndarray) -> list:
    """Per orientation bin (:data:`ANGLE_BINS` over [0, pi)) the distance (px) to the nearest
    Canny edge (50/150) whose gradient lies in that bin or a neighbouring one: the oriented
    chamfer distance, so that texture edges across the outline do not count as a fit."""
    edges = cv2.Canny(grey, 50, 150) > 0
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3)
    bins = (np.floor((np.arctan2(gy, gx) % np.pi) / np.pi * ANGLE_BINS).astype(int)) % ANGLE_BINS
    maps = []
    for k in range(ANGLE_BINS):
        near = edges & ((bins == k) | (bins == (k + 1) % ANGLE_BINS) | (bins == (k - 1) % ANGLE_BINS))
        maps.append(cv2.distanceTransform(np.where(near, 0, 255).astype(np.uint8), cv2.DIST_L2, 5))
    return maps


def outline_distance(camera: Camera, corners: np.ndarray, grey: np.ndarray, maps: list | None = None) -> float:
    """Median oriented distance (px) from the projected cuboid's silhouette samples in the
    frame to the nearest photo edge of like direction (:func:`oriented_distances`; ``maps``
    made beforehand); inf when no sample is in the frame."""
    samples, normals = outline_samples(camera, corners)
    uv = np.round(samples).astype(int)
    h, w = grey.shape
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    if not inside.any():
        return float("inf")
    maps = oriented_distances(grey) if maps is None else maps
    uv, bins = uv[inside], (np.floor(normals[inside] / np.pi * ANGLE_BINS).astype(int)) % ANGLE_BINS
    stack = np.stack(maps)
    return float(np.median(stack[bins, uv[:, 1], uv[:, 0]]))


def _frames(video: Path, limit: int | None = None) -> list:
    capture, frames = cv2.VideoCapture(str(video)), list[np.ndarray]()
    while limit is None or len(frames) < limit:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    return frames


def _write_video(path: Path, frames: list) -> Path:
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), 25.0, (w, h))
    for frame in frames:
        writer.write(frame)
    writer.release()
    return path


def _teabox_scene(folder: Path, corners: np.ndarray) -> Path:
    """The tea box as an OBJ (metres) and a one-part manifest in ``folder``."""
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in corners]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in cuboid_faces()]
    write_text(folder / "teabox.obj", "\n".join(lines) + "\n")
    manifest = 'format = 1\nname = "teabox"\n\n[[parts]]\nname = "teabox"\nmesh = "teabox.obj"\nunits = "m"\n'
    return write_text(folder / "scene.toml", manifest)


def track_one(
    name, video, scene, camera: Camera, clicks: Path, corners, limit, folder: Path, outline: bool = False
) -> VideoRun:
    """Track ``video`` (its first ``limit`` frames when given) from the clicks' pose; ``outline``:
    ``track --outline`` (the run's name says so)."""
    frames = _frames(video, limit)
    if limit is not None:
        video = _write_video(folder / f"{name}-first.mp4", frames)
    start, rms = start_from_clicks(camera, *read_clicks(clicks))
    name = f"{name} --outline" if outline else name
    intrinsics, rough = folder / f"{name}.cam.json", folder / f"{name}.rough.json"
    write_camera(intrinsics, camera, pose=False)
    write_camera(rough, start)
    try:
        result = track_command(video, scene, intrinsics, rough, folder / f"{name}-overlay.mp4", outline=outline)
    except MrcheckError as exc:
        return VideoRun(name, 0, 0, 0, 0.0, rms, error=str(exc))
    distances = [
        outline_distance(f.camera, corners, cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
        for f, frame in zip(result.frames, frames)
    ]
    held = sum(not f.lost and d <= OUTLINE_PX for f, d in zip(result.frames, distances))
    return VideoRun(name, len(result.frames), len(result.lost), held, result.fps, rms, distances)


def video_runs(root: Path, quick: bool, progress=None) -> tuple[list, list]:
    """(runs, skipped reasons): the box video with the nominal and the fitted camera (not with
    ``quick``) and the tea box (``quick``: its first :data:`QUICK_FRAMES` frames), each also
    with ``track --outline`` (not with ``quick``)."""
    runs, skipped = [], []
    box_scene, tea = _REPO / "examples" / "box" / "scene.toml", Path(root) / "teabox"
    clicks = _REPO / "tests" / "data"
    with tempfile.TemporaryDirectory(prefix="mrcheck-realbench-") as name:
        out = Path(name)
        if quick:
            skipped.append("box video: left out of --quick (455 frames)")
        elif not (Path(root) / "box_video" / "box.mp4").exists() or not box_scene.exists():
            skipped.append("box video: box_video/box.mp4 or examples/box/scene.toml is absent")
        else:
            corners = cuboid_corners(np.array([[0, 0, 0], [0.189, 0.258, 0.075]]))
            cameras = {"box_video": Camera(640, 480, np.array(BOX_K)), "box_video_f680": read_camera(FITTED_BOX_CAMERA)}
            for (name, camera), outline in ((c, o) for c in cameras.items() for o in (False, True)):
                runs.append(track_one(name, Path(root) / "box_video" / "box.mp4", box_scene, camera,
                                      clicks / "box_video_clicks.json", corners, None, out, outline))  # fmt: skip
                if progress:
                    progress(f"{runs[-1].video}: {runs[-1].frames} frames")
        if not (tea / "teabox.mp4").exists():
            skipped.append(f"tea box: {tea / 'teabox.mp4'} is absent")
        else:
            corners = cuboid_corners(cao_points(tea / "teabox.cao"))
            scene = _teabox_scene(out, corners)
            camera = Camera(640, 480, np.array(TEA_K))
            for outline in (False,) if quick else (False, True):
                runs.append(track_one("teabox", tea / "teabox.mp4", scene, camera, clicks / "teabox_clicks.json",
                                      corners, QUICK_FRAMES if quick else None, out, outline))  # fmt: skip
                if progress:
                    progress(f"{runs[-1].video}: {runs[-1].frames} frames")
    return runs, skipped


__all__ = [
    "VideoRun",
    "read_clicks",
    "start_from_clicks",
    "outline_samples",
    "oriented_distances",
    "outline_distance",
    "track_one",
    "video_runs",
    "OUTLINE_PX",
    "FITTED_BOX_CAMERA",
]
