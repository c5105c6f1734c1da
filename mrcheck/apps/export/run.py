"""``mrcheck export``: batch registration, renders, overlays, sheets and a report for a whole job.

Job file (TOML; every relative path is relative to the job file's folder)::

    scene = "factory_scenes/sample_cell/scene.toml"   # required: the planned CAD (manifest or mesh)
    modes = ["phong", "vector", "ssao"]       # default D1, D2, D3; any of phong vector ssao crytek hbao alchemy
    alphas = [0.0, 0.5, 1.0]                  # photo opacities of the overlays, 0..1 (default [0.5])
    intensities = [0.5, 1.0, 1.5, 2.0]        # AO strengths, weak to strong (default [1.0]; AO modes only)
    overlay_intensity = 1.0                   # optional: the intensity of the overlays and the sheet;
                                              # default 1.0 when listed, else the middle of `intensities`
    width = 640                               # optional: output width; the camera (K) and the photo are
                                              # scaled to it, same aspect ratio (default: the photo's size)
    max_registration_error_px = 2.0           # optional: a shot registered with a larger RMS fails
    samples = 16                              # optional: AO samples per pixel
    edges = false                             # optional: draw the CAD's edges over the overlays
    intrinsics = "camera.json"                # optional defaults for every [[shots]] entry below
    markers = "markers.json"

    [[shots]]                                 # an already registered SHOT.json (`mrcheck register`)
    name = "north-01"                         # optional (default: the file's stem)
    shot = "shots/north-01.json"

    [[shots]]                                 # one photo, registered here
    photo = "photos/south-07.jpg"
    intrinsics = "camera.json"                # camera JSON or OpenCV YAML (or the job-wide default)
    points = "south-07.corr.json"             # manual correspondences, or markers = "MAP.json"

    [[shots]]                                 # a glob of photos from one camera; each is a shot
    photos = "photos/hall-*.jpg"              # named after the file's stem
    markers = "markers.json"                  # (a glob takes markers only: points are per photo)

Shot names must be unique and use letters, digits, ``.``, ``_`` and ``-`` (names from a glob
are sanitised). A bad job (malformed TOML, unknown key, no scene or one that does not load, no
shots, an unknown mode, an alpha outside 0..1, a glob matching nothing, a missing intrinsics or
marker file) is a one-line ``error: JOB.toml: ...`` before anything is written.

Per shot, under ``OUTDIR/shots/NAME/`` (``{x:g}`` numbers: ``i1``, ``i0.5``, ``a0``):

* ``SHOT.json`` -- the registered shot (a copy when the job gives one), its photo path relative
  to this folder (:func:`mrcheck.mr.registration.photo_reference`);
* ``render_phong.png`` and ``render_MODE_iI.png`` for every AO mode and every intensity: the CAD
  alone in the photo's geometry (lens distortion applied, the photo's size);
* ``overlay_MODE_aA.png`` for phong and ``overlay_MODE_iI_aA.png`` for every AO mode, every alpha,
  at the overlay intensity only (so the count is modes x alphas, not x intensities);
* ``sheet.png`` -- the study sheet: D1 | D2 | D3 virtual (top) and over the photo at 50 %
  (bottom), at the overlay intensity (D1-D3 are rendered for it even when not in ``modes``);
* ``record.json`` -- written last: the outputs with their parameters, the registration, timings
  and a fingerprint of the job's settings, the shot's input paths and the size and mtime of every
  file the shot reads (the scene's manifest, meshes and their companions; the shot's photo,
  intrinsics, markers or points, its SHOT.json and that shot's photo).

For the job: ``OUTDIR/manifest.json`` (every shot with its status, error, registration error,
outputs with parameters, timings) and ``OUTDIR/report.html`` (one self-contained file: inline
JPEG thumbnails of the sheets, links to the full images inside OUTDIR, shots sorted by
registration error, failures last).

Restart: every file is written atomically (temp + rename) and ``record.json`` last, so a shot is
finished exactly when its record exists and says done, its fingerprint matches the job and every
output it lists exists. A failed shot's folder keeps only a record.json saying so: outputs of
earlier runs there no longer match its inputs and are removed. A rerun skips finished shots (``--force`` redoes them) and retries failed ones; a
shot whose settings or input files changed (edited, replaced or touched) is not finished. A
killed run loses only the shots in flight. Outputs of earlier runs that the job no longer
produces are removed before the shots run (listed in the manifest's ``removed``): in the job's
shot folders, the export's own file names that it no longer plans (a dropped alpha, intensity or
mode); in ``OUTDIR/shots/``, the export's files in folders of shots no longer in the job that
hold a ``record.json``, and the folder once empty. Other files, and the job's own inputs, stay.
A bad shot (unreadable photo, no markers, an error above the limit) is reported and the others
go on; the exit status is 1 when any shot failed.
PNGs are deterministic (fixed seeds, no timestamps): the same job gives the same bytes, with any
number of workers or on a cluster.

Progress goes to stderr: a bar on a terminal, one line per shot (count, name, status, ETA) in a
pipe or log file.

Execution: ``--workers 1`` runs in this process; ``--workers N`` in N spawned processes
(``ProcessPoolExecutor``, "spawn": each has its own EGL context and keeps its scene and Renderer
across shots, see :func:`_renderer`); ``--scheduler ADDRESS`` sends :func:`run_shot` to a Dask
distributed cluster, whose workers read the scene and photos from the (absolute) paths of the job
and return the encoded files, which this process writes into OUTDIR.
Killed (``kill -9``), the export takes its local workers with it (:func:`_exit_with_parent`): none
goes on writing into OUTDIR beside a rerun. A cluster's workers are the cluster's and stay; they
never write into OUTDIR, and the scheduler releases the shots of a client that is gone (one
already running finishes on its worker, and its result is dropped).
"""

