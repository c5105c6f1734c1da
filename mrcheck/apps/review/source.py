"""What a review looks at: shots (camera + photo) of one scene, from a job, an export or a folder."""

from __future__ import annotations

import concurrent.futures
import json
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from mrcheck.apps.names import MANIFEST, REPORT, SHOT_FILE, shot_folder, shot_name
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_photo
from mrcheck.core.errors import MrcheckError, MrcheckWarning, display
from mrcheck.core.images import MAX_PIXELS  # the largest photo read (--max-pixels)
from mrcheck.core.inputs import check_input
from mrcheck.core.shot import read_shot
from mrcheck.scene.manifest import files_stamp, read_manifest, scene_files
from mrcheck.scene.model import MANIFEST_KEYS, load_scene

MAX_SIZE = 1280  # renders and photos are served at most this wide (same aspect as the photo)
# Marker, pick and suggestion coordinates are the photo's native pixels everywhere (database, API,
# CSV, report), whatever the size the images are served at: a downstream tool, and mrcheck
# discrepancies, look at the original photo.
# an export's shot names (never "." or ".."), at most 128 characters: a path segment of the API's URLs
_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,127}")
ADDED_SHOTS = "added-shots"  # shots added in the review ("Add photo") of an export or a job, beside it


@dataclass
class Shot:
    name: str
    camera: Camera  # at the photo's native size
    photo: Path
    error_px: float | None  # registration RMS, px
    file: Path | None = None  # its SHOT.json, where it came from one

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the photo: the frame of marker coordinates."""
        return self.camera.width, self.camera.height

    @property
    def served_size(self) -> tuple[int, int]:
        """(width, height) of the images served to the browser (it stretches them to ``size``)."""
        w, h = self.size
        if w <= MAX_SIZE:
            return w, h
        return MAX_SIZE, max(1, round(MAX_SIZE * h / w))

    def served_scale(self) -> tuple[float, float]:
        """Served image pixels per photo pixel, in x and y."""
        return self.served_size[0] / self.size[0], self.served_size[1] / self.size[1]

    def served_camera(self) -> Camera:
        w, h = self.served_size
        return self.camera if (w, h) == self.size else self.camera.resized(w, h)


@dataclass
class Source:
    scene: Path
    shots: dict  # name -> Shot, in display order
    home: Path  # folder for review.sqlite and the render cache
    label: str  # what is reviewed, for people (display(): printable, JSON-encodable)
    scene_stamp: str = ""  # files_stamp of the scene's files, set by open_source (keys the render cache)
    loaded: object = None  # the Scene, loaded once by open_source (the renderer and the picker share it)
    origin: Path | None = None  # the job file, export folder or shots folder reviewed
    files: list = field(default_factory=list)  # the files read to find the shots (job, manifest, SHOT.json, ...)
    kind: str = "scene"  # what is reviewed: "scene" (SCENE --shots DIR), "export" or "job"
    max_pixels: int = MAX_PIXELS  # a photo of more pixels is refused before it is decoded

    def inputs(self) -> list:
        """``(what, paths)`` of every file the review reads (:func:`mrcheck.core.output.check_not_inputs`)."""
        return [
            ("a file of the review", self.files),
            ("a photo", [s.photo for s in self.shots.values()]),
            ("the scene", scene_files(self.scene)),
        ]

    def review_name(self, db_path) -> str:
        """The review's name in the database at ``db_path``: the path of what is reviewed,
        relative to the database's folder ("." for an export's own review.sqlite), so that a
        folder moved or copied with its database keeps its review, and one database given to
        several exports keeps their markers apart."""
        # display(): a name that is not valid UTF-8 is no SQLite text; as \xNN it is (and stays apart)
        return display(Path(os.path.relpath(Path(self.origin).resolve(), Path(db_path).resolve().parent)).as_posix())


def _shot(name, path) -> Shot:
    registered = read_shot(path)
    return Shot(name, registered.camera, registered.photo, registered.rms, file=Path(path))


def _checked_name(name: str, path) -> str:
    if not _NAME.fullmatch(name):
        raise MrcheckError(f"shot name {name!r} is not usable (up to 128 letters, digits, . _ -)", path)
    return name


def _warn(message: str) -> None:
    """One shot that cannot be reviewed is a warning, not the end of the review of the others."""
    warnings.warn(message, MrcheckWarning, stacklevel=2)


def _read_manifest(path: Path) -> tuple[Path, list]:
    """The scene and shot entries of an export's manifest.json, or a one-line error naming it."""
    try:
        manifest = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise MrcheckError(f"cannot read the export manifest ({exc})", path) from None
    settings = manifest.get("settings") if isinstance(manifest, dict) else None
    if not isinstance(settings, dict) or not isinstance(settings.get("scene"), str):
        raise MrcheckError("not an export manifest (no settings.scene)", path)
    entries = manifest.get("shots", [])
    if not isinstance(entries, list) or not all(
        isinstance(e, dict) and isinstance(e.get("name"), str) for e in entries
    ):
        raise MrcheckError("not an export manifest (shots must be a list of entries with a name)", path)
    return Path(settings["scene"]), entries


