"""Type-instanced IFC elements without IfcOpenShell's per-element meshing.

IfcOpenShell's iterator meshes every element, also one that only maps its type's shape
(an IfcMappedItem of an IfcRepresentationMap): the time grows with the triangles *drawn*, some
13 ms per 5,000-triangle element here, 100 s for the 5 M-triangle hall of 8,000 elements that
share 50 shapes. Here each IfcRepresentationMap is meshed once (``ifcopenshell.geom.create_shape``
on its representation) and each element that maps it gets only a matrix: its placement @ the
mapped item's transformation (target @ origin, :func:`ifcopenshell.util.placement.get_mappeditem_transformation`).

Only elements whose Body is exactly one IfcMappedItem and that have no openings take this path
(openings cut each element differently); everything else, and any map that fails to build here,
goes through the iterator.

cgal-simple, the fast kernel, does no Boolean operations and says nothing about it: a wall's
openings make it an empty shape, a clipped item is left out of a shape that has others (a
table without its clipped shelf). :class:`Booleans` tells which shapes need them; those are
built with OpenCascade only.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np


def single_mapped_item(element):
    """The one IfcMappedItem that is the element's whole Body (3-D) representation, else None."""
    if getattr(element, "HasOpenings", None):
        return None
    shape = element.Representation
    bodies = [r for r in (shape.Representations or ()) if (r.RepresentationIdentifier or "Body") == "Body"]
    if len(bodies) != 1 or len(bodies[0].Items or ()) != 1:
        return None
    item = bodies[0].Items[0]
    if not item.is_a("IfcMappedItem") or not item.MappingTarget.is_a("IfcCartesianTransformationOperator3D"):
        return None
    return item


def split_mapped(bodies) -> tuple[dict, list]:
    """({IfcRepresentationMap id: [(element, mapped item), ...]}, the other elements)."""
    groups: dict[int, list] = {}
    rest = []
    for element in bodies:
        item = single_mapped_item(element)
        if item is None:
            rest.append(element)
        else:
            groups.setdefault(item.MappingSource.id(), []).append((element, item))
    return groups, rest


class Booleans:
    """Whether an element's or a representation's shape needs Boolean operations: an opening,
    an IfcBooleanResult (IfcBooleanClippingResult: Revit's roofs and clipped walls), also
    inside the representation an IfcMappedItem maps. Memoised per representation."""

    def __init__(self):
        self._memo: dict = {}

    def element(self, element) -> bool:
        if getattr(element, "HasOpenings", None):
            return True
        shape = element.Representation
        return any(
            self.representation(r)
            for r in (shape.Representations or () if shape is not None else ())
            if (r.RepresentationIdentifier or "Body") == "Body"
        )

    def representation(self, representation) -> bool:
        key = representation.id()
        if key not in self._memo:
            self._memo[key] = any(self._item(item) for item in representation.Items or ())
        return self._memo[key]

    def _item(self, item) -> bool:
        if item.is_a("IfcMappedItem"):
            return self.representation(item.MappingSource.MappedRepresentation)
        return item.is_a("IfcBooleanResult")


