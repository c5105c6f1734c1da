"""An imported model as a normal mrcheck scene folder: ``scene.toml`` plus ``meshes/NAME.glb``.

Each part's mesh is re-centred on its bounding-box centre in float64 before it is stored as
float32 in its GLB, and the centre goes into the instances' float64 matrices; the model's
float64 ``origin`` is the manifest's ``origin`` key (world = origin + placement). So a model at
map coordinates keeps its millimetres through the files: float32 only ever holds coordinates
relative to a part's own centre, TOML floats are float64 written with ``repr``.

The manifest carries what the importers know about each element (part and instance ``name``,
``ifc_class``, ``storey``; instance ids are GlobalIds or assembly paths) and one computed
viewpoint, ``overview``, so that ``mrcheck render MODEL.ifc --view overview`` works at once.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError, display
from mrcheck.scene.importers.records import ImportedModel, ImportedPart
from mrcheck.scene.manifest import dumps_manifest, remove_stale_work, write_generated

MARKER = "Imported by mrcheck scene import"  # a folder whose scene.toml starts with this may be replaced
OWN = ("scene.toml", "meshes", "README.md")
OVERVIEW = "overview"
INLINE_INSTANCES = 16  # more instances of a part go to meshes/NAME.instances.json
OVERVIEW_SIZE = (1024, 768)
OVERVIEW_FOV_DEG = 60.0


def check_import_dir(outdir: Path) -> None:
    """Refuse to write into a folder that holds other things than an earlier import (what a
    killed import left there is removed first: it is not the user's)."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("output exists and is not a folder", outdir)
    remove_stale_work(outdir)
    if outdir.is_dir() and any(outdir.iterdir()):
        manifest = outdir / "scene.toml"
        head = manifest.read_text(errors="replace")[:200] if manifest.is_file() else ""
        if MARKER not in head:
            raise MrcheckError(
                "output folder is not empty and holds no imported scene; not replacing it "
                "(pick a new folder or empty it)",
                outdir,
            )


def write_scene(model: ImportedModel, outdir: Path, header: str) -> Path:
    """Write ``model`` into ``outdir`` (only the entries :data:`OWN` are replaced) and return
    its scene.toml. ``header`` is the manifest's first comment line after the marker."""
    outdir = Path(os.path.abspath(outdir))
    check_import_dir(outdir)
    header = display(header)  # a file name that is not UTF-8 as \xNN: the files are UTF-8 text
    write_generated(outdir, lambda work: _fill(work, model, header), stale=OWN)
    return outdir / "scene.toml"


def _fill(work: Path, model: ImportedModel, header: str) -> None:
    (work / "meshes").mkdir()
    tables = [_write_part(work, part) for part in model.parts]
    data = {"format": 1, "name": model.name, "description": describe(model)}
    if np.any(model.origin != 0):
        data["origin"] = [float(v) for v in model.origin]
    if model.crs:
        data["crs"] = model.crs
    data["parts"] = tables
    # the file's own viewpoints first (the first is what a command without --view shows), then
    # the computed overview unless the file has one of that name
    names = {v["name"] for v in model.viewpoints}
    data["viewpoints"] = list(model.viewpoints) + ([overview(model)] if OVERVIEW not in names else [])
    (work / "scene.toml").write_text(dumps_manifest(data, f"{MARKER} {header}"), encoding="utf-8")
    (work / "README.md").write_text(_readme(model, header), encoding="utf-8")


def describe(model: ImportedModel) -> str:
    what = "elements" if model.kind == "ifc" else "instances"
    text = (
        f"Imported from {display(model.source.name)} ({model.schema.split()[0]}): {model.element_count} {what} in "
        f"{len(model.parts)} parts, {model.triangle_count:,} triangles as rendered."
    )
    if model.failed:
        text += f" {len(model.failed)} element(s) without geometry left out."
    return text


def _write_part(work: Path, part: ImportedPart) -> dict:
    """Write the part's GLB (float32 around its centre) and return its manifest table."""
    import trimesh

    vertices = np.asarray(part.vertices, np.float64)
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    shift = np.eye(4)
    shift[:3, 3] = centre
    mesh = trimesh.Trimesh(vertices=vertices - centre, faces=part.faces, process=False)
    mesh.export(work / "meshes" / f"{part.name}.glb", file_type="glb")
    table = {
        "name": part.name,
        "mesh": f"meshes/{part.name}.glb",
        "units": "m",
        "color": [round(float(c), 6) for c in part.color],
    }
    for key in ("ifc_class", "storey"):
        if getattr(part, key):
            table[key] = getattr(part, key)
    instances = [_instance(i, shift) for i in part.instances]
    if len(instances) > INLINE_INSTANCES:  # thousands of matrices: JSON beside the mesh, not TOML
        name = f"meshes/{part.name}.instances.json"
        (work / name).write_text(json.dumps(instances, separators=(",", ":")), encoding="utf-8")
        table["instances_file"] = name
    else:
        table["instances"] = instances
    return table


def _instance(instance, shift: np.ndarray) -> dict:
    entry = {"id": instance.id, "matrix": [[float(v) for v in row] for row in instance.matrix @ shift]}
    for key in ("name", "ifc_class", "storey"):
        if getattr(instance, key):
            entry[key] = getattr(instance, key)
    return entry


def overview(model: ImportedModel) -> dict:
    """A viewpoint that sees the whole model from above a corner (manifest frame: relative to
    the origin)."""
    boxes = []
    for part in model.parts:
        lo, hi = part.vertices.min(axis=0), part.vertices.max(axis=0)
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for instance in part.instances:
            boxes.append((corners @ instance.matrix.T)[:, :3])
    points = np.concatenate(boxes)
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, radius = (lo + hi) / 2.0, max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-3)
    # far enough that the bounding sphere fits the vertical field of view
    distance = radius / np.sin(np.radians(OVERVIEW_FOV_DEG / 2.0)) * 1.05
    direction = np.array([-0.55, -0.7, 0.45])
    eye = centre + direction / np.linalg.norm(direction) * distance
    return {
        "name": OVERVIEW,
        "eye": [float(v) for v in eye],
        "target": [float(v) for v in centre],
        "up": [0.0, 0.0, 1.0],
        "fov_y_deg": OVERVIEW_FOV_DEG,
        "width": OVERVIEW_SIZE[0],
        "height": OVERVIEW_SIZE[1],
    }


def _readme(model: ImportedModel, header: str) -> str:
    failed = "\n".join(f"- {f.ifc_class} {f.name!r} `{f.id}`: {f.reason}" for f in model.failed[:200]) or "none"
    notes = "\n".join(f"- {n}" for n in model.notes) or "none"
    origin = ", ".join(f"{v:.3f}" for v in model.origin)
    return f"""# {model.name}: imported scene

{MARKER} {header}. Do not edit by hand: import the model again.

{describe(model)}

Origin (world position of the placements, metres): ({origin}){f", CRS {model.crs}" if model.crs else ""}.

## Notes

{notes}

## Elements without geometry

{failed}
"""


__all__ = ["write_scene", "check_import_dir", "describe", "overview", "MARKER", "OVERVIEW"]