def from_outdir(outdir: Path) -> Source:
    scene, entries = _read_manifest(outdir / MANIFEST)
    shots, files = {}, [outdir / MANIFEST]
    for entry in sorted(entries, key=lambda e: e["name"]):
        if entry.get("status") not in ("done", "skipped"):  # failed in the export: its report says why
            continue
        try:  # a done shot's SHOT.json deleted or broken since the export
            name = _checked_name(entry["name"], outdir / MANIFEST)
            folder = outdir / entry["folder"] if "folder" in entry else shot_folder(outdir, name)
            files.append(folder / SHOT_FILE)
            shots[name] = _shot(name, files[-1])
        except MrcheckError as exc:
            _warn(f"shot {entry['name']} skipped: {exc}")
    if not shots:
        failed = sum(e.get("status") == "failed" for e in entries)
        why = (
            f"every shot ({failed}) failed in the export; its {REPORT} says why"
            if entries and failed == len(entries)
            else "the export has no shots"
            if not entries
            else "see the warnings above"
        )
        raise MrcheckError(f"no usable shots to review: {why}", outdir)
    return Source(scene, shots, outdir, display(outdir), origin=outdir, files=files, kind="export")


def from_job(job_path: Path) -> Source:
    from mrcheck.apps.export.job import load_job
    from mrcheck.apps.export.shot import register_shot
    from mrcheck.apps.export.tasks import input_files

    job = load_job(job_path)
    bounds = job.loaded.bounds()  # loaded by load_job: a camera far outside the scene is a warning, as in export
    shots, files = {}, [job_path]
    for entry in job.shots:
        files += input_files(entry.inputs)
        try:
            registered = register_shot(entry.inputs, None, bounds)
        except MrcheckError as exc:
            _warn(f"shot {entry.name} skipped: {exc}")
            continue
        for warning in registered.warnings if entry.inputs.shot is None else ():  # registered here, as export would
            _warn(f"shot {entry.name}: {warning}")
        name = _checked_name(entry.name, job_path)
        shots[name] = Shot(name, registered.camera, registered.photo, registered.rms)
    if not shots:
        raise MrcheckError("no usable shots to review: every shot was skipped (see the warnings above)", job_path)
    return Source(
        Path(job.scene),
        shots,
        job_path.resolve().parent,
        display(job_path),
        loaded=job.loaded,
        origin=job_path,
        files=files,
        kind="job",
    )


def _folder_shots(shots_dir: Path, shots: dict) -> list:
    """Add the SHOT.json files of ``shots_dir`` to ``shots``, named after their files as export
    names its shots; the folder's other JSON files (intrinsics, correspondences, a broken shot)
    are warnings. Returns the files read."""
    files = sorted(shots_dir.glob("*.json"))
    named = {}
    for path in files:
        try:
            name = _checked_name(shot_name(path.stem)[:128], path)
            if name in shots:
                raise MrcheckError(f"its shot name {name!r} is that of {named.get(name, 'another shot')} too", path)
            shots[name], named[name] = _shot(name, path), path.name
        except MrcheckError as exc:
            _warn(f"{exc} (skipped: not a usable shot)")
    return files


def from_scene(scene: Path, shots_dir: Path) -> Source:
    """The SHOT.json files of ``shots_dir`` (:func:`_folder_shots`)."""
    shots = {}
    files = _folder_shots(shots_dir, shots)
    if not shots:
        why = f"none of its {len(files)} JSON file(s) is a shot" if files else "it has no SHOT.json files (*.json)"
        raise MrcheckError(f"no usable shots to review: {why}", shots_dir)
    return Source(scene, shots, shots_dir, display(f"{scene} + {shots_dir}"), origin=shots_dir, files=files)


def _toml_keys(path: Path) -> set:
    try:
        return set(read_manifest(path))
    except MrcheckError:
        return set()  # load_job or load_scene says what is wrong with it


def _is_scene_manifest(path: Path) -> bool:
    # a scene's keys and none of a job's: a manifest without [[parts]] is still a scene (a broken one)
    keys = _toml_keys(path)
    return bool(keys) and keys <= MANIFEST_KEYS


def _check_scene_target(target: Path) -> None:
    """SCENE of ``SCENE --shots DIR`` is not a job or an export, which name their scene themselves
    (else load_scene would list the job's keys as unknown, or miss the export's scene.toml)."""
    if target.is_dir() and (target / MANIFEST).is_file():
        raise MrcheckError("is an export folder, not a scene: review it without --shots", target)
    if target.suffix == ".toml" and target.is_file() and "shots" in _toml_keys(target):
        raise MrcheckError("is a job file, not a scene: review it without --shots", target)


