"""The export's job file (TOML): read, checked and resolved into a :class:`Job`.

Every relative path is relative to the job file's folder; every problem is one line naming the
job file (and the ``[[shots]]`` table, counted from 1, with its name or photo). The keys are
listed in :mod:`mrcheck.apps.export`'s docstring.
"""

from __future__ import annotations

import glob
import os
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

from mrcheck.apps.names import is_shot_name, shot_name
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input_text, real_path
from mrcheck.core.jsonfile import number_problem
from mrcheck.mr.overlay import STUDY_ORDER, check_alpha
from mrcheck.render.renderer import DEFAULT_SAMPLES, MODES
from mrcheck.render.settings import MAX_ACCUMULATE

SHEET_ALPHA = 0.5  # the photo's opacity in the study sheet's bottom row, and the default alpha
TOP_KEYS = {
    "scene",
    "modes",
    "alphas",
    "intensities",
    "overlay_intensity",
    "width",
    "max_registration_error_px",
    "samples",
    "accumulate",
    "edges",
    "antialias",
    "intrinsics",
    "markers",
    "points",
    "shots",
}
SHOT_KEYS = {"name", "shot", "photo", "photos", "intrinsics", "markers", "points"}
_METHODS = ("markers", "points")
_SHARED = ("intrinsics", *_METHODS)  # shot inputs the job may give once for every shot


@dataclass(frozen=True)
class JobSettings:
    """What every shot of the job is made with (also the manifest's ``settings``)."""

    scene: str  # the scene's path, resolved
    modes: list
    alphas: list
    intensities: list
    overlay_intensity: float
    width: int | None  # None: the photo's size
    max_error: float | None  # max_registration_error_px; None: no limit
    samples: int
    edges: bool
    antialias: bool = True  # the renders anti-aliased (mrcheck.render.antialias)
    accumulate: int = 1  # AO frames averaged (RenderSettings.accumulate)

    def to_dict(self) -> dict:
        """As the manifest and the shots' fingerprints write them (the job file's key names)."""
        d = asdict(self)
        d["max_registration_error_px"] = d.pop("max_error")
        return {
            k: d[k]
            for k in (
                "scene",
                "modes",
                "alphas",
                "intensities",
                "overlay_intensity",
                "width",
                "max_registration_error_px",
                "samples",
                "edges",
                "antialias",
                "accumulate",
            )
        }


@dataclass(frozen=True)
class ShotInputs:
    """The files one shot is made from: a registered ``shot`` (SHOT.json), or a ``photo`` with its
    ``intrinsics`` and ``markers`` or ``points``. Paths are absolute strings."""

    shot: str | None = None
    photo: str | None = None
    intrinsics: str | None = None
    markers: str | None = None
    points: str | None = None

    def to_dict(self) -> dict:
        """The given ones, as record.json and the fingerprint write them."""
        return {k: v for k, v in asdict(self).items() if v is not None}

    @classmethod
    def from_dict(cls, data: dict) -> "ShotInputs":
        return cls(**{k: data[k] for k in ("shot", "photo", "intrinsics", "markers", "points") if k in data})


@dataclass(frozen=True)
class PlannedShot:
    name: str
    inputs: ShotInputs


@dataclass
class Job:
    path: Path
    settings: JobSettings
    shots: list = field(default_factory=list)  # [PlannedShot]
    loaded: object = field(default=None, repr=False, compare=False)  # the Scene, loaded once by load_job

    @property
    def scene(self) -> Path:
        return Path(self.settings.scene)


class _Reader:
    """One job file being read: its data, folder and the shared inputs checked so far."""

    def __init__(self, path: Path):
        self.path = path
        text = read_input_text(path, "job file", encoding="utf-8-sig")  # -sig: a BOM (Windows Notepad) is no error
        try:
            self.data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            self.fail(f"malformed job TOML: {exc}")
        self.base = real_path(path).parent
        self.checked = set()  # shared inputs are parsed once so that a bad one fails the job, not every shot

    def fail(self, message):
        raise MrcheckError(message, self.path)

    def resolve(self, value, where) -> Path:
        if not isinstance(value, str) or not value:
            self.fail(f"{where} must be a path (a non-empty string)")
        return real_path(self.base / value) if not Path(value).is_absolute() else Path(value)

    def number(self, key, value, check, what) -> float:
        """``value`` when it is a finite number that passes ``check``; else "KEY: what is wrong"."""
        if problem := number_problem(value) or (None if check(value) else f"{value} is {what}"):
            self.fail(f"{key}: {problem}")
        return float(value)

    def numbers(self, key, default, check, what) -> list:
        values = self.data.get(key, default)
        if not isinstance(values, list) or not values:
            self.fail(f"{key} must be a non-empty list of numbers")
        return list(dict.fromkeys(self.number(key, v, check, what) for v in values))

    def shared_input(self, key, value, where) -> str:
        """A shot's intrinsics, markers or points file, loaded once per job to check it."""
        file = self.resolve(value, f"{where}: {key}")
        if (key, file) not in self.checked:
            from mrcheck.core.camerafiles import read_camera
            from mrcheck.mr.markers import load_marker_map
            from mrcheck.mr.registration import load_points

            load = {"intrinsics": read_camera, "markers": load_marker_map, "points": load_points}[key]
            try:
                load(file)
            except MrcheckError as exc:
                self.fail(f"{where}: {exc}")
            self.checked.add((key, file))
        return str(file)


