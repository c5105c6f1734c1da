"""Scenes: a TOML manifest (or one mesh file) -> parts with float64 world transforms.

A part is one mesh drawn at one or more transforms (instances). World units are metres for
parts that declare ``units``; a part without ``units`` keeps its coordinates as authored, which
is what a CAD export with a forgotten unit looks like.

Precision for large extents: each mesh is re-centred on its own bounding-box centre in float64
before its vertices are stored as float32, and the offset goes into the part's float64 world
transform. The renderer multiplies view @ world in float64 and casts to float32 only then, so
float32 only ever holds coordinates relative to the camera (a hall 1e6 m from the origin
renders exactly like one at the origin). A mesh that float32 cannot hold around one centre (a
factory at map coordinates with a stray element at the origin in the same file) stays float64,
and the renderer draws it in pieces with centres of their own (:func:`mrcheck.scene.precision.float32_tiles`).

Manifest (format 1)::

    format = 1
    name = "sample_cell"

    [[parts]]
    name = "conveyor"
    mesh = "meshes/conveyor.glb"   # relative to the manifest; glb/gltf/obj/stl/ply/off/urdf
    units = "mm"                   # mm, cm, m, in, ft; omitted: coordinates as authored
    color = [0.3, 0.3, 0.35]       # optional linear RGB 0..1
    translate = [4.0, 2.0, 0.0]    # metres, after unit scaling
    rotate_deg = [0, 0, 90]        # XYZ Euler degrees about world axes
    scale = 1.0
    instances = [{ translate = [0, 3, 0] }, ...]   # optional, applied after the part transform
                                   # (so an instance's rotate_deg turns about the world origin);
                                   # an instance may carry id = "column-A3" (else NAME#i);
                                   # ids are unique in the whole manifest
    joints = { joint_a1 = 0.5 }    # URDF only, radians (or metres for prismatic joints),
                                   # finite and within the URDF's limits

    [[viewpoints]]
    name = "overview"
    eye = [x, y, z]
    target = [x, y, z]
    up = [0, 0, 1]
    fov_y_deg = 60
    width = 1024
    height = 768
"""

from __future__ import annotations

import contextlib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera, fit_size
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input, read_input_text
from mrcheck.core.progress import no_progress, shown_progress
from mrcheck.scene.elements import (
    ELEMENT_KEYS,
    ElementInfo,
    element_info,
    manifest_crs,
    manifest_origin,
    manifest_package_path,
    part_element_fields,
    read_instances_file,
    shifted,
    viewpoint_in_world,
)
from mrcheck.scene.importers.cache import cached_manifest
from mrcheck.scene.importers.records import ImportSettings
from mrcheck.scene.importers.sniff import IMPORT_SUFFIXES
from mrcheck.scene.meshes import JointError, read_mesh
from mrcheck.scene.part_tables import UNITS, part_color, part_joints, part_transforms, transform_from_table, unit_scale
from mrcheck.scene.precision import float32_or_float64

DEFAULT_COLOR = (0.7, 0.7, 0.7)  # linear RGB of parts without a colour


MANIFEST_KEYS = {"format", "name", "description", "origin", "crs", "package_path", "parts", "viewpoints"}
_PART_KEYS = {
    "name",
    "mesh",
    "units",
    "color",
    "translate",
    "rotate_deg",
    "scale",
    "matrix",
    "instances",
    "joints",
    "ifc_class",
    "storey",
    "instances_file",
}
_INSTANCE_KEYS = {"id", "translate", "rotate_deg", "scale", "matrix"} | set(ELEMENT_KEYS)
_VIEW_KEYS = {"name", "eye", "target", "up", "fov_y_deg", "width", "height"}


def default_instance_ids(name: str, count: int) -> list[str]:
    """The ids of a part's instances the manifest does not name: NAME for one, else NAME#i."""
    return [name] if count == 1 else [f"{name}#{i}" for i in range(count)]