def open_source(target, shots_dir=None, max_pixels: int = MAX_PIXELS) -> Source:
    """``JOB.toml`` | ``OUTDIR`` (with manifest.json) | ``SCENE`` with ``shots_dir``; ``max_pixels``:
    the largest photo the review reads (checked on its header before decoding)."""
    target = Path(target)
    if os.path.lexists(target):  # a missing one: the usage below; a symlink loop, a FIFO: say so
        check_input(target, "review target", folder_ok=True)
    if shots_dir is not None:
        if not Path(shots_dir).is_dir():
            raise MrcheckError("--shots must be a folder of registered SHOT.json files", shots_dir)
        _check_scene_target(target)
        source = from_scene(target, Path(shots_dir))
    elif target.is_dir():
        if not (target / MANIFEST).is_file():
            raise MrcheckError(
                "not an export folder (no manifest.json); pass JOB.toml, OUTDIR or SCENE --shots DIR", target
            )
        source = from_outdir(target)
    elif target.suffix == ".toml" and target.is_file():
        if _is_scene_manifest(target):  # else load_job would list the manifest's keys as unknown job keys
            raise MrcheckError(
                "is a scene manifest: give its shots with --shots DIR (registered SHOT.json files), "
                "or pass JOB.toml or an export OUTDIR",
                target,
            )
        source = from_job(target)
    else:
        raise MrcheckError("pass JOB.toml, an export OUTDIR or SCENE --shots DIR", target)
    source.max_pixels = max_pixels
    if source.kind != "scene" and (Path(source.home) / ADDED_SHOTS).is_dir():  # shots added in an earlier review
        source.files += _folder_shots(Path(source.home) / ADDED_SHOTS, source.shots)
    _check_files(source, target)
    return source


def _check_photos(source: Source) -> None:
    """Every photo decodes and has its shot's size (read_photo's one-line errors): the files are
    read in parallel (a network share's latency overlaps); the decodes take turns, as every
    decode does (mrcheck.core.quiet: the codecs' own messages are captured), about 0.25 s per 12 MP
    JPEG on this machine's cores. Of ``SCENE --shots DIR``, a shot whose photo has another size
    than its SHOT.json is skipped with a warning naming the SHOT.json, as its other unusable
    files are; of a job or an export, it is an error."""

    def size(shot) -> tuple[int, int]:  # the decoded image is not kept: dozens of them would not fit in memory
        if source.kind != "scene":
            read_photo(Path(shot.photo), shot.camera, max_pixels=source.max_pixels)
            return shot.size
        height, width = read_photo(Path(shot.photo), max_pixels=source.max_pixels).shape[:2]
        return width, height

    shots = list(source.shots.values())
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(8, os.cpu_count() or 1)) as pool:
        sizes = list(pool.map(size, shots))  # raises the error of the first bad photo in shot order
    for shot, (w, h) in zip(shots, sizes):
        if (w, h) != shot.size:
            _warn(
                f"{shot.file}: its photo {shot.photo.name} is {w}x{h} but the shot was registered at "
                f"{shot.size[0]}x{shot.size[1]} (skipped: not a usable shot)"
            )
            del source.shots[shot.name]
    if not source.shots:
        raise MrcheckError(f"no usable shots to review: the photos of all {len(shots)} have another size", source.home)


def _check_files(source: Source, target: Path) -> None:
    """Every file the server will read exists, and the scene loads, checked before the URL is
    printed: else each render or pick of the shot (or of every shot) would fail only once the
    planner asks for it. Also stamps the scene's files once, for the render cache."""
    if not os.path.lexists(source.scene):
        named_by = f" (named by {target / MANIFEST}; moved since the export?)" if target.is_dir() else ""
        raise MrcheckError(f"scene not found{named_by}", source.scene)
    check_input(source.scene, "scene", folder_ok=True)  # a symlink loop, a FIFO ...
    files = scene_files(source.scene)
    # files[0] is the manifest or mesh itself (a folder's scene.toml may be another *.toml: load_scene says)
    missing = next((p for p in files[1:] if not os.path.lexists(p)), None)
    if missing is not None:
        raise MrcheckError(f"scene file not found (a mesh of {source.scene})", missing)
    for shot in source.shots.values():
        if not os.path.lexists(shot.photo):
            raise MrcheckError(f"photo of shot {shot.name!r} not found", shot.photo)
    _check_photos(source)
    source.scene_stamp = files_stamp(files)
    if source.loaded is None:
        source.loaded = load_scene(source.scene, progress=True)