@dataclass
class MapMesh:
    """The triangles of one IfcRepresentationMap in its own coordinates, metres."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64
    color: tuple | None  # linear RGB of its style, None when it has none


def mesh_maps(model, settings, groups: dict, kernels, threads: int, unit_m: float) -> dict:
    """{map id: MapMesh} of every map that builds; maps that fail are left out (their elements
    go to the iterator). A map of IfcTriangulatedFaceSets is read as it is written (its indices
    are the triangles: nothing to mesh); any other through ``create_shape`` (cgal-simple first,
    then OpenCascade; OpenCascade alone for one with Booleans)."""
    import ifcopenshell.geom

    booleans = Booleans()

    def build(map_id):
        representation = model.by_id(map_id).MappedRepresentation
        direct = triangulated(representation, unit_m)
        if direct is not None:
            return map_id, direct
        for kernel in kernels[-1:] if booleans.representation(representation) else kernels:
            # with these settings a triangulation; IfcOpenShell types it as every kind of result
            shape: Any
            try:
                shape = ifcopenshell.geom.create_shape(settings, representation, geometry_library=kernel)
            except Exception:  # noqa: BLE001 -- IfcOpenShell raises RuntimeError and others: try the next kernel
                continue
            if shape is not None and len(shape.faces):
                return map_id, MapMesh(*shape_arrays(shape), shape_colour(shape))
        return map_id, None

    with ThreadPoolExecutor(max_workers=max(1, threads)) as pool:
        return {map_id: mesh for map_id, mesh in pool.map(build, sorted(groups)) if mesh is not None}


def triangulated(representation, unit_m: float) -> MapMesh | None:
    """The MapMesh of a representation whose items are all IfcTriangulatedFaceSets (the
    common export of furniture, equipment and MEP), else None. ``PnIndex`` (IFC4 ADD2) is
    honoured; a closed flag or normals change nothing the renderer uses."""
    items = list(representation.Items or ())
    if not items or not all(item.is_a("IfcTriangulatedFaceSet") for item in items):
        return None
    vertices, faces, offset, colour = [], [], 0, None
    for item in items:
        points = np.asarray(item.Coordinates.CoordList, np.float64) * unit_m
        index = np.asarray(item.CoordIndex, np.int64) - 1
        pn = getattr(item, "PnIndex", None)
        if pn:
            index = np.asarray(pn, np.int64)[index] - 1
        if index.ndim != 2 or index.shape[1] != 3 or index.min() < 0 or index.max() >= len(points):
            return None  # malformed: IfcOpenShell decides what to make of it
        vertices.append(points)
        faces.append(index + offset)
        offset += len(points)
        colour = colour or item_colour(item)
    return MapMesh(np.concatenate(vertices), np.concatenate(faces), colour)


def item_colour(item) -> tuple | None:
    """The surface colour of an IfcStyledItem on a representation item (IFC4 styles)."""
    for styled in getattr(item, "StyledByItem", None) or ():
        for style in styled.Styles or ():
            assignments = style.Styles if style.is_a("IfcPresentationStyleAssignment") else [style]
            for surface in assignments:
                for element in getattr(surface, "Styles", None) or ():
                    colour = getattr(element, "SurfaceColour", None)
                    if colour is not None:
                        return (float(colour.Red), float(colour.Green), float(colour.Blue))
    return None


def shape_arrays(geometry) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (n, 3) float64, faces (m, 3) int64) of an IfcOpenShell triangulation."""
    vertices = np.asarray(geometry.verts, np.float64).reshape(-1, 3)
    faces = np.asarray(geometry.faces, np.int64).reshape(-1, 3)
    return vertices, faces


def shape_colour(geometry) -> tuple | None:
    """The diffuse colour of the style that covers most triangles (the scene model has one
    colour per part), None when IfcOpenShell gives none."""
    materials = list(geometry.materials)
    if not materials:
        return None
    ids = np.asarray(geometry.material_ids, np.int64)
    index = int(np.bincount(ids[ids >= 0], minlength=len(materials)).argmax()) if (ids >= 0).any() else 0
    diffuse = materials[index].diffuse
    rgb = [float(c) for c in (diffuse.components if hasattr(diffuse, "components") else diffuse)][:3]
    if len(rgb) != 3 or not all(np.isfinite(rgb)):
        return None
    return tuple(min(max(c, 0.0), 1.0) for c in rgb)


