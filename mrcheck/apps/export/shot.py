"""The work of one shot, in a worker: register it (or read its SHOT.json), render the modes in the
photo's geometry, blend them over the photo, make the study sheet and encode every file.

:func:`register_shot` is shared with ``mrcheck review``, which registers a job's shots as the
export does.
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2

from mrcheck.apps.export.folders import store_shot
from mrcheck.apps.export.job import SHEET_ALPHA, JobSettings, ShotInputs
from mrcheck.apps.export.tasks import ShotRecord, ShotTask, plan_outputs
from mrcheck.apps.names import SHEET, SHOT_FILE, overlay_name, render_name
from mrcheck.core.camerafiles import read_photo
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image, set_max_pixels
from mrcheck.core.jsonfile import is_number
from mrcheck.core.shot import Shot, read_shot, shot_text
from mrcheck.mr.lens import distortion_map
from mrcheck.mr.overlay import STUDY_ORDER, overlay_images, study_sheet
from mrcheck.mr.shot import render_for_photo
from mrcheck.render.renderer import RenderSettings
from mrcheck.scene.manifest import files_stamp, scene_files

_RENDERERS: dict = {}  # per process: (scene path, stamp of its files) -> Renderer, kept across shots


def _renderer(scene_path: str, scene=None, stamp: str | None = None):
    """This process's Renderer of ``scene_path`` (the scene is loaded once per process; ``scene``:
    already loaded, by :func:`~mrcheck.apps.export.job.load_job` when the shots run in this
    process). ``stamp``: the job's :func:`files_stamp` of the scene's files; a Dask worker
    outlives a job, and an edited mesh must not be rendered from its old copy."""
    from mrcheck.render.renderer import Renderer
    from mrcheck.scene.model import load_scene

    path = Path(scene_path)
    key = (str(path), stamp if stamp is not None else files_stamp(scene_files(path)))
    if key not in _RENDERERS:
        for old in [k for k in _RENDERERS if k[0] == key[0]]:
            _RENDERERS.pop(old).release()
        _RENDERERS[key] = Renderer(scene if scene is not None else load_scene(path, progress=False))
    return _RENDERERS[key]


class ShotFailed(MrcheckError):
    """A shot that cannot be exported, with what its registration found (for the record)."""

    def __init__(self, message, registration=None):
        super().__init__(message)
        self.registration = registration


def registration_summary(shot: Shot) -> dict:
    """What the record and the report say of a shot's registration."""
    report = shot.report
    names = lambda entries: [e.get("id", e.get("index", f"board {e.get('board')}")) for e in entries or []]  # noqa: E731
    return {
        "method": report.get("method", "given"),
        "rms_px": report.get("rms"),
        "expected_overlay_error_px": report.get("expected_overlay_error_px"),
        "used": names(report.get("used")),
        "rejected": names(report.get("rejected")),
        "warnings": list(report.get("warnings") or []),
    }


def register_shot(inputs: ShotInputs, max_error, scene_bounds) -> Shot:
    """The shot: given, or registered from markers / points (with register's warnings, a
    camera far outside ``scene_bounds`` among them). A registration error above ``max_error``
    (px; None: no limit) is a :class:`ShotFailed`."""
    from mrcheck.core.camerafiles import read_camera
    from mrcheck.mr.markers import load_marker_map
    from mrcheck.mr.registration import load_points, register_photo

    if inputs.shot is not None:
        shot = read_shot(inputs.shot)
        # an rms that is no number is unknown, as the review shows it: NaN is no JSON for the outputs
        if not is_number(shot.report.get("rms", 0.0)):
            shot = shot.with_report(rms=None)
    else:
        shot = register_photo(
            Path(inputs.photo),
            read_camera(inputs.intrinsics),
            marker_map=load_marker_map(inputs.markers) if inputs.markers else None,
            points=load_points(inputs.points) if inputs.points else None,
            scene_bounds=scene_bounds,
            points_file=inputs.points,
        )
    rms = shot.report.get("rms")
    if max_error is not None and is_number(rms) and rms > max_error:
        raise ShotFailed(
            f"registration error {rms:.3f} px is above the job's limit of {max_error:g} px", registration_summary(shot)
        )
    return shot


