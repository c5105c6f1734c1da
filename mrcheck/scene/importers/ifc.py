"""IFC models (IFC2X3, IFC4, IFC4X3) through IfcOpenShell's geometry iterator.

One part per distinct shape representation: IfcOpenShell builds each representation once and
gives every element that maps it (an IfcMappedItem of a type's IfcRepresentationMap, or the
same representation reused) the same geometry id, so repeated elements become instances of one
part. Every instance's id is its element's GlobalId; part and instance keep the element's name,
IFC class and storey. Coordinates come in metres whatever the file's unit assignment (the
iterator converts them). An element whose geometry fails or builds empty is listed (class, name,
GlobalId and why) and the rest imports.

The iterator runs on ``threads`` cores (C++ threads: the Python loop only collects results).
"""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.native_names import utf8_name
from mrcheck.core.progress import Progress, no_progress
from mrcheck.core.quiet import native_output
from mrcheck.scene.importers.georef import map_conversion, site_origin
from mrcheck.scene.importers.ifc_mapped import (
    Booleans,
    Placements,
    mesh_maps,
    shape_arrays,
    shape_colour,
    split_mapped,
)
from mrcheck.scene.importers.ifc_units import LENGTH_UNITS, declared_unit, rescale, unit_note
from mrcheck.scene.importers.ifc_views import file_viewpoints
from mrcheck.scene.importers.records import (
    FailedElement,
    ImportedInstance,
    ImportedModel,
    ImportedPart,
    ImportSettings,
    unique_part_names,
)
from mrcheck.scene.importers.sniff import FileKind

# IfcSpace and IfcOpeningElement have Body geometry that is not built: rooms' air and the voids
# already cut from their walls
SKIPPED_CLASSES = ("IfcSpace", "IfcOpeningElement", "IfcVirtualElement")
DEFAULT_COLOR = (0.7, 0.7, 0.7)


def default_threads() -> int:
    import os

    return max(1, len(os.sched_getaffinity(0)))


def read_ifc(path: Path, kind: FileKind, settings: ImportSettings, progress: Progress = no_progress) -> ImportedModel:
    """The model of an IFC file (already checked by :func:`mrcheck.scene.importers.sniff.sniff`).

    ``progress`` (:data:`mrcheck.core.progress.Progress`) shows the shapes as they are built. Raises MrcheckError for
    a file
    IfcOpenShell cannot parse, a model without any element with a Body representation, and one
    where no element's geometry could be built.
    """
    model = _open(path)
    bodies = _body_elements(model)
    if not bodies:
        products = len(model.by_type("IfcProduct"))
        raise MrcheckError(
            f"no element has a body representation ({products} IfcProduct entities, none with "
            "3-D 'Body' geometry): nothing to render",
            path,
        )
    _check_units(model, path)
    placement = _placement(model, settings, path)
    storeys = storey_names(model)
    try:
        parts, seen, empty = _iterate(model, settings, bodies, storeys, placement.matrix, (progress, path.name))
    except RuntimeError as exc:  # IfcOpenShell's iterator on a file that breaks the schema
        raise MrcheckError(f"IfcOpenShell cannot build the model ({' '.join(str(exc).split())[:160]})", path) from None
    failed = [_failed(e, e.id() in empty) for e in bodies if e.id() not in seen]
    if not parts:
        raise MrcheckError(
            f"no element's geometry could be built ({len(failed)} of them failed, e.g. "
            f"{failed[0].ifc_class} {failed[0].id})",
            path,
        )
    scale = _length_unit(model, parts, placement, settings, path)
    views, view_notes = file_viewpoints(model, placement.matrix, scale)
    project = (model.by_type("IfcProject") or [None])[0]
    name = (getattr(project, "Name", None) or path.stem) if project is not None else path.stem
    return ImportedModel(
        name=str(name),
        source=path,
        kind="ifc",
        schema=kind.schema,
        parts=_named(parts),
        origin=placement.origin,
        crs=placement.crs,
        failed=failed,
        notes=placement.notes + view_notes,
        viewpoints=views,
    )