@dataclass
class Part:
    """One mesh and the transforms it is drawn at.

    Attributes
    ----------
    vertices : (n, 3) float32, or float64
        Vertex positions relative to the mesh's own bounding-box centre, already in metres for
        a part with declared units. float64 only for a mesh that float32 would round (one with
        an element far from the rest, see :func:`mrcheck.scene.precision.float32_tiles`).
    faces : (m, 3) uint32
    transforms : (k, 4, 4) float64
        Local -> world, one per instance.
    instance_ids : list of str
        One per instance: the manifest's ``id``, else ``NAME`` for a single instance and
        ``NAME#i`` for instance i (what as-built discrepancy lists refer to).
    instance_info : list of ElementInfo
        One per instance: name, IFC class and storey of an imported element (empty otherwise).
    ifc_class, storey : str
        The part's, when all its instances share one (imported scenes), else "".
    """

    name: str
    source: Path
    vertices: np.ndarray
    faces: np.ndarray
    transforms: np.ndarray
    color: tuple = DEFAULT_COLOR
    units: str | None = None
    instance_ids: list = field(default_factory=list)
    instance_info: list = field(default_factory=list)
    ifc_class: str = ""
    storey: str = ""
    _bounds: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        if not self.instance_ids:
            self.instance_ids = default_instance_ids(self.name, len(self.transforms))
        if not self.instance_info:
            self.instance_info = [ElementInfo() for _ in self.instance_ids]

    @property
    def triangle_count(self) -> int:
        return int(len(self.faces))

    def local_bounds(self) -> np.ndarray:
        """(2, 3) float64 bounds of ``vertices`` (computed once: the vertices never change, and
        the renderer asks every frame; min/max are exact, no float64 copy of float32 needed)."""
        if self._bounds is None:
            self._bounds = np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)]).astype(np.float64)
        return self._bounds

    def instance_bounds(self) -> np.ndarray:
        """(k, 2, 3) float64 world-space axis-aligned bounds of every instance."""
        lo, hi = self.local_bounds()
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        world = np.einsum("kij,cj->kci", self.transforms, corners)[..., :3]
        return np.stack([world.min(axis=1), world.max(axis=1)], axis=1)


@dataclass
class Scene:
    """Parts in world coordinates (float64 transforms, metres).

    ``origin`` (3,) float64 is the world position of the manifest's frame (its ``origin`` key:
    placements and viewpoints are relative to it, world = origin + placement); a model at map
    coordinates has its map offset here, and ``crs`` names the map (``EPSG:25832``) when known.
    """

    name: str
    source: Path
    parts: list[Part]
    viewpoints: dict = field(default_factory=dict)
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    crs: str = ""

    def element(self, instance_id: str):
        """(part, instance index, ElementInfo) of an instance id, or None."""
        for part in self.parts:
            if instance_id in part.instance_ids:
                index = part.instance_ids.index(instance_id)
                return part, index, part.instance_info[index]
        return None

    @property
    def triangle_count(self) -> int:
        """Triangles as rendered (instances counted)."""
        return sum(p.triangle_count * len(p.transforms) for p in self.parts)

    def bounds(self) -> np.ndarray:
        """(2, 3) float64 world bounds of everything."""
        boxes = np.concatenate([p.instance_bounds() for p in self.parts])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])

    def camera(self, view: str, width: int | None = None, height: int | None = None) -> Camera:
        """The camera of a named viewpoint, at its own size unless one is given; given one side
        only, the other keeps the viewpoint's aspect ratio (as a resized camera file does)."""
        if view not in self.viewpoints:
            known = ", ".join(sorted(self.viewpoints)) or "none"
            raise MrcheckError(f"no viewpoint named {view!r} (the scene has: {known})", self.source)
        vp = self.viewpoints[view]
        try:
            width, height = fit_size(vp.get("width", 1024), vp.get("height", 768), width, height)
            return Camera.from_look_at(
                vp["eye"], vp["target"], vp.get("up", (0, 0, 1)), vp.get("fov_y_deg", 60.0), width, height
            )
        except (MrcheckError, TypeError, ValueError, ZeroDivisionError) as exc:  # TOML gives any type: width = "wide"
            raise MrcheckError(f"viewpoint {view!r}: {exc}", self.source) from None


def make_part(
    name,
    source,
    vertices,
    faces,
    transforms,
    color=None,
    units=None,
    instance_ids=None,
    instance_info=None,
    ifc_class: str = "",
    storey: str = "",
) -> Part:
    """A :class:`Part` from float64 geometry: re-centred, scaled to metres, stored as float32
    (float64 where float32 would not hold it, see :func:`_stored`)."""
    scale = unit_scale(units, source)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    centre = (lo + hi) / 2.0
    faces = np.asarray(faces)
    local = float32_or_float64((vertices - centre) * scale, faces)
    to_world = np.eye(4)
    to_world[:3, 3] = centre * scale
    transforms = np.asarray(transforms, np.float64).reshape(-1, 4, 4) @ to_world
    return Part(
        name=name,
        source=Path(source),
        vertices=local,
        faces=faces.astype(np.uint32),
        transforms=transforms,
        color=tuple(float(c) for c in (color if color is not None else DEFAULT_COLOR)),
        units=units,
        instance_ids=list(instance_ids or []),
        instance_info=list(instance_info or []),
        ifc_class=ifc_class,
        storey=storey,
    )