from __future__ import annotations

import ctypes
import glob
import hashlib
import json
import multiprocessing
import multiprocessing.connection
import os
import re
import signal
import socket
import sys
import threading
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import click
import cv2

from mrcheck.apps.export.report import REPORT, write_report
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_shot, read_photo
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image
from mrcheck.core.inputs import read_input_text, real_path
from mrcheck.core.jsonfile import is_number, number_problem, read_json
from mrcheck.core.output import (
    check_not_inputs,
    check_writable_ancestor,
    write_bytes,
    write_text,
)
from mrcheck.mr.lens import distortion_map
from mrcheck.mr.overlay import STUDY_ORDER, check_alpha, overlay_images, study_sheet
from mrcheck.mr.shot import render_for_photo
from mrcheck.render.renderer import DEFAULT_SAMPLES, MODES, RenderSettings
from mrcheck.scene.manifest import files_stamp, scene_files

RECORD = "record.json"
SHOT_FILE = "SHOT.json"
MANIFEST = "manifest.json"   # the job's, in OUTDIR (and export_report.REPORT)
SHEET = "sheet.png"
SHEET_ALPHA = 0.5
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
SCHEDULER_TIMEOUT = "30s"  # how long to try reaching --scheduler before giving up
_TOP_KEYS = {"scene", "modes", "alphas", "intensities", "overlay_intensity", "width", "max_registration_error_px",
             "samples", "edges", "intrinsics", "markers", "points", "shots"}
_SHOT_KEYS = {"name", "shot", "photo", "photos", "intrinsics", "markers", "points"}
_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]*")
_NUM = r"[0-9][0-9.e+-]*"  # a number as _fmt writes it: 1, 0.5, 1e-05
_AO = "|".join(m for m in MODES if m != "phong")
# every name the export writes into a shot folder (temp files included): only these are ever removed
_OUTPUT_NAME = re.compile(rf"(render_phong|render_({_AO})_i{_NUM}|overlay_phong_a{_NUM}|overlay_({_AO})_i{_NUM}_a{_NUM}"
                          rf"|sheet)\.png|SHOT\.json|record\.json|\..+\.part")


# -- the job file -----------------------------------------------------------------------------
@dataclass
class Job:
    path: Path
    scene: Path
    modes: list
    alphas: list
    intensities: list
    overlay_intensity: float
    width: int | None
    max_error: float | None
    samples: int
    edges: bool
    shots: list = field(default_factory=list)  # [{"name", "shot" | "photo" + "intrinsics" + "markers"|"points"}]
    loaded: object = field(default=None, repr=False, compare=False)  # the Scene, loaded once by load_job

    def settings(self) -> dict:
        return {"scene": str(self.scene), "modes": self.modes, "alphas": self.alphas, "intensities": self.intensities,
                "overlay_intensity": self.overlay_intensity, "width": self.width,
                "max_registration_error_px": self.max_error, "samples": self.samples, "edges": self.edges}


