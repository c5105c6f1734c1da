"""STEP parts and assemblies (AP203, AP214, AP242) through OpenCascade's XCAF reader (cadquery-ocp).

The reader's document holds the assembly tree: a *prototype* label per distinct shape, and
component labels that place a prototype (or a sub-assembly) with a location. Every prototype
becomes one part, tessellated once; every path from a top-level shape down to a prototype
becomes one instance whose id is that assembly path (``"gearbox/shaft_1/bearing_2"``), so a
bolt used 40 times is one part with 40 instances. Names and colours come from the document
(a colour on the occurrence, the prototype, or, failing both, on the faces: the colour covering
most faces wins, as the scene has one colour per part). Lengths land in metres whatever the
file's unit (the document's length unit is read back and applied).

Tessellation: OpenCascade's BRepMesh with a chord error of ``ImportSettings.deflection_m()`` (the
tolerance stated in pixels at a distance) and a 0.5 rad angular limit, on every core.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.native_names import utf8_name
from mrcheck.core.progress import Progress, no_progress
from mrcheck.core.quiet import native_output
from mrcheck.scene.importers.records import (
    FailedElement,
    ImportedInstance,
    ImportedModel,
    ImportedPart,
    ImportSettings,
    unique_part_names,
)
from mrcheck.scene.importers.sniff import FileKind

DEFAULT_COLOR = (0.7, 0.7, 0.7)
ANGULAR_DEFLECTION = 0.5  # rad: curved faces get at least one segment per ~29 degrees


@dataclass
class _Prototype:
    name: str
    shape: object
    color: tuple | None
    instances: list = field(default_factory=list)  # (path, matrix, color)


def read_step(path: Path, kind: FileKind, settings: ImportSettings, progress: Progress = no_progress) -> ImportedModel:
    """The model of a STEP file (checked by :func:`mrcheck.scene.importers.sniff.sniff` first).

    Raises MrcheckError for a file the reader refuses, one without any shape, and one where no
    shape tessellates. Prototypes that give no triangles are listed as failed.
    """
    doc, unit_m = _read_document(path)
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    shapes = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    colours = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    prototypes = _collect(shapes, colours, unit_m)
    if not prototypes:
        raise MrcheckError(f"{kind.label} file holds no shape", path)
    parts: list[ImportedPart] = []
    failed: list[FailedElement] = []
    skipped = 0
    with contextlib.closing(progress(list(prototypes.values()), f"importing {path.name}", "shape")) as items:
        for proto in items:
            skipped += _add_prototype(proto, settings.deflection_m() / unit_m, colours, unit_m, parts, failed)
    if not parts:
        raise MrcheckError(
            f"no shape of the {kind.label} file tessellates ({len(failed)} failed to mesh, {skipped} "
            "have no faces left: broken or missing surfaces?)",
            path,
        )
    unique_part_names(parts)
    notes = [f"{skipped} shape(s) without faces (wireframe or points) left out"] if skipped else []
    return ImportedModel(
        name=path.stem, source=path, kind="step", schema=kind.schema, parts=parts, failed=failed, notes=notes
    )


def _add_prototype(proto, deflection: float, colours, unit_m: float, parts: list, failed: list) -> int:
    """Tessellate one prototype onto ``parts`` (or its instances onto ``failed``); returns the
    instances left out for having no faces at all (a wireframe or point set: AP203's bounded
    wireframe), which are no failure."""
    vertices, faces, face_colour = _tessellate(proto.shape, deflection, colours)
    if not len(faces):
        if _has_faces(proto.shape):
            failed += [FailedElement(p, "STEP shape", "does not tessellate") for p, _, _ in proto.instances]
            return 0
        return len(proto.instances)
    instances = [ImportedInstance(id=p, matrix=m, name=p.rsplit("/", 1)[-1]) for p, m, _ in proto.instances]
    parts.append(
        ImportedPart(
            name=proto.name,
            vertices=vertices * unit_m,
            faces=faces,
            color=proto.color or face_colour or DEFAULT_COLOR,
            instances=instances,
        )
    )
    return 0


def _has_faces(shape) -> bool:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    return TopExp_Explorer(shape, TopAbs_FACE).More()


def _read_document(path: Path):
    """(XCAF document, metres per document length unit)."""
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.UnitsMethods import UnitsMethods_LengthUnit
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = TDocStd_Document(TCollection_ExtendedString("MDTV-XCAF"))
    reader = STEPCAFControl_Reader()
    reader.SetColorMode(True)
    reader.SetNameMode(True)
    reader.SetLayerMode(False)
    with native_output(fds=(1, 2)) as printed:  # the reader prints its statistics and complaints
        with utf8_name(path) as name:
            status = reader.ReadFile(name)
        ok = status == IFSelect_ReturnStatus.IFSelect_RetDone and reader.Transfer(doc)
    if not ok:
        reason = "; ".join(printed[:2]) or str(status).rsplit("_", 1)[-1]
        raise MrcheckError(f"cannot read STEP ({reason[:200]})", path)
    unit = [0.0]
    try:
        found = XCAFDoc_DocumentTool.GetLengthUnit_s(doc, unit, UnitsMethods_LengthUnit.UnitsMethods_LengthUnit_Meter)
    except TypeError:  # bindings that return the value instead of filling the list
        found = False
    return doc, (float(unit[0]) if found and unit[0] > 0 else 0.001)  # OpenCascade's default: millimetres


def label_name(label) -> str:
    """The TDataStd_Name of a label, or "" (copied through an ASCII string: ToExtString's
    pointer does not outlive the attribute in these bindings)."""
    from OCP.TCollection import TCollection_AsciiString
    from OCP.TDataStd import TDataStd_Name

    attribute = TDataStd_Name()
    if not label.FindAttribute(TDataStd_Name.GetID_s(), attribute):
        return ""
    return TCollection_AsciiString(attribute.Get(), "?").ToCString().strip()


def _label_colour(colours, label) -> tuple | None:
    """The surface (else generic) colour set on a document label."""
    return _colour(lambda kind, colour: colours.GetColor_s(label, kind, colour))


def _shape_colour(colours, shape) -> tuple | None:
    """The surface (else generic) colour the document sets on a sub-shape (a face)."""
    return _colour(lambda kind, colour: colours.GetColor(shape, kind, colour))


def _colour(get) -> tuple | None:
    from OCP.Quantity import Quantity_Color
    from OCP.XCAFDoc import XCAFDoc_ColorType

    colour = Quantity_Color()
    for kind in (XCAFDoc_ColorType.XCAFDoc_ColorSurf, XCAFDoc_ColorType.XCAFDoc_ColorGen):
        if get(kind, colour):
            return _linear(colour)
    return None


def _linear(colour) -> tuple:
    """OpenCascade's Quantity_Color values are linear RGB already (its TOC_RGB is linear)."""
    return (float(colour.Red()), float(colour.Green()), float(colour.Blue()))