def load_job(path) -> Job:
    """Parse and validate a job file; every error is one line naming the file. The scene is
    loaded here (``Job.loaded``): a bad scene is a bad job, not N failed shots."""
    reader = _Reader(Path(path))
    unknown = sorted(set(reader.data) - TOP_KEYS)
    if unknown:
        reader.fail(f"unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(TOP_KEYS))})")
    scene, loaded = _scene(reader)
    settings = _settings(reader, scene)
    return Job(reader.path, settings, _shots(reader), loaded)


def _scene(reader: _Reader):
    """The scene's resolved path and the Scene, loaded."""
    if "scene" not in reader.data:
        reader.fail('no scene: give scene = "path/to/scene.toml"')
    scene = reader.resolve(reader.data["scene"], "scene")
    if not os.path.lexists(scene):
        reader.fail(f"scene not found: {scene}")
    from mrcheck.scene.model import load_scene

    try:
        return scene, load_scene(scene, progress=True)
    except MrcheckError as exc:
        reader.fail(f"scene: {exc}")


def _modes(reader: _Reader) -> list:
    modes = reader.data.get("modes", list(STUDY_ORDER))
    if not isinstance(modes, list) or not modes or not all(isinstance(m, str) for m in modes):
        reader.fail("modes must be a non-empty list of mode names")
    bad = [m for m in modes if m not in MODES]
    if bad:
        reader.fail(f"unknown mode(s) {', '.join(map(repr, bad))} (use {', '.join(MODES)})")
    return list(dict.fromkeys(modes))


def _whole(reader: _Reader, key: str, default, low: int, high: int, what: str):
    """A whole number ``low..high`` (or the default, which may be None: not set)."""
    value = reader.data.get(key, default)
    if value is not None and not (isinstance(value, int) and not isinstance(value, bool) and low <= value <= high):
        reader.fail(f"{key} must be {what}, got {value!r}")
    return value