def load_job(path) -> Job:
    """Parse and validate a job file; every error is one line naming the file."""
    path = Path(path)

    def fail(message):
        raise MrcheckError(message, path)

    text = read_input_text(path, "job file", encoding="utf-8-sig")   # -sig: a BOM (Windows Notepad) is no error
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        fail(f"malformed job TOML: {exc}")
    base = real_path(path).parent

    def resolve(value, where):
        if not isinstance(value, str) or not value:
            fail(f"{where} must be a path (a non-empty string)")
        return real_path(base / value) if not Path(value).is_absolute() else Path(value)

    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        fail(f"unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(_TOP_KEYS))})")
    if "scene" not in data:
        fail('no scene: give scene = "path/to/scene.toml"')
    scene = resolve(data["scene"], "scene")
    if not os.path.lexists(scene):
        fail(f"scene not found: {scene}")
    from mrcheck.scene.model import load_scene

    try:  # loaded here, not first in a shot: a bad scene (a PNG, a corrupt mesh) is a bad job, not N failed shots
        loaded = load_scene(scene, progress=True)
    except MrcheckError as exc:
        fail(f"scene: {exc}")

    modes = data.get("modes", list(STUDY_ORDER))
    if not isinstance(modes, list) or not modes or not all(isinstance(m, str) for m in modes):
        fail("modes must be a non-empty list of mode names")
    bad = [m for m in modes if m not in MODES]
    if bad:
        fail(f"unknown mode(s) {', '.join(map(repr, bad))} (use {', '.join(MODES)})")
    modes = list(dict.fromkeys(modes))

    def number(key, value, check, what) -> float:
        """``value`` when it is a finite number that passes ``check``; else "KEY: what is wrong"."""
        if problem := number_problem(value) or (None if check(value) else f"{value} is {what}"):
            fail(f"{key}: {problem}")
        return float(value)

    def numbers(key, default, check, what):
        values = data.get(key, default)
        if not isinstance(values, list) or not values:
            fail(f"{key} must be a non-empty list of numbers")
        return list(dict.fromkeys(number(key, v, check, what) for v in values))

    alphas = numbers("alphas", [SHEET_ALPHA], lambda a: 0.0 <= a <= 1.0, "outside 0..1 (the photo's opacity)")
    for a in alphas:
        check_alpha(a)
    intensities = numbers("intensities", [1.0], lambda i: i >= 0.0, "negative (AO strength must be >= 0)")
    overlay_intensity = data.get("overlay_intensity", 1.0 if 1.0 in intensities else intensities[len(intensities) // 2])
    overlay_intensity = number("overlay_intensity", overlay_intensity, lambda i: i in intensities,
                               f"not one of the intensities {intensities}")
    width = data.get("width")
    if width is not None and not (isinstance(width, int) and not isinstance(width, bool) and 16 <= width <= 16384):
        fail(f"width must be a whole number of pixels, 16..16384, got {width!r}")
    max_error = data.get("max_registration_error_px")
    if max_error is not None:
        max_error = number("max_registration_error_px", max_error, lambda e: e > 0, "not positive")
    samples = data.get("samples", DEFAULT_SAMPLES)
    if not (isinstance(samples, int) and not isinstance(samples, bool) and 1 <= samples <= 512):
        fail(f"samples must be a whole number 1..512, got {samples!r}")
    edges = data.get("edges", False)
    if not isinstance(edges, bool):
        fail(f"edges must be true or false, got {edges!r}")

    entries = data.get("shots")
    if not isinstance(entries, list) or not entries:
        fail("no shots: add [[shots]] tables (shot = SHOT.json, photo = ..., or photos = GLOB)")
    defaults = {k: data[k] for k in ("intrinsics", "markers", "points") if k in data}
    checked = {}  # shared inputs are parsed once here so that a bad one fails the job, not every shot

    def shared_input(key, value, where):
        file = resolve(value, f"{where}: {key}")
        if (key, file) not in checked:
            from mrcheck.core.camerafiles import read_camera
            from mrcheck.mr.markers import load_marker_map
            from mrcheck.mr.registration import load_points

            load = {"intrinsics": read_camera, "markers": load_marker_map, "points": load_points}[key]
            try:
                load(file)
            except MrcheckError as exc:
                fail(f"{where}: {exc}")
            checked[key, file] = True
        return str(file)

    shots, names = [], set()
    for index, entry in enumerate(entries):
        # the planner counts [[shots]] tables from 1 and knows them by their name or photo
        label = next((f"{k} = {entry[k]!r}" for k in ("name", "photo", "photos", "shot")
                      if isinstance(entry, dict) and isinstance(entry.get(k), str)), None)
        where = f"[[shots]] #{index + 1}" + (f" ({label})" if label else "")
        if not isinstance(entry, dict):
            fail(f"{where} must be a table ([[shots]])")
        unknown = sorted(set(entry) - _SHOT_KEYS)
        if unknown:
            fail(f"{where}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(_SHOT_KEYS))})")
        sources = [k for k in ("shot", "photo", "photos") if k in entry]
        if len(sources) != 1:
            fail(f"{where}: give exactly one of shot = SHOT.json, photo = PHOTO, photos = GLOB")
        source = sources[0]
        if "name" in entry and (not isinstance(entry["name"], str) or not _NAME.fullmatch(entry["name"])):
            fail(f"{where}: name {entry['name']!r} must be letters, digits, '.', '_' or '-'")
        if source == "photos" and "name" in entry:
            fail(f"{where}: a photos glob names its shots after the files; drop name")
        if source == "shot":
            file = resolve(entry["shot"], f"{where}: shot")
            planned = [{"name": entry.get("name", _safe_name(file.stem)), "shot": str(file)}]
        else:
            merged = {**defaults, **{k: entry[k] for k in ("intrinsics", "markers", "points") if k in entry}}
            if "markers" in entry and "points" in entry:
                fail(f"{where}: give markers or points, not both")
            if "markers" in entry or "points" in entry:  # the shot's own choice beats the job-wide default
                merged.pop("points" if "markers" in entry else "markers", None)
            if "intrinsics" not in merged:
                fail(f"{where}: no intrinsics (camera JSON or YAML) for the photo")
            method = [k for k in ("markers", "points") if k in merged]
            if len(method) != 1:
                fail(f"{where}: give exactly one of markers = MAP.json or points = CORR.json")
            method = method[0]
            if source == "photos" and method == "points":
                fail(f"{where}: correspondences are per photo; use photo = ... for each (a glob takes markers)")
            common = {"intrinsics": shared_input("intrinsics", merged["intrinsics"], where),
                      method: shared_input(method, merged[method], where)}
            if source == "photo":
                file = resolve(entry["photo"], f"{where}: photo")
                planned = [{"name": entry.get("name", _safe_name(file.stem)), "photo": str(file), **common}]
            else:
                pattern = entry["photos"]
                if not isinstance(pattern, str) or not pattern:
                    fail(f"{where}: photos must be a glob pattern (a string)")
                # not only the readable files: a photo that cannot be read (a symlink loop, a broken
                # link) is a shot that fails and says why, not one silently left out
                files = sorted(real_path(p) for p in glob.glob(os.path.join(str(base), pattern), recursive=True)
                               if not os.path.isdir(p))
                if not files:
                    fail(f"{where}: photos {pattern!r} matches no file")
                planned = [{"name": _safe_name(f.stem), "photo": str(f), **common} for f in files]
        for shot in planned:
            if shot["name"] in names:
                fail(f"{where}: shot name {shot['name']!r} used twice (give each shot its own name)")
            names.add(shot["name"])
        shots += planned
    return Job(path, scene, modes, alphas, intensities, overlay_intensity, width, max_error, samples, edges, shots, loaded)


def _safe_name(stem: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", stem).lstrip(".") or "shot"
    return name


# -- planning ---------------------------------------------------------------------------------
def _fmt(x: float) -> str:
    return f"{x:g}"


def plan_outputs(job_settings: dict) -> list:
    """The image outputs of one shot: ``[{"file", "kind", "mode", "intensity", "alpha"}]``."""
    modes, default = job_settings["modes"], job_settings["overlay_intensity"]
    outputs = []
    for mode in modes:
        if mode == "phong":
            outputs.append({"file": "render_phong.png", "kind": "render", "mode": mode, "intensity": None, "alpha": 0.0})
        else:
            outputs += [{"file": f"render_{mode}_i{_fmt(i)}.png", "kind": "render", "mode": mode, "intensity": i,
                         "alpha": 0.0} for i in job_settings["intensities"]]
    for mode in modes:
        for alpha in job_settings["alphas"]:
            tag = "" if mode == "phong" else f"_i{_fmt(default)}"
            outputs.append({"file": f"overlay_{mode}{tag}_a{_fmt(alpha)}.png", "kind": "overlay", "mode": mode,
                            "intensity": None if mode == "phong" else default, "alpha": alpha})
    outputs.append({"file": SHEET, "kind": "sheet", "mode": list(STUDY_ORDER), "intensity": default,
                    "alpha": SHEET_ALPHA})
    return outputs


def _input_files(inputs: dict) -> list:
    """The files one shot reads besides the scene: its inputs and, for a given SHOT.json, its photo."""
    files = [inputs[k] for k in ("shot", "photo", "intrinsics", "markers", "points") if k in inputs]
    if "shot" in inputs:
        try:
            files.append(str(real_path(load_shot(inputs["shot"])[1])))
        except MrcheckError:
            pass  # the shot fails when it runs, and a failed shot is always run again
    return files


def _tasks(job: Job, outdir: Path, write: bool, scene_paths: list) -> list:
    settings = job.settings()
    # the inputs' paths are not enough: a moved part, a replaced photo or an edited marker map must
    # redo the shots that read them, so their sizes and mtimes go into the fingerprint too
    scene_stamp = files_stamp(scene_paths)  # scene_files(job.scene): once per job, it reads every OBJ
    tasks = []
    for shot in job.shots:
        inputs = {k: v for k, v in shot.items() if k != "name"}
        files = _input_files(inputs)
        stamps = {"scene": scene_stamp, "inputs": files_stamp(files)}
        fingerprint = hashlib.sha256(json.dumps({"settings": settings, "inputs": inputs, "stamps": stamps},
                                                sort_keys=True).encode()).hexdigest()[:16]
        tasks.append({"name": shot["name"], "inputs": inputs, "settings": settings, "fingerprint": fingerprint,
                      "scene_stamp": scene_stamp, "input_files": files,
                      "dir": str(outdir / "shots" / shot["name"]), "write": write})
    return tasks


def finished_record(task: dict) -> dict | None:
    """The shot's record when it is finished (record present, same fingerprint, every output there)."""
    folder = Path(task["dir"])
    try:
        record = json.loads((folder / RECORD).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("fingerprint") != task["fingerprint"] or record.get("status") != "done":
        return None
    files = [o.get("file") for o in record.get("outputs", []) if isinstance(o, dict)]
    if not files or not all(isinstance(f, str) and (folder / f).is_file() for f in files):
        return None
    return record


# -- the work of one shot (runs in a worker) ----------------------------------------------------
_RENDERERS: dict = {}  # per process: (scene path, stamp of its files) -> Renderer, kept across shots


def _renderer(scene_path: str, scene=None, stamp: str | None = None):
    """This process's Renderer of ``scene_path`` (the scene is loaded once per process; ``scene``:
    already loaded, by :func:`load_job` when the shots run in this process). ``stamp``: the
    job's :func:`files_stamp` of the scene's files; a Dask worker outlives a job, and an edited
    mesh must not be rendered from its old copy."""
    from mrcheck.render.renderer import Renderer
    from mrcheck.scene.model import load_scene

    path = Path(scene_path)
    key = (str(path), stamp if stamp is not None else files_stamp(scene_files(path)))
    if key not in _RENDERERS:
        for old in [k for k in _RENDERERS if k[0] == key[0]]:
            _RENDERERS.pop(old).release()
        _RENDERERS[key] = Renderer(scene if scene is not None else load_scene(path, progress=False))
    return _RENDERERS[key]


class _ShotFailed(MrcheckError):
    def __init__(self, message, registration=None):
        super().__init__(message)
        self.registration = registration


def _registration_summary(shot: dict) -> dict:
    names = lambda entries: [e.get("id", e.get("index", f"board {e.get('board')}")) for e in entries or []]  # noqa: E731
    return {"method": shot.get("method", "given"), "rms_px": shot.get("rms"),
            "expected_overlay_error_px": shot.get("expected_overlay_error_px"),
            "used": names(shot.get("used")), "rejected": names(shot.get("rejected")),
            "warnings": list(shot.get("warnings") or [])}


def _register(inputs: dict, max_error, scene_bounds) -> tuple[dict, Camera, Path]:
    """The shot dict, its camera and photo path: given, or registered from markers / points
    (with register's warnings, a camera far outside ``scene_bounds`` among them)."""
    from mrcheck.core.camerafiles import read_camera
    from mrcheck.mr.markers import load_marker_map
    from mrcheck.mr.registration import load_points, register_photo

    if "shot" in inputs:
        camera, photo = load_shot(inputs["shot"])
        shot = read_json(inputs["shot"], "shot")
        shot["photo"] = str(photo)
        if not is_number(shot.get("rms", 0.0)):   # unknown, as the review shows it: NaN is no JSON for the outputs
            shot["rms"] = None
    else:
        shot = register_photo(Path(inputs["photo"]), read_camera(inputs["intrinsics"]),
                              marker_map=load_marker_map(inputs["markers"]) if "markers" in inputs else None,
                              points=load_points(inputs["points"]) if "points" in inputs else None,
                              scene_bounds=scene_bounds, points_file=inputs.get("points"))
        camera, photo = Camera.from_dict(shot), Path(shot["photo"])
    rms = shot.get("rms")
    if max_error is not None and is_number(rms) and rms > max_error:
        raise _ShotFailed(f"registration error {rms:.3f} px is above the job's limit of {max_error:g} px",
                          _registration_summary(shot))
    return shot, camera, photo


def _shot_files(task: dict, timings: dict, scene=None) -> tuple[dict, dict]:
    """Every output of one shot as ``{file name: bytes}`` and the registration summary."""
    from mrcheck.mr.registration import photo_reference

    settings = task["settings"]
    t = time.perf_counter()
    renderer = _renderer(settings["scene"], scene, task.get("scene_stamp"))
    timings["scene"] = time.perf_counter() - t

    t = time.perf_counter()
    shot, camera, photo_path = _register(task["inputs"], settings["max_registration_error_px"],
                                         renderer.scene.bounds())
    registration = _registration_summary(shot)
    photo = read_photo(photo_path, camera)
    if settings["width"] and settings["width"] > camera.width:
        registration["warnings"].append(f"the job's width {settings['width']} is larger than the photo "
                                        f"({camera.width} px): the photo is upscaled")
    if settings["width"] and settings["width"] != camera.width:
        camera = camera.fitted(settings["width"])
        photo = cv2.resize(photo, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    timings["registration"] = time.perf_counter() - t
    modes, default = settings["modes"], settings["overlay_intensity"]
    maps = distortion_map(camera)
    images = {}
    render_s = compose_s = 0.0
    for intensity in settings["intensities"]:
        wanted = [m for m in modes if m != "phong"] if intensity != default else \
            list(dict.fromkeys(list(modes) + list(STUDY_ORDER)))
        if not wanted:
            continue
        t = time.perf_counter()
        render_settings = RenderSettings(samples=settings["samples"], intensity=intensity, seed=0)
        renders, edges, offset, maps = render_for_photo(renderer, camera, wanted, render_settings,
                                                        settings["edges"], maps)
        render_s += time.perf_counter() - t
        t = time.perf_counter()
        virtual = overlay_images(photo, renders, camera, 0.0, None, offset=offset, maps=maps)
        for mode in wanted:
            if mode in modes and (mode != "phong" or intensity == default):
                name = "render_phong.png" if mode == "phong" else f"render_{mode}_i{_fmt(intensity)}.png"
                images[name] = virtual[mode]
        if intensity == default:
            for alpha in settings["alphas"]:
                mixed = overlay_images(photo, {m: renders[m] for m in modes}, camera, alpha, edges,
                                       offset=offset, maps=maps)
                for mode in modes:
                    tag = "" if mode == "phong" else f"_i{_fmt(default)}"
                    images[f"overlay_{mode}{tag}_a{_fmt(alpha)}.png"] = mixed[mode]
            half = overlay_images(photo, {m: renders[m] for m in STUDY_ORDER}, camera, SHEET_ALPHA, edges,
                                  offset=offset, maps=maps)
            images[SHEET] = study_sheet({m: virtual[m] for m in STUDY_ORDER}, half, SHEET_ALPHA)
        compose_s += time.perf_counter() - t
    t = time.perf_counter()
    files = {name: encode_image(name, image) for name, image in images.items()}
    shot_file = Path(task["dir"]) / SHOT_FILE
    files[SHOT_FILE] = (json.dumps({**shot, "photo": photo_reference(photo_path, shot_file)}, indent=2) + "\n").encode()
    timings.update(render=render_s, compose=compose_s, encode=time.perf_counter() - t)
    return files, {"registration": registration, "size": [camera.width, camera.height], "photo": str(photo_path)}


def run_shot(task: dict, scene=None) -> dict:
    """Register, render, blend and encode one shot; never raises for a bad shot.

    Returns the shot's record (``status`` "done" or "failed" with ``error``). With
    ``task["write"]`` the files and ``record.json`` are written into ``task["dir"]`` here;
    otherwise the record carries them as ``files`` (bytes) for the caller to write. ``scene``:
    the job's loaded Scene, when this runs in the process that loaded it.
    """
    start = time.perf_counter()
    timings = {}
    record = {"name": task["name"], "status": "failed", "error": None, "fingerprint": task["fingerprint"],
              "inputs": task["inputs"], "registration": None}
    try:
        files, info = _shot_files(task, timings, scene)
        outputs = [dict(o) for o in plan_outputs(task["settings"])] + [{"file": SHOT_FILE, "kind": "shot"}]
        missing = [o["file"] for o in outputs if o["file"] not in files]
        if missing:
            raise MrcheckError(f"internal error: outputs not produced: {missing}")
        record.update(status="done", outputs=outputs, **info)
        record["files"] = files
    except _ShotFailed as exc:
        record.update(error=str(exc), registration=exc.registration)
    except MrcheckError as exc:
        record["error"] = str(exc)
    except Exception as exc:  # a bug, or the GL driver: report it and go on with the other shots
        record["error"] = f"internal error: {type(exc).__name__}: {exc}"
    record["registration_error_px"] = (record["registration"] or {}).get("rms_px")
    timings["total"] = time.perf_counter() - start
    record["timings_s"] = {k: round(v, 4) for k, v in timings.items()}
    if task["write"] and record["status"] == "done":
        record = store_shot(task["dir"], record)
    return record


def store_shot(folder, record: dict) -> dict:
    """Write a shot's ``files`` atomically, then its ``record.json`` (last: it marks the shot
    finished). Returns the record without the files, with the write time."""
    folder = Path(folder)
    start = time.perf_counter()
    for name, data in record["files"].items():
        write_bytes(folder / name, data)
    record = {k: v for k, v in record.items() if k != "files"}
    record["timings_s"] = dict(record.get("timings_s") or {}, write=round(time.perf_counter() - start, 4))
    write_text(folder / RECORD, json.dumps(record, indent=2) + "\n")
    return record


def store_failure(folder, record: dict, keep: set = frozenset()) -> None:
    """A failed shot: what earlier runs wrote into its folder no longer matches its inputs and goes
    (only the export's own file names, never a file in ``keep``, what the job reads); a
    record.json saying "failed" marks the folder as the export's, so that a later job without
    the shot recognises and removes it (a failed record is never "finished": reruns redo it)."""
    folder = Path(folder)
    for file in _own_files(folder, keep) if folder.is_dir() else []:
        file.unlink(missing_ok=True)
    record = {k: v for k, v in record.items() if k != "files"}
    write_text(folder / RECORD, json.dumps(record, indent=2) + "\n")


def _prepare_folder(folder: Path) -> None:
    """Before a shot runs: its old record goes first (the shot is unfinished until it is written
    again) and temp files of a killed run are removed."""
    (folder / RECORD).unlink(missing_ok=True)
    if folder.is_dir():
        for part in folder.glob(".*.part"):
            part.unlink(missing_ok=True)


def _own_names(task: dict) -> list:
    """The names of every file the export writes into ``task``'s shot folder."""
    return [*(o["file"] for o in plan_outputs(task["settings"])), SHOT_FILE, RECORD]


def _own_files(folder: Path, keep: set) -> list:
    """The files in ``folder`` with the export's own names (:data:`_OUTPUT_NAME`), except those in
    ``keep`` (what the job reads): the only files the export ever removes."""
    return [f for f in folder.iterdir() if _OUTPUT_NAME.fullmatch(f.name) and f.is_file() and real_path(f) not in keep]


def _remove_stale(outdir: Path, tasks: list, keep: set) -> list:
    """Remove what earlier runs wrote and this job no longer produces: in this job's shot folders,
    outputs no longer planned (a dropped alpha, intensity or mode); folders of shots no longer in
    the job, when they hold the export's record.json. Only the export's own file names go, never a
    file in ``keep`` (what the job reads); a folder is removed once empty. Returns the removed
    paths, relative to OUTDIR."""
    planned = {Path(t["dir"]).name: set(_own_names(t)) for t in tasks}
    shots = outdir / "shots"
    removed = []
    for folder in sorted(shots.iterdir()) if shots.is_dir() else []:
        wanted = planned.get(folder.name)
        if not folder.is_dir() or folder.is_symlink() or (wanted is None and not (folder / RECORD).is_file()):
            continue  # not a folder the export finished a shot in: maybe not ours
        # record.json last: a run killed half-way leaves a folder the next run still recognises
        stale = sorted((f for f in _own_files(folder, keep) if f.name not in (wanted or ())),
                       key=lambda f: f.name == RECORD)
        for file in stale:
            file.unlink(missing_ok=True)
            removed.append(file.relative_to(outdir).as_posix())
        if wanted is None:
            try:
                folder.rmdir()
            except OSError:
                pass  # files the export did not write stay, and so does their folder
    return removed


# -- executors ----------------------------------------------------------------------------------
def _worker_init(gl_threads: int | None) -> None:
    _exit_with_parent()
    # llvmpipe rasterises with one thread per core; N processes on the same cores share them
    if gl_threads and "LP_NUM_THREADS" not in os.environ:
        os.environ["LP_NUM_THREADS"] = str(gl_threads)


def _exit_with_parent() -> None:
    """End this worker when the export that spawned it dies (``kill -9``, OOM killer). Otherwise it
    finishes the shots already queued to it, writing into OUTDIR while a rerun works there, and
    then waits for more forever.

    Linux: the kernel's parent-death signal, at once, even in a long GL call that holds the GIL.
    It is sent when the *thread* that started this process ends; ProcessPoolExecutor starts its
    workers in the thread that submits the shots, which holds the pool until it is shut down.
    Everywhere, and for a parent already gone before prctl: multiprocessing's parent sentinel, a
    pipe from the parent that reads end-of-file once the parent has exited, watched by a thread.
    """
    parent = multiprocessing.parent_process()
    if parent is None:  # not started by multiprocessing: no parent to follow
        return
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    threading.Thread(target=_exit_on_eof, args=(parent.sentinel,), name="mrcheck-parent-watch", daemon=True).start()


def _exit_on_eof(sentinel) -> None:
    multiprocessing.connection.wait([sentinel])
    os._exit(1)  # no cleanup: every file is written atomically, a rerun removes the temp files


def _local_workers(workers: int, shots: int) -> int:
    """Processes :func:`_run_local` uses: 1 (this one) for one shot or one worker."""
    return 1 if workers <= 1 or shots <= 1 else min(workers, shots)


def _run_local(tasks, workers: int, scene=None):
    workers = _local_workers(workers, len(tasks))
    if workers == 1:
        for task in tasks:
            yield task, run_shot(task, scene)
        return
    threads = max(1, (os.cpu_count() or 1) // workers)
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=_worker_init, initargs=(threads,)) as pool:
        futures = {pool.submit(run_shot, task): task for task in tasks}
        for future in as_completed(futures):
            task = futures[future]
            try:
                yield task, future.result()
            except Exception as exc:  # the worker process died (BrokenProcessPool) or could not start
                yield task, _lost(task, exc)


class _Progress:
    """stderr for the progress bar and lines, which a closed reader cannot stop: with
    ``mrcheck export ... 2>&1 | head`` the export still finishes and writes its manifest and
    report (the bar's writes fail with EPIPE and are dropped from then on)."""

    def __init__(self, stream):
        self.stream, self.closed_reader = stream, False

    def _try(self, call) -> None:
        if not self.closed_reader:
            try:
                call()
            except (BrokenPipeError, ValueError):   # ValueError: the stream itself was closed
                self.closed_reader = True

    def write(self, text: str) -> None:
        self._try(lambda: self.stream.write(text))

    def flush(self) -> None:
        self._try(self.stream.flush)

    def isatty(self) -> bool:
        return not self.closed_reader and self.stream.isatty()


def _connect(address: str):
    """A Dask client of the scheduler at ``address``; a bad or unreachable address is a one-line error."""
    try:
        from distributed import Client
    except ImportError:
        raise MrcheckError("--scheduler needs Dask distributed: pip install 'mrcheck[cluster]'") from None
    # Dask retries a refused connection until its timeout (30 s); a plain TCP connect answers a
    # closed port or an unknown host at once
    match = re.fullmatch(r"(?:tcp://)?\[?([^\]/]+?)\]?:(\d+)/?", address.strip())
    if match:
        try:
            socket.create_connection((match[1], int(match[2])), timeout=5).close()
        except (OSError, ValueError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
            raise MrcheckError(f"cannot connect to the Dask scheduler at {address} ({reason})") from None
    try:
        return Client(address, timeout=SCHEDULER_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        raise MrcheckError(f"cannot connect to the Dask scheduler at {address} ({exc})") from None


def _run_dask(tasks, client):
    from distributed import as_completed as dask_completed

    futures = client.map(run_shot, tasks, pure=False)
    owner = {f.key: t for f, t in zip(futures, tasks)}
    for future in dask_completed(futures):
        task = owner[future.key]
        try:
            record = future.result()
        except Exception as exc:  # a worker died or could not unpickle the task
            record = _lost(task, exc)
        future.release()
        yield task, record


def _lost(task, exc) -> dict:
    return {"name": task["name"], "status": "failed", "fingerprint": task["fingerprint"], "inputs": task["inputs"],
            "error": f"worker failed: {type(exc).__name__}: {exc}", "registration": None,
            "registration_error_px": None, "timings_s": {}}


# -- the command --------------------------------------------------------------------------------
def _manifest_entry(record: dict, status: str, outdir: Path, folder: Path) -> dict:
    rel = folder.relative_to(outdir).as_posix()
    entry = {k: v for k, v in record.items() if k not in ("files", "outputs", "fingerprint")}
    entry["status"] = status
    entry["folder"] = rel
    entry["outputs"] = [dict(o, path=f"{rel}/{o['file']}") for o in record.get("outputs", [])] \
        if record.get("status") == "done" else []
    return entry


def _make_outdir(outdir: Path) -> None:
    """Create OUTDIR and check that it takes files: one under /proc, below a file or read-only
    fails now, in one line, not after the first shot's render."""
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MrcheckError(f"cannot create or write to the output folder ({exc.strerror or exc})", outdir) from None
    check_writable_ancestor(outdir, "output folder", itself=True)


def export_command(job, outdir, workers: int = 1, scheduler: str | None = None, force: bool = False) -> int:
    """``mrcheck export``: returns the exit status (0 every shot done or skipped, 1 any failed)."""
    from tqdm import tqdm

    started = time.perf_counter()
    job = load_job(job)
    outdir = real_path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("output folder is a file", outdir)
    if workers < 1:
        raise MrcheckError(f"workers must be >= 1, got {workers}")
    if scheduler and workers != 1:
        click.echo("warning: --workers is ignored with --scheduler (the cluster's workers run the shots)", err=True)
    scene_paths = scene_files(job.scene)
    tasks = _tasks(job, outdir, write=scheduler is None, scene_paths=scene_paths)
    check_not_inputs([outdir / MANIFEST, outdir / REPORT, *(Path(t["dir"]) / name for t in tasks for name in _own_names(t))],
                     [("the job", job.path), ("the scene", scene_paths),
                      *((f"an input of shot {t['name']}", t["input_files"]) for t in tasks)])

    entries, to_run = {}, []
    for task in tasks:
        record = None if force else finished_record(task)
        if record is not None:
            entries[task["name"]] = _manifest_entry(record, "skipped", outdir, Path(task["dir"]))
        else:
            to_run.append(task)
    # connected before OUTDIR is made: a bad or unreachable scheduler leaves no empty OUTDIR behind
    client = _connect(scheduler) if scheduler else None
    try:
        _make_outdir(outdir)
        reads = {real_path(f) for f in scene_paths} | {real_path(f) for t in tasks for f in t["input_files"]}
        removed = _remove_stale(outdir, tasks, reads)
        for task in to_run:
            _prepare_folder(Path(task["dir"]))

        runner = _run_dask(to_run, client) if client is not None else _run_local(to_run, workers, job.loaded)
        run_start, finished = time.perf_counter(), 0
        progress = _Progress(sys.stderr)
        # disable=None: a bar on a terminal only; a log gets one plain line per shot instead of \r frames
        with tqdm(total=len(tasks), initial=len(tasks) - len(to_run), desc="export", unit="shot", file=progress,
                  dynamic_ncols=True, disable=None) as bar:
            for task, record in runner:
                folder = Path(task["dir"])
                if record["status"] == "done" and "files" in record:  # from a cluster: written here
                    record = store_shot(folder, record)
                elif record["status"] == "failed":
                    store_failure(folder, record, reads)
                entries[task["name"]] = _manifest_entry(record, record["status"], outdir, folder)
                bar.update(1)
                finished += 1
                if bar.disable:
                    eta = (time.perf_counter() - run_start) / finished * (len(to_run) - finished)
                    progress.write(f"export: {len(tasks) - len(to_run) + finished}/{len(tasks)} shots, {task['name']} "
                                   f"{record['status']}, ETA {eta:.0f} s\n")
                failed = sum(e["status"] == "failed" for e in entries.values())
                if failed:
                    bar.set_postfix(failed=failed)
    finally:
        if client is not None:
            client.close()

    shots = [entries[t["name"]] for t in tasks]
    counts = {s: sum(e["status"] == s for e in shots) for s in ("done", "skipped", "failed")}
    elapsed = time.perf_counter() - started
    ran = [e for e in shots if e["status"] != "skipped"]
    manifest = {
        "format": 1, "job": str(job.path.resolve()), "outdir": str(outdir), "settings": job.settings(),
        # the processes that ran: never more than the shots to run, and one (this one) for one shot
        "executor": f"dask {scheduler}" if scheduler else f"local, {_local_workers(workers, len(to_run))} worker(s)",
        "summary": {"shots": len(shots), **counts}, "timings_s": {
            "total": round(elapsed, 3),
            "shots_per_minute": round(60.0 * len(ran) / elapsed, 2) if ran and elapsed > 0 else None},
        "shots": shots, "removed": removed,
    }
    write_text(outdir / MANIFEST, json.dumps(manifest, indent=2) + "\n")
    write_report(manifest, outdir)

    click.echo(f"export: {len(shots)} shots: {counts['done']} done, {counts['skipped']} skipped, "
               f"{counts['failed']} failed ({elapsed:.1f} s)")
    for entry in shots:
        if entry["status"] == "failed":
            click.echo(f"  failed {entry['name']}: {entry['error']}")
    warned = [e["name"] for e in shots if e["status"] == "done" and (e.get("registration") or {}).get("warnings")]
    if warned:
        click.echo(f"  {len(warned)} shot(s) with registration warnings ({', '.join(warned[:5])}"
                   f"{', ...' if len(warned) > 5 else ''}): see report.html")
    if removed:
        # removed paths are shots/NAME/FILE; a NAME no longer in the job is a dropped shot
        dropped = {p.split("/")[1] for p in removed} - {entry["name"] for entry in shots}
        of_shots = f", including the outputs of {len(dropped)} shot(s) no longer in the job" if dropped else ""
        click.echo(f"removed {len(removed)} file(s) of earlier runs that this job no longer produces{of_shots} "
                   f"(listed in manifest.json)")
    click.echo(f"wrote {outdir / MANIFEST} and {outdir / REPORT}")
    return 1 if counts["failed"] else 0


__all__ = ["export_command", "load_job", "run_shot", "plan_outputs", "finished_record", "store_shot", "store_failure",
           "Job"]