# -- loading ------------------------------------------------------------------------------------
def load_scene(
    path, units: str | None = None, progress: bool = False, import_settings: ImportSettings | None = None
) -> Scene:
    """A manifest (``.toml``), an IFC/STEP model (imported through the cache,
    :mod:`mrcheck.scene.importers.cache`, with ``import_settings``) or any single mesh file (then
    ``units`` says its unit); ``progress``: the loading shown through
    :func:`mrcheck.core.progress.shown_progress`."""
    path = Path(path)
    check_input(path, "scene file", folder_ok=True)
    if path.suffix.lower() in IMPORT_SUFFIXES and not path.is_dir():
        return _load_model(path, units, progress, import_settings)
    if path.is_dir():
        candidates = [path / "scene.toml", *sorted(path.glob("*.toml"))]
        manifest = next((c for c in candidates if c.exists()), None)
        if manifest is None:
            raise MrcheckError("folder has no scene manifest (scene.toml)", path)
        path = manifest
    if path.suffix.lower() == ".toml":
        if units is not None:
            raise MrcheckError("--units applies to a single mesh file; a manifest declares units per part", path)
        return _load_manifest(path, progress)
    vertices, faces = read_mesh(path)
    part = make_part(path.stem, path, vertices, faces, np.eye(4), units=units)
    return Scene(name=path.stem, source=path, parts=[part])


def _load_model(path: Path, units, progress: bool, settings: ImportSettings | None) -> Scene:
    """The scene of an IFC/STEP file through the import cache; its source is the model file."""
    if units is not None:
        raise MrcheckError("--units applies to a mesh file; an IFC or STEP file declares its own units", path)
    result = cached_manifest(path, settings, shown_progress() if progress else no_progress)
    scene = load_scene(result.manifest, progress=progress)
    scene.source = path
    return scene


def _load_manifest(path: Path, progress: bool) -> Scene:
    text = read_input_text(path, "manifest", encoding="utf-8-sig")  # -sig: a BOM (Windows Notepad) is no error
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MrcheckError(f"malformed manifest: {exc}", path) from None
    unknown = sorted(set(data) - MANIFEST_KEYS)
    if unknown:  # e.g. [[viewpoint]] for [[viewpoints]]: silently ignoring it would lose the views
        raise MrcheckError(
            f"unknown manifest key(s) {', '.join(unknown)} (known: {', '.join(sorted(MANIFEST_KEYS))})", path
        )
    if data.get("format", 1) != 1:
        raise MrcheckError(f"unsupported manifest format {data.get('format')!r} (this mrcheck reads format 1)", path)
    tables = data.get("parts", [])
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise MrcheckError("manifest 'parts' must be an array of tables ([[parts]])", path)
    if not tables:
        raise MrcheckError("scene is empty (no [[parts]])", path)

    origin, crs = manifest_origin(data, path), manifest_crs(data, path)
    folders = manifest_package_path(data, path)
    viewpoints = {}
    views = data.get("viewpoints", [])
    if not isinstance(views, list) or not all(isinstance(t, dict) for t in views):
        raise MrcheckError("manifest 'viewpoints' must be an array of tables ([[viewpoints]])", path)
    for table in views:
        name = table.get("name")
        unknown = sorted(set(table) - _VIEW_KEYS)
        if not isinstance(name, str) or not name or unknown or "eye" not in table or "target" not in table:
            raise MrcheckError(
                f"viewpoint {name!r} needs name, eye and target (unknown keys: {unknown or 'none'})", path
            )
        if name in viewpoints:
            raise MrcheckError(f"two viewpoints are named {name!r}", path)
        viewpoints[name] = viewpoint_in_world(table, origin, path)

    parts: list[Part] = []
    names: set[str] = set()
    owners: dict[str, str] = {}  # instance id -> part name
    show = shown_progress() if progress else no_progress
    # closing: a bar is taken down on an error too, so the error line starts a clean line
    with contextlib.closing(show(tables, "loading scene", "part")) as items:
        for index, table in enumerate(items):
            parts.append(_part_from_table(path, index, table, names, owners, origin, folders))

    scene = Scene(
        name=data.get("name", path.stem), source=path, parts=parts, viewpoints=viewpoints, origin=origin, crs=crs
    )
    for view in viewpoints:
        scene.camera(view)  # validate every viewpoint once, at load time
    return scene


