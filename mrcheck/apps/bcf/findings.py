"""What mrcheck's results become in BCF: a shot's camera as a perspective camera, a severity
as a priority, stable topic ids, the element a finding is about as a component (and as a person
reads it: :func:`element_label`), and the IFC file a scene came from (:func:`ifc_file_of`)."""

from __future__ import annotations

import getpass
import math
import re
import uuid
from pathlib import Path

import numpy as np

from mrcheck.apps.bcf.model import BcfCamera, BcfComponent

NAMESPACE = uuid.UUID("6f1d3a52-5b7e-4c55-9d0e-2b8f1c4e7a10")  # mrcheck's topics (uuid5 names)
PRIORITIES = {1: "Low", 2: "Normal", 3: "High"}  # review severity 1..3
GLOBALID_CHARS = frozenset("0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$")
SEVERITIES = {v.lower(): k for k, v in PRIORITIES.items()} | {
    "critical": 3,
    "major": 3,
    "medium": 2,
    "minor": 1,
    "on hold": 1,
}


def priority(severity: int) -> str:
    """The BCF Priority of a severity 1..3 (Low / Normal / High)."""
    return PRIORITIES[min(max(int(severity), 1), 3)]


def severity_of(text: str) -> int | None:
    """A severity 1..3 from another tool's Priority text, None when unknown."""
    return SEVERITIES.get((text or "").strip().lower())


def topic_guid(*key) -> str:
    """A stable topic Guid from what identifies the finding (a run's output folder and instance
    id; the review's database and marker id for markers of a database without their own GUID,
    :meth:`mrcheck.apps.review.storage.Store.guids`): exported twice, a finding keeps its topic."""
    text = "\x1f".join(str(k) for k in key)
    # a path of undecodable bytes (surrogate escapes) must still give its own, stable id
    return str(uuid.uuid5(NAMESPACE, text.encode("utf-8", "surrogateescape").decode("latin-1")))


def bcf_camera(camera) -> BcfCamera:
    """A :class:`~mrcheck.core.camera.Camera`'s pose as a BCF perspective camera: the eye, the
    viewing direction (the optical axis, OpenCV +z) and up (OpenCV -y) in world coordinates;
    the vertical field of view from fy and the image height, the shot's own (not clamped)."""
    R = np.asarray(camera.R, np.float64)
    direction, up = R.T @ np.array([0.0, 0.0, 1.0]), R.T @ np.array([0.0, -1.0, 0.0])
    fov = math.degrees(2.0 * math.atan(camera.height / (2.0 * camera.fy)))
    return BcfCamera(tuple(map(float, camera.center)), tuple(map(float, direction)), tuple(map(float, up)), fov)


def ifc_global_id(part, k: int) -> str | None:
    """The instance's IFC GlobalId when it has one: an IFC import names its instances by their
    element's GlobalId and records the element's IFC class (:mod:`mrcheck.scene.elements`); a
    STEP import or a manifest names them otherwise."""
    instance_id = part.instance_ids[k]
    info = part.instance_info[k] if k < len(part.instance_info) else None
    if info is None or not info.ifc_class.lower().startswith("ifc"):
        return None
    return instance_id if len(instance_id) == 22 and set(instance_id) <= GLOBALID_CHARS else None


def element_component(scene, instance_id: str | None) -> list[BcfComponent]:
    """The component of an instance: with its IFC GlobalId only where the scene says it has one
    (:func:`ifc_global_id`); [] for no instance."""
    if not instance_id:
        return []
    found = scene.element(instance_id) if scene is not None else None
    guid = ifc_global_id(found[0], found[1]) if found else None
    return [BcfComponent(guid, instance_id)]


def default_author() -> str:
    """Who writes BCF topics and comments when no ``--author`` is given: the OS user."""
    try:
        return getpass.getuser()
    except (KeyError, OSError):  # no user name in the environment nor the password database
        return "mrcheck"


def element_label(scene, instance_id: str | None) -> str:
    """How a person reads an element: its name with its IFC class and storey, "Basic Wall:Interior
    138mm (IfcWallStandardCase, Level 1)", where an import knows its name; else its id (a
    manifest's instance names are readable already); "" for none. The GlobalId stays in the data."""
    if not instance_id:
        return ""
    found = scene.element(instance_id) if scene is not None else None
    return info_label(instance_id, found[2] if found else None)


def info_label(instance_id: str, info) -> str:
    """:func:`element_label` of an instance whose :class:`~mrcheck.scene.elements.ElementInfo`
    the caller has already (no search through the scene's parts: a caller labelling every
    element of a large model would search once per element)."""
    if info is None or not info.name:
        return instance_id
    where = ", ".join(v for v in (info.ifc_class, info.storey) if v)
    return f"{info.name} ({where})" if where else info.name


IFC_SUFFIXES = (".ifc", ".ifczip", ".ifcxml")
_IMPORTED_FROM = re.compile(r"^#\s*Imported by mrcheck scene import from (?P<name>.+?\.ifc(?:zip|xml)?) \(", re.I)


def ifc_file_of(scene) -> str:
    """The name of the IFC file a scene came from, "" when it did not: the model itself
    (``scene.source``, a scene loaded from its IFC file), or the file named on the first line
    of the manifest ``scene import`` wrote from one."""
    source = Path(getattr(scene, "source", "") or "")
    if source.suffix.lower() in IFC_SUFFIXES:
        return source.name
    if source.suffix.lower() != ".toml" or not source.is_file():
        return ""
    try:
        with source.open(encoding="utf-8", errors="replace") as f:
            first = f.readline(4096)
    except OSError:
        return ""
    found = _IMPORTED_FROM.match(first)
    return found["name"] if found else ""


__all__ = [
    "default_author",
    "element_label",
    "info_label",
    "ifc_file_of",
    "priority",
    "severity_of",
    "topic_guid",
    "bcf_camera",
    "element_component",
    "ifc_global_id",
    "PRIORITIES",
]