def _fitted_photo(task: ShotTask, renderer):
    """The registered shot, its camera and photo at the job's width, the registration summary."""
    settings = task.settings
    shot = register_shot(task.inputs, settings.max_error, renderer.scene.bounds())
    camera, photo_path = shot.camera, shot.photo
    registration = registration_summary(shot)
    photo = read_photo(photo_path, camera)
    if settings.width and settings.width > camera.width:
        registration["warnings"].append(
            f"the job's width {settings.width} is larger than the photo ({camera.width} px): the photo is upscaled"
        )
    if settings.width and settings.width != camera.width:
        camera = camera.fitted(settings.width)
        photo = cv2.resize(photo, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    return shot, photo_path, camera, photo, registration


def _blended(photo, renders, edges, camera, offset, maps, settings: JobSettings, virtual) -> dict:
    """The overlays at every alpha and the study sheet, at the overlay intensity."""
    modes, default = settings.modes, settings.overlay_intensity
    images = {}
    for alpha in settings.alphas:
        mixed = overlay_images(photo, {m: renders[m] for m in modes}, camera, alpha, edges, offset=offset, maps=maps)
        for mode in modes:
            images[overlay_name(mode, None if mode == "phong" else default, alpha)] = mixed[mode]
    half = overlay_images(
        photo, {m: renders[m] for m in STUDY_ORDER}, camera, SHEET_ALPHA, edges, offset=offset, maps=maps
    )
    images[SHEET] = study_sheet({m: virtual[m] for m in STUDY_ORDER}, half, SHEET_ALPHA)
    return images


def _images(renderer, camera, photo, settings: JobSettings, timings: dict) -> dict:
    """Every image of one shot, by file name. The overlay intensity also renders D1-D3 for the
    sheet; the other intensities only the job's AO modes."""
    modes, default = settings.modes, settings.overlay_intensity
    maps = distortion_map(camera)
    images = {}
    render_s = compose_s = 0.0
    for intensity in settings.intensities:
        wanted = (
            [m for m in modes if m != "phong"]
            if intensity != default
            else list(dict.fromkeys(list(modes) + list(STUDY_ORDER)))
        )
        if not wanted:
            continue
        t = time.perf_counter()
        render_settings = RenderSettings(
            samples=settings.samples,
            intensity=intensity,
            seed=0,
            antialias=settings.antialias,
            accumulate=settings.accumulate,
        )
        renders, edges, offset, maps = render_for_photo(renderer, camera, wanted, render_settings, settings.edges, maps)
        render_s += time.perf_counter() - t
        t = time.perf_counter()
        virtual = overlay_images(photo, renders, camera, 0.0, None, offset=offset, maps=maps)
        for mode in wanted:
            if mode in modes and (mode != "phong" or intensity == default):
                images[render_name(mode, intensity)] = virtual[mode]
        if intensity == default:
            images.update(_blended(photo, renders, edges, camera, offset, maps, settings, virtual))
        compose_s += time.perf_counter() - t
    timings.update(render=render_s, compose=compose_s)
    return images


def _shot_files(task: ShotTask, timings: dict, scene=None) -> tuple[dict, dict]:
    """Every output of one shot as ``{file name: bytes}`` and what the record says of it."""
    t = time.perf_counter()
    renderer = _renderer(task.settings.scene, scene, task.scene_stamp)
    timings["scene"] = time.perf_counter() - t
    t = time.perf_counter()
    shot, photo_path, camera, photo, registration = _fitted_photo(task, renderer)
    timings["registration"] = time.perf_counter() - t
    images = _images(renderer, camera, photo, task.settings, timings)
    t = time.perf_counter()
    files = {name: encode_image(name, image) for name, image in images.items()}
    files[SHOT_FILE] = shot_text(shot, task.folder / SHOT_FILE).encode()
    timings["encode"] = time.perf_counter() - t
    return files, {"registration": registration, "size": [camera.width, camera.height], "photo": str(photo_path)}


def run_shot(task: ShotTask, scene=None) -> ShotRecord:
    """Register, render, blend and encode one shot; never raises for a bad shot.

    Returns the shot's record (``status`` "done" or "failed" with ``error``). With
    ``task.write`` the files and ``record.json`` are written into ``task.folder`` here;
    otherwise the record carries them as ``files`` (bytes) for the caller to write. ``scene``:
    the job's loaded Scene, when this runs in the process that loaded it.
    """
    set_max_pixels(task.max_pixels)  # in a spawned or remote worker, the limit of the export's command line
    start = time.perf_counter()
    timings = {}
    record = ShotRecord(task.name, "failed", task.fingerprint, task.inputs.to_dict())
    try:
        files, info = _shot_files(task, timings, scene)
        outputs = [dict(o) for o in plan_outputs(task.settings)] + [{"file": SHOT_FILE, "kind": "shot"}]
        missing = [o["file"] for o in outputs if o["file"] not in files]
        if missing:
            raise MrcheckError(f"internal error: outputs not produced: {missing}")
        record.status, record.outputs, record.files = "done", outputs, files
        record.registration, record.size, record.photo = info["registration"], info["size"], info["photo"]
    except ShotFailed as exc:
        record.error, record.registration = str(exc), exc.registration
    except MrcheckError as exc:
        record.error = str(exc)
    except Exception as exc:  # a bug, or the GL driver: report it and go on with the other shots
        record.error = f"internal error: {type(exc).__name__}: {exc}"
    record.registration_error_px = (record.registration or {}).get("rms_px")
    timings["total"] = time.perf_counter() - start
    record.timings_s = {k: round(v, 4) for k, v in timings.items()}
    if task.write and record.status == "done":
        record = store_shot(task.folder, record)
    return record


__all__ = ["run_shot", "register_shot", "registration_summary", "ShotFailed"]