def _settings(reader: _Reader, scene: Path) -> JobSettings:
    data = reader.data
    modes = _modes(reader)
    alphas = reader.numbers("alphas", [SHEET_ALPHA], lambda a: 0.0 <= a <= 1.0, "outside 0..1 (the photo's opacity)")
    for a in alphas:
        check_alpha(a)
    intensities = reader.numbers("intensities", [1.0], lambda i: i >= 0.0, "negative (AO strength must be >= 0)")
    overlay = data.get("overlay_intensity", 1.0 if 1.0 in intensities else intensities[len(intensities) // 2])
    overlay = reader.number(
        "overlay_intensity", overlay, lambda i: i in intensities, f"not one of the intensities {intensities}"
    )
    width = _whole(reader, "width", None, 16, 16384, "a whole number of pixels, 16..16384")
    max_error = data.get("max_registration_error_px")
    if max_error is not None:
        max_error = reader.number("max_registration_error_px", max_error, lambda e: e > 0, "not positive")
    samples = _whole(reader, "samples", DEFAULT_SAMPLES, 1, 512, "a whole number 1..512")
    accumulate = _whole(reader, "accumulate", 1, 1, MAX_ACCUMULATE, f"a whole number 1..{MAX_ACCUMULATE}")
    edges, antialias = (_flag(reader, key, default) for key, default in (("edges", False), ("antialias", True)))
    return JobSettings(
        str(scene), modes, alphas, intensities, overlay, width, max_error, samples, edges, antialias, accumulate
    )


def _flag(reader: _Reader, key: str, default: bool) -> bool:
    value = reader.data.get(key, default)
    if not isinstance(value, bool):
        reader.fail(f"{key} must be true or false, got {value!r}")
    return value


def _shots(reader: _Reader) -> list:
    entries = reader.data.get("shots")
    if not isinstance(entries, list) or not entries:
        reader.fail("no shots: add [[shots]] tables (shot = SHOT.json, photo = ..., or photos = GLOB)")
    defaults = {k: reader.data[k] for k in _SHARED if k in reader.data}
    shots, names = [], set()
    for index, entry in enumerate(entries):
        where = _where(entry, index)
        for shot in _entry_shots(reader, entry, where, defaults):
            if shot.name in names:
                reader.fail(f"{where}: shot name {shot.name!r} used twice (give each shot its own name)")
            names.add(shot.name)
            shots.append(shot)
    return shots


def _where(entry, index: int) -> str:
    """``[[shots]] #N (name = ...)``: the planner counts [[shots]] tables from 1 and knows them by
    their name or photo."""
    label = next(
        (
            f"{k} = {entry[k]!r}"
            for k in ("name", "photo", "photos", "shot")
            if isinstance(entry, dict) and isinstance(entry.get(k), str)
        ),
        None,
    )
    return f"[[shots]] #{index + 1}" + (f" ({label})" if label else "")


def _entry_shots(reader: _Reader, entry, where: str, defaults: dict) -> list:
    """The shots of one ``[[shots]]`` table: one, or one per photo of a glob."""
    if not isinstance(entry, dict):
        reader.fail(f"{where} must be a table ([[shots]])")
    unknown = sorted(set(entry) - SHOT_KEYS)
    if unknown:
        reader.fail(f"{where}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(SHOT_KEYS))})")
    sources = [k for k in ("shot", "photo", "photos") if k in entry]
    if len(sources) != 1:
        reader.fail(f"{where}: give exactly one of shot = SHOT.json, photo = PHOTO, photos = GLOB")
    source = sources[0]
    if "name" in entry and (not isinstance(entry["name"], str) or not is_shot_name(entry["name"])):
        reader.fail(f"{where}: name {entry['name']!r} must be letters, digits, '.', '_' or '-'")
    if source == "photos" and "name" in entry:
        reader.fail(f"{where}: a photos glob names its shots after the files; drop name")
    if source == "shot":
        file = reader.resolve(entry["shot"], f"{where}: shot")
        return [PlannedShot(entry.get("name", shot_name(file.stem)), ShotInputs(shot=str(file)))]
    common = _photo_inputs(reader, entry, where, defaults, glob_=source == "photos")
    if source == "photo":
        file = reader.resolve(entry["photo"], f"{where}: photo")
        return [PlannedShot(entry.get("name", shot_name(file.stem)), ShotInputs(photo=str(file), **common))]
    return [
        PlannedShot(shot_name(f.stem), ShotInputs(photo=str(f), **common))
        for f in _glob(reader, entry["photos"], where)
    ]


def _photo_inputs(reader: _Reader, entry: dict, where: str, defaults: dict, glob_: bool) -> dict:
    """The intrinsics and the markers or points of a photo (or a glob's photos): the entry's own,
    else the job-wide defaults; each file checked once per job."""
    merged = {**defaults, **{k: entry[k] for k in _SHARED if k in entry}}
    if "markers" in entry and "points" in entry:
        reader.fail(f"{where}: give markers or points, not both")
    if "markers" in entry or "points" in entry:  # the shot's own choice beats the job-wide default
        merged.pop("points" if "markers" in entry else "markers", None)
    if "intrinsics" not in merged:
        reader.fail(f"{where}: no intrinsics (camera JSON or YAML) for the photo")
    method = [k for k in _METHODS if k in merged]
    if len(method) != 1:
        reader.fail(f"{where}: give exactly one of markers = MAP.json or points = CORR.json")
    method = method[0]
    if glob_ and method == "points":
        reader.fail(f"{where}: correspondences are per photo; use photo = ... for each (a glob takes markers)")
    return {
        "intrinsics": reader.shared_input("intrinsics", merged["intrinsics"], where),
        method: reader.shared_input(method, merged[method], where),
    }


def _glob(reader: _Reader, pattern, where: str) -> list:
    if not isinstance(pattern, str) or not pattern:
        reader.fail(f"{where}: photos must be a glob pattern (a string)")
    # not only the readable files: a photo that cannot be read (a symlink loop, a broken link) is
    # a shot that fails and says why, not one silently left out
    files = sorted(
        real_path(p) for p in glob.glob(os.path.join(str(reader.base), pattern), recursive=True) if not os.path.isdir(p)
    )
    if not files:
        reader.fail(f"{where}: photos {pattern!r} matches no file")
    return files


__all__ = ["Job", "JobSettings", "PlannedShot", "ShotInputs", "load_job", "SHEET_ALPHA"]