def _matrix(location, unit_m: float) -> np.ndarray:
    """(4, 4) float64 of a TopLoc_Location, translation in metres."""
    trsf = location.Transformation()
    m = np.eye(4)
    for r in range(3):
        for c in range(4):
            m[r, c] = trsf.Value(r + 1, c + 1)
    m[:3, 3] *= unit_m
    return m


def _collect(shapes, colours, unit_m: float) -> dict:
    """{prototype label entry: _Prototype} with every instance path under the free shapes."""
    from OCP.OCP.collections import Sequence_TDF_Label

    free = Sequence_TDF_Label()
    shapes.GetFreeShapes(free)
    prototypes: dict = {}
    used: dict = {}
    for i in range(1, free.Length() + 1):
        label = free.Value(i)
        _walk(shapes, colours, label, np.eye(4), [label_name(label) or f"shape{i}"], None, prototypes, used, unit_m)
    return prototypes


def _walk(shapes, colours, label, matrix, path, colour, prototypes, used, unit_m):
    """Descend from ``label`` (at ``matrix``, reached through ``path``) to its prototypes."""
    from OCP.OCP.collections import Sequence_TDF_Label
    from OCP.TDF import TDF_Label

    colour = _label_colour(colours, label) or colour
    if shapes.IsReference_s(label):
        referred = TDF_Label()
        shapes.GetReferredShape_s(label, referred)
        matrix = matrix @ _matrix(shapes.GetLocation_s(label), unit_m)
        _walk(shapes, colours, referred, matrix, path, colour, prototypes, used, unit_m)
        return
    if shapes.IsAssembly_s(label):
        components = Sequence_TDF_Label()
        shapes.GetComponents_s(label, components)
        for j in range(1, components.Length() + 1):
            component = components.Value(j)
            name = _component_name(shapes, component) or f"component{j}"
            _walk(shapes, colours, component, matrix, path + [name], colour, prototypes, used, unit_m)
        return
    entry = _entry(label)
    proto = prototypes.get(entry)
    if proto is None:
        proto = prototypes[entry] = _Prototype(
            label_name(label) or path[-1], shapes.GetShape_s(label), _label_colour(colours, label)
        )
    instance_id = "/".join(path)
    count = used.get(instance_id, 0)
    used[instance_id] = count + 1
    proto.instances.append((instance_id if count == 0 else f"{instance_id}#{count + 1}", matrix, colour))
    if colour is not None and proto.color is None:
        proto.color = colour