def _check_units(model, path: Path) -> None:
    """IFC2X3 requires the project's UnitsInContext (IfcOpenShell's iterator stops without it);
    IFC4 makes it optional (then metres)."""
    project = (model.by_type("IfcProject") or [None])[0]
    if model.schema == "IFC2X3" and project is not None and project.UnitsInContext is None:
        raise MrcheckError(
            "the IfcProject has no UnitsInContext, which IFC2X3 requires: export the file again with its units", path
        )


def _length_unit(model, parts, placement, settings: ImportSettings, path: Path) -> float:
    """Rescale to ``settings.units`` when given (a file whose numbers are not in its declared
    unit), and the factor; a note when element sizes are implausible for the unit read in."""
    factor = 1.0
    if settings.units:
        if settings.units not in LENGTH_UNITS:
            raise MrcheckError(f"unknown --units {settings.units!r} (use one of {', '.join(LENGTH_UNITS)})", path)
        declared = declared_unit(model)
        factor = LENGTH_UNITS[settings.units] / (declared[1] if declared else 1.0)
        rescale(parts, None if placement.on_map else placement.origin, factor)
    note = unit_note(model, parts, settings.units)
    placement.notes += [note] if note else []
    return factor


def _failed(element, empty: bool) -> FailedElement:
    reason = (
        "its shape is empty (openings or clippings remove all of it)" if empty else "IfcOpenShell built no geometry"
    )
    return FailedElement(str(element.GlobalId), element.is_a(), reason, name=str(element.Name or ""))


def _open(path: Path):
    """The parsed file; any error the parser logs (it skips what it cannot read and carries on)
    is a syntax error: an element silently missing from the model would be a wrong check."""
    import ifcopenshell

    ifcopenshell.get_log()  # reading the log empties it: what follows is this file's
    try:
        with native_output(), utf8_name(path) as name:
            model = ifcopenshell.open(name)
    except Exception as exc:  # ifcopenshell raises its own, RuntimeError and others for a broken file
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise MrcheckError(f"cannot parse IFC ({reason})", path) from None
    errors = [line for line in ifcopenshell.get_log().splitlines() if line.startswith("[error]")]
    if errors:
        raise MrcheckError(f"cannot parse IFC: {parse_error(errors, path)}", path)
    return model


_OFFSET = re.compile(r" at offset (\d+)$")
_LOG_PREFIX = re.compile(r"^\[error\] (\[[A-Z]+\d+\] )?\[[^]]+\] ")


def parse_error(errors: list[str], path: Path) -> str:
    """The first of IfcOpenShell's parse errors as "line N: what" (its offsets are bytes)."""
    with_offset = [e for e in errors if _OFFSET.search(e)] or errors
    first = with_offset[0]
    match = _OFFSET.search(first)
    text = _LOG_PREFIX.sub("", _OFFSET.sub("", first)).strip()[:160]
    where = ""
    if match:
        with open(path, "rb") as handle:
            line = handle.read(int(match.group(1))).count(b"\n") + 1
        where = f"line {line}: "
    more = f" ({len(errors)} errors in all)" if len(errors) > 1 else ""
    return f"{where}{text}{more}"


def _body_elements(model) -> list:
    """The products with a 3-D Body representation (what the iterator builds), skipped classes aside."""
    found = []
    for product in model.by_type("IfcProduct"):
        if product.is_a() in SKIPPED_CLASSES or any(product.is_a(c) for c in SKIPPED_CLASSES):
            continue
        shape = getattr(product, "Representation", None)
        if shape is None:
            continue
        if any((r.RepresentationIdentifier or "Body") == "Body" and _is_3d(r) for r in shape.Representations or ()):
            found.append(product)
    return found