def _part_from_table(
    path: Path, index: int, table: dict, names: set, owners: dict, origin=None, package_folders=()
) -> Part:
    """The part of one [[parts]] table of the manifest ``path``; ``names`` collects part names,
    ``owners`` maps every instance id so far to its part's name; placements are relative to
    ``origin`` (float64, the manifest's); URDF ``package://`` meshes are also looked up in
    ``package_folders``."""
    where = f"part {table.get('name', index)!r}"
    unknown = sorted(set(table) - _PART_KEYS)
    if unknown:
        raise MrcheckError(f"{where}: unknown key(s) {', '.join(unknown)}", path)
    name = table.get("name", f"part{index}")
    if not isinstance(name, str):
        raise MrcheckError(f"{where}: name must be a string", path)
    if name in names:
        raise MrcheckError(f"two parts are named {name!r}", path)
    names.add(name)
    if not isinstance(table.get("mesh"), str):
        raise MrcheckError(f'{where}: needs a mesh = "file" entry', path)
    try:
        unit_scale(table.get("units"), None)
    except MrcheckError as exc:
        raise MrcheckError(f"{where}: {exc}", path) from None
    instances = (
        read_instances_file(path, table, where) if "instances_file" in table else table.get("instances", [{}])
    )  # no key: one copy at the part's own transform
    if not isinstance(instances, list) or not all(isinstance(t, dict) for t in instances):
        raise MrcheckError(f"{where}: instances must be an array of tables", path)
    if not instances:  # it drew one copy before, silently; a planner who empties it means none
        raise MrcheckError(
            f"{where}: instances is empty (no copy placed); remove the part, or leave out "
            "'instances' for one copy at the part's transform",
            path,
        )
    for i, t in enumerate(instances):
        unknown = sorted(set(t) - _INSTANCE_KEYS)
        if unknown:
            raise MrcheckError(f"{where} instance {i}: unknown key(s) {', '.join(unknown)}", path)
    transforms = shifted(part_transforms(table, instances, where, path), origin if origin is not None else np.zeros(3))
    color = part_color(table, where, path)
    joints = part_joints(table, where, path)
    ids = _instance_ids(name, instances, owners, path)
    try:
        vertices, faces = read_mesh(path.parent / table["mesh"], joints, package_folders)
    except JointError as exc:  # the manifest's value is wrong: name the manifest and the part
        raise MrcheckError(f"{where}: {exc}", path) from None
    except MrcheckError as exc:  # the mesh is named; say which manifest entry asked for it
        error = MrcheckError(f"{exc} ({where} of {path})")
        error.path = exc.path
        raise error from None
    return make_part(
        name,
        path.parent / table["mesh"],
        vertices,
        faces,
        transforms,
        color,
        table.get("units"),
        ids,
        element_info(instances, where, path),
        *part_element_fields(table, where, path),
    )


def _instance_ids(name: str, instances: list, owners: dict, path: Path) -> list[str]:
    """The ids of the part ``name``'s instances; ``owners`` (id -> part name) collects them.

    The ids Part gives (NAME, NAME#i), unless the manifest names them; an id names one object
    in the whole scene (as-built variants and reports look changes up by it), so a generated
    id that another part's explicit one repeats is as wrong as two explicit ones."""
    ids = [
        (str(t["id"]) if "id" in t else "") or default
        for t, default in zip(instances, default_instance_ids(name, len(instances)))
    ]
    for iid in ids:
        if iid in owners:
            other = owners[iid]
            raise MrcheckError(
                f"instance id {iid!r} is used twice in part {name!r}"
                if other == name
                else f"instance id {iid!r} is used by parts {other!r} and {name!r}",
                path,
            )
        owners[iid] = name
    return ids


__all__ = ["ElementInfo", "Part", "Scene", "UNITS", "load_scene", "make_part", "transform_from_table", "unit_scale"]
