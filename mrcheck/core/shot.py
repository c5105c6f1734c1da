"""A registered shot (SHOT.json): the one record, its one reader and its one writer.

A SHOT.json is a camera JSON (:meth:`Camera.to_dict`'s keys, so ``render --camera`` takes it as
is), then ``"photo"`` (the photo's path relative to the SHOT.json's folder, :func:`photo_reference`),
then what the registration reported, in the order it reported it. The report's keys depend on the
method: :mod:`mrcheck.mr.registration` (``"markers"``, ``"points"``), :mod:`mrcheck.mr.edgeshot`
(``"edges"``) and the review's clicks (:mod:`mrcheck.apps.review.clicks`) each list theirs. Every
method writes ``method``, ``rms``, ``expected_overlay_error_px``, ``camera_position`` and
``warnings``, which :class:`Shot` reads as properties.

:func:`read_shot` and :func:`write_shot` (:func:`shot_text` for a writer that stores the bytes
later, the export's workers) are the only code that reads or writes the file's JSON: the text is
``json.dumps(..., indent=2)`` plus a newline.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.core.jsonfile import is_number, read_json
from mrcheck.core.output import write_text

CAMERA_KEYS = ("width", "height", "K", "dist", "R", "t")  # a camera JSON's keys, first in a SHOT.json


@dataclass(frozen=True)
class Anchors:
    """The correspondences a markers or points pose was solved from (the inliers): ``world``
    (n, 3), ``pixels`` (n, 2) and ``sigma_px``, their noise (px, 1 sigma per axis). Kept in
    memory for the edge refinement's gate (:func:`mrcheck.mr.register.refinement_gate`); not
    written to SHOT.json."""

    world: Any
    pixels: Any
    sigma_px: float


@dataclass(frozen=True)
class Shot:
    """A photo and the camera that took it, with what its registration reported.

    ``photo``: the photo's absolute path, None for an image registered in memory
    (:func:`mrcheck.mr.registration.register_markers`) that no file is known for yet.
    ``report``: the registration's fields as JSON values (lists, dicts, numbers, strings), in
    the order the SHOT.json lists them; never the camera keys or ``"photo"``. ``anchors``: the
    correspondences of a markers or points pose (:class:`Anchors`; not in the file).
    """

    camera: Camera
    photo: Path | None = None
    report: Mapping[str, Any] = field(default_factory=dict)
    anchors: Anchors | None = field(default=None, compare=False)

    @property
    def method(self) -> str | None:
        """How the pose was found ("markers", "points", "edges"), None for a hand-made shot."""
        method = self.report.get("method")
        return method if isinstance(method, str) else None

    @property
    def rms(self) -> float | None:
        """The registration's RMS error (px), None when absent or not a finite number."""
        rms: Any = self.report.get("rms")
        return float(rms) if is_number(rms) else None

    @property
    def warnings(self) -> list[str]:
        """The registration's warnings, in order."""
        return [str(w) for w in self.report.get("warnings") or ()]

    def with_photo(self, photo: os.PathLike[str] | str) -> Shot:
        """This shot of the photo file ``photo`` (made absolute)."""
        return dataclasses.replace(self, photo=Path(photo).resolve())

    def with_report(self, **fields: Any) -> Shot:
        """This shot with report ``fields`` changed in place or, when new, added at the end."""
        return dataclasses.replace(self, report={**self.report, **fields})

    def to_dict(self, photo: str | None = None) -> dict[str, Any]:
        """The SHOT.json object: camera keys, ``"photo"`` (``photo``, else the absolute path), the report."""
        if self.photo is None:
            raise ValueError("a shot without a photo file has no SHOT.json")
        return {**self.camera.to_dict(), "photo": str(self.photo) if photo is None else photo, **self.report}


def read_shot(path: os.PathLike[str] | str) -> Shot:
    """The :class:`Shot` of a SHOT.json, its photo resolved against the file's folder; a
    one-line error naming the file when it is no shot."""
    path = Path(path)
    data = read_json(path, "shot")  # a shot is JSON (camera keys + "photo"), never OpenCV YAML
    camera = Camera.from_dict(data, path)
    photo = data.get("photo")
    if not isinstance(photo, str) or not photo:
        raise MrcheckError('shot JSON has no "photo" path', path)
    photo_path = Path(photo)
    if not photo_path.is_absolute():
        photo_path = path.resolve().parent / photo_path
    report = {k: v for k, v in data.items() if k not in CAMERA_KEYS and k != "photo"}
    return Shot(camera, photo_path, report)


def shot_text(shot: Shot, shot_file: os.PathLike[str] | str) -> str:
    """The SHOT.json text of ``shot`` written to ``shot_file`` (its photo relative to that file)."""
    if shot.photo is None:
        raise ValueError("a shot without a photo file has no SHOT.json")
    return json.dumps(shot.to_dict(photo_reference(shot.photo, shot_file)), indent=2) + "\n"


def write_shot(path: os.PathLike[str] | str, shot: Shot) -> Path:
    """Write ``shot`` to the SHOT.json ``path`` atomically; returns the path."""
    return write_text(path, shot_text(shot, path))


def photo_reference(photo: os.PathLike[str] | str, shot_file: os.PathLike[str] | str) -> str:
    """The ``"photo"`` value of a SHOT.json written to ``shot_file``: the photo's path relative
    to the shot's folder (:func:`read_shot` resolves it against that folder), so that a project
    folder of shots and photos, or an export folder with the photos beside it, can be moved or
    copied to another machine as a whole; absolute when no relative path exists (a photo on
    another Windows drive). Pure path arithmetic: an export's Dask worker computes it for a
    folder on the client."""
    real_photo, folder = os.path.realpath(photo), os.path.dirname(os.path.realpath(shot_file))
    try:
        return Path(os.path.relpath(real_photo, folder)).as_posix()
    except ValueError:
        return real_photo


__all__ = ["Anchors", "Shot", "read_shot", "write_shot", "shot_text", "photo_reference", "CAMERA_KEYS"]