def _is_3d(representation) -> bool:
    context = representation.ContextOfItems
    while context is not None and context.is_a("IfcGeometricRepresentationSubContext"):
        context = context.ParentContext
    return context is None or getattr(context, "ContextType", "Model") in (None, "Model", "Design")


def storey_names(model) -> dict:
    """{element step id: storey name} through IfcRelContainedInSpatialStructure, for elements
    contained in a storey directly or through the element they are aggregated into."""
    container = {}
    for rel in model.by_type("IfcRelContainedInSpatialStructure"):
        structure = rel.RelatingStructure
        if structure is not None and structure.is_a("IfcBuildingStorey"):
            for element in rel.RelatedElements or ():
                container[element.id()] = structure.Name or structure.LongName or f"#{structure.id()}"
    for rel in model.by_type("IfcRelAggregates"):
        whole = rel.RelatingObject
        if whole is not None and whole.id() in container:
            for piece in rel.RelatedObjects or ():
                container.setdefault(piece.id(), container[whole.id()])
    return container


def _placement(model, settings: ImportSettings, path: Path):
    """World frame of the import: the file's own coordinates, or its map coordinates."""
    if settings.coordinates != "map":
        return _own_placement(model, path)
    conversion = map_conversion(model, path)
    if conversion is not None:
        return conversion
    placement = site_origin(model)
    placement.notes.append("no IfcMapConversion in the file: its site placement is taken as the map position")
    return placement


def _own_placement(model, path: Path):
    """The file's own coordinates; a note when it has a map conversion (an unusable one too)."""
    placement = site_origin(model)
    try:
        conversion = map_conversion(model, path)
    except MrcheckError as exc:
        placement.notes.append(f"{exc.problem}; --coordinates map refuses it")
        return placement
    if conversion is not None:
        placement.crs = ""
        placement.notes.append(
            f"the file has a map conversion (to {conversion.crs or 'a map CRS'}); "
            "--coordinates map places the model there"
        )
    return placement


def _geometry_settings(settings: ImportSettings):
    import ifcopenshell.geom

    geom = ifcopenshell.geom.settings()
    geom.set("use-world-coords", False)  # local coordinates: shared representations stay shared
    geom.set("weld-vertices", False)  # faster; the renderer needs no shared vertices
    geom.set("no-normals", True)  # the renderer computes its own
    geom.set("mesher-linear-deflection", max(settings.deflection_m(), 1e-4))
    return geom


# cgal-simple builds tessellated and extruded shapes some 8x faster than OpenCascade but no
# Booleans (openings, clippings; the CSG bath): elements that need them, and those it leaves
# out or builds empty, get a pass with OpenCascade
KERNELS = ("cgal-simple", "opencascade")


def _iterate(model, settings, bodies, storeys, world, show):
    """{geometry id: ImportedPart} of every built element, the step ids built and those built
    empty: elements that only map a type's shape through :mod:`.ifc_mapped` (each shape meshed
    once), the rest through IfcOpenShell's iterator (cgal-simple, then OpenCascade for what that
    left out or built empty, and for every element whose shape needs Booleans)."""
    import ifcopenshell.util.unit

    parts: dict[str, ImportedPart] = {}  # by geometry id, "map<id>" for a representation map
    seen: set[int] = set()
    empty: set[int] = set()
    progress, name = show
    desc = f"importing {name}"
    groups, todo = split_mapped(bodies)
    threads = settings.threads or default_threads()
    unit_m = float(ifcopenshell.util.unit.calculate_unit_scale(model))
    meshes = mesh_maps(model, _geometry_settings(settings), groups, KERNELS, threads, unit_m)
    placements = Placements(unit_m)
    with contextlib.closing(progress(list(groups.items()), desc, "shape")) as items:
        for map_id, members in items:
            _add_mapped(parts, seen, meshes.get(map_id), members, todo, (world, placements, storeys))
    booleans = Booleans()
    for kernel in KERNELS:
        todo = [e for e in todo if e.id() not in seen]
        batch = todo if kernel == KERNELS[-1] else [e for e in todo if not booleans.element(e)]
        if batch:
            with contextlib.closing(progress(_run_iterator(model, settings, kernel, batch), desc, "element")) as shapes:
                for shape in shapes:
                    _add_shape(model, parts, (seen, empty), shape, (world, storeys))
    return list(parts.values()), seen, empty - seen