class Placements:
    """Element placements as (4, 4) float64 matrices in metres, each IfcLocalPlacement and mapped
    item transformation computed once (a storey's placement is shared by thousands of elements)."""

    def __init__(self, unit_m: float):
        self.unit_m = unit_m
        self._local: dict = {}
        self._mapped: dict = {}

    def local(self, placement) -> np.ndarray:
        """Project units, as IfcOpenShell's get_local_placement, memoised along the chain."""
        import ifcopenshell.util.placement

        if placement is None:
            return np.eye(4)
        key = placement.id()
        if key not in self._local:
            if placement.is_a("IfcLocalPlacement"):
                own = axis2placement(placement.RelativePlacement)
                self._local[key] = self.local(placement.PlacementRelTo) @ own
            else:  # grid placements and the like: IfcOpenShell's own resolution
                self._local[key] = np.asarray(ifcopenshell.util.placement.get_local_placement(placement), np.float64)
        return self._local[key]

    def element(self, element, item) -> np.ndarray:
        """The element's placement @ its mapped item's transformation, translation in metres."""
        import ifcopenshell.util.placement

        # thousands of mapped items share one map and an identity operator (each of its own, as
        # exporters write them): computed once per map and operator value
        key = (item.MappingSource.id(), operator_key(item.MappingTarget))
        if key not in self._mapped:
            self._mapped[key] = np.asarray(ifcopenshell.util.placement.get_mappeditem_transformation(item), np.float64)
        matrix = self.local(element.ObjectPlacement) @ self._mapped[key]
        matrix[:3, 3] *= self.unit_m  # placements are in the project's length unit, the mesh in metres
        return matrix


def operator_key(operator) -> tuple:
    """The values of an IfcCartesianTransformationOperator3D(nonUniform), hashable."""

    def ratios(direction):
        return tuple(direction.DirectionRatios) if direction is not None else None

    return (
        operator.is_a(),
        ratios(operator.Axis1),
        ratios(operator.Axis2),
        ratios(operator.Axis3),
        tuple(operator.LocalOrigin.Coordinates),
        operator.Scale,
        getattr(operator, "Scale2", None),
        getattr(operator, "Scale3", None),
    )


def axis2placement(placement) -> np.ndarray:
    """(4, 4) float64 of an IfcAxis2Placement3D (project units), in plain float arithmetic:
    IfcOpenShell's helper spends ~0.5 ms per placement in small numpy calls, the hall has
    8,000. Axis and RefDirection as IFC defines them: z = Axis, x = RefDirection made
    orthogonal to z, y = z x x; defaults z = (0, 0, 1), x = (1, 0, 0). A 2-D placement goes to
    IfcOpenShell's helper."""
    import ifcopenshell.util.placement

    if not placement.is_a("IfcAxis2Placement3D"):
        return np.asarray(ifcopenshell.util.placement.get_axis2placement(placement), np.float64)
    location = [float(v) for v in placement.Location.Coordinates]
    z = _unit(placement.Axis.DirectionRatios if placement.Axis is not None else (0.0, 0.0, 1.0))
    x = placement.RefDirection.DirectionRatios if placement.RefDirection is not None else (1.0, 0.0, 0.0)
    if abs(_dot(_unit(x), z)) > 1.0 - 1e-12:  # parallel to z: IFC's default choice of x
        x = (1.0, 0.0, 0.0) if abs(z[0]) < 0.9 else (0.0, 1.0, 0.0)
    dot = _dot(x, z)
    x = _unit([x[i] - dot * z[i] for i in range(3)])
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2], matrix[:3, 3] = x, y, z, location
    return matrix


def _dot(a, b) -> float:
    return float(a[0] * b[0] + a[1] * b[1] + a[2] * b[2])


def _unit(v):
    v = [float(c) for c in v]
    n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) ** 0.5
    return [c / n for c in v]


__all__ = [
    "Booleans",
    "single_mapped_item",
    "split_mapped",
    "mesh_maps",
    "triangulated",
    "item_colour",
    "shape_arrays",
    "shape_colour",
    "Placements",
    "MapMesh",
    "axis2placement",
    "operator_key",
]