def _component_name(shapes, component) -> str:
    """A component's own name, else its prototype's: OpenCascade names an unnamed component
    after its reference ("=>[0:1:1:2]"), which says nothing to a planner."""
    from OCP.TDF import TDF_Label

    name = label_name(component)
    if name and not name.startswith("=>"):
        return name
    referred = TDF_Label()
    if shapes.IsReference_s(component) and shapes.GetReferredShape_s(component, referred):
        return label_name(referred)
    return ""


def _entry(label) -> str:
    from OCP.TCollection import TCollection_AsciiString
    from OCP.TDF import TDF_Tool

    text = TCollection_AsciiString()
    TDF_Tool.Entry_s(label, text)
    return text.ToCString()


def _tessellate(shape, deflection: float, colours):
    """(vertices (n, 3) float64, faces (m, 3) int64, dominant face colour or None) of a shape,
    in the document's length unit, in the shape's own frame."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    with native_output(fds=(1, 2)):
        BRepMesh_IncrementalMesh(shape, max(deflection, 1e-9), False, ANGULAR_DEFLECTION, True)
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    face_colours: dict[tuple, int] = {}
    offset = 0
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        explorer.Next()
        location = TopLoc_Location()
        triangulation = BRep_Tool.Triangulation_s(face, location)
        if triangulation is None or triangulation.NbTriangles() == 0:
            continue
        nodes, triangles = _arrays(triangulation)
        if not location.IsIdentity():
            m = _matrix(location, 1.0)
            nodes = nodes @ m[:3, :3].T + m[:3, 3]
        if face.Orientation() == TopAbs_REVERSED:
            triangles = triangles[:, ::-1]
        vertices.append(nodes)
        faces.append(triangles + offset)
        offset += len(nodes)
        colour = _shape_colour(colours, face)
        if colour is not None:
            face_colours[colour] = face_colours.get(colour, 0) + len(triangles)
    if not faces:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), None
    dominant = max(face_colours, key=face_colours.__getitem__) if face_colours else None
    return np.concatenate(vertices), np.concatenate(faces), dominant


def _arrays(triangulation):
    """(nodes (n, 3) float64, triangles (m, 3) int64 0-based) of a Poly_Triangulation."""
    n, m = triangulation.NbNodes(), triangulation.NbTriangles()
    nodes = np.empty((n, 3))
    for i in range(n):
        p = triangulation.Node(i + 1)
        nodes[i] = (p.X(), p.Y(), p.Z())
    triangles = np.empty((m, 3), np.int64)
    for i in range(m):
        triangles[i] = triangulation.Triangle(i + 1).Get()
    return nodes, triangles - 1


__all__ = ["read_step", "label_name", "ANGULAR_DEFLECTION"]