def _add_mapped(parts, seen, mesh, members, todo, frame) -> None:
    """The instances of one representation map (``members``: (element, mapped item)), or, when
    its mesh did not build, its elements onto ``todo`` (for the iterator)."""
    world, placements, storeys = frame
    if mesh is None:
        todo += [element for element, _ in members]
        return
    map_id = members[0][1].MappingSource.id()
    part = parts[f"map{map_id}"] = ImportedPart(
        name=_part_name(members[0][0]), vertices=mesh.vertices, faces=mesh.faces, color=mesh.color or DEFAULT_COLOR
    )
    for element, item in members:
        part.instances.append(_instance(element, world @ placements.element(element, item), storeys))
        seen.add(element.id())


def _add_shape(model, parts, done, shape, frame) -> None:
    """One element the iterator built: an instance of the part of its geometry id; an empty
    shape is noted in ``done``'s second set (a later kernel may build it)."""
    import ifcopenshell.util.shape

    seen, empty = done
    world, storeys = frame
    geometry = shape.geometry
    if not len(geometry.faces):
        empty.add(shape.id)
        return
    element = model.by_id(shape.id)
    seen.add(shape.id)
    part = parts.get(geometry.id)
    if part is None:
        part = parts[geometry.id] = _part(geometry, element)
    matrix = world @ np.asarray(ifcopenshell.util.shape.get_shape_matrix(shape), np.float64)
    part.instances.append(_instance(element, matrix, storeys))


def _instance(element, matrix, storeys) -> ImportedInstance:
    return ImportedInstance(
        id=str(element.GlobalId),
        matrix=matrix,
        name=str(element.Name or ""),
        ifc_class=element.is_a(),
        storey=storeys.get(element.id(), ""),
    )


def _run_iterator(model, settings, kernel, include):
    """The shapes of one pass of IfcOpenShell's iterator with ``kernel`` over the elements
    ``include``, as they come."""
    import ifcopenshell.geom

    threads = settings.threads or default_threads()
    # IfcOpenShell logs failures to its own log (not stderr): the caller lists what was not built
    iterator = ifcopenshell.geom.iterator(
        _geometry_settings(settings), model, threads, geometry_library=kernel, include=include
    )
    if iterator.initialize():
        while True:
            yield iterator.get()
            if not iterator.next():  # the next element, or None when none is left
                break


def _part(geometry, element) -> ImportedPart:
    vertices, faces = shape_arrays(geometry)
    return ImportedPart(
        name=_part_name(element), vertices=vertices, faces=faces, color=shape_colour(geometry) or DEFAULT_COLOR
    )


def _part_name(element) -> str:
    """The type's name for a typed element (its shape is the type's), else the element's name,
    else its class."""
    import ifcopenshell.util.element

    kind = ifcopenshell.util.element.get_type(element)
    return str((kind.Name if kind is not None else None) or element.Name or element.is_a())


def _named(parts: list[ImportedPart]) -> list[ImportedPart]:
    """Unique, file-safe part names; each part's class and storey are its instances' when they
    all share one."""
    unique_part_names(parts)
    for part in parts:
        classes = {i.ifc_class for i in part.instances}
        storeys = {i.storey for i in part.instances}
        part.ifc_class = classes.pop() if len(classes) == 1 else ""
        part.storey = storeys.pop() if len(storeys) == 1 else ""
    return parts


__all__ = ["read_ifc", "storey_names", "default_threads", "parse_error", "SKIPPED_CLASSES", "KERNELS"]
