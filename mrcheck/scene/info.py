"""``mrcheck scene info``: what a planner checks in a CAD export before rendering it.

:func:`describe` loads a scene (a manifest or one mesh file, exactly as ``mrcheck render``
does, but without any GL) and returns a JSON-ready dictionary:

``scene``, ``source``
    the scene's name and the manifest (or mesh file) read.
``triangles``, ``unique_triangles``, ``instances``
    triangles as rendered (every instance counted), triangles of each part's mesh counted once
    (what the GPU holds), and the number of instances drawn.
``bounds_m``
    ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of everything, world units: metres for parts
    with declared units, raw coordinates for parts without (equal to ``Scene.bounds()``).
``units_declared``, ``parts_without_units``
    the sorted distinct units the parts declare, and the names of the parts that declare none:
    their coordinates are taken as authored, the usual sign of a CAD export whose unit was
    forgotten (a part in mm then comes out 1000 times too large).
``files_bytes``
    total size of the files the meshes load from (mesh files and their companions, see
    :mod:`mrcheck.scene.manifest`), each file counted once however many parts use it.
``parts``
    one entry per part: ``name``, ``mesh`` (as written in the manifest, or the file as given),
    ``units`` (null = as authored), ``instances``, ``triangles`` (of the mesh),
    ``triangles_drawn`` (x instances), ``bounds_m`` (all its instances).
``origin``, ``crs``
    the float64 world position of the manifest's placements (map coordinates of an imported
    BIM model, else zeros) and the map's CRS ("" when unknown).
``parts[].ifc_class``, ``parts[].storey``, ``parts[].elements``
    of imported (IFC/STEP) scenes: the part's IFC class and storey (when all its instances
    share one) and per instance ``id`` (GlobalId or assembly path), ``name``, ``ifc_class``, ``storey``.
``viewpoints``
    one entry per named view: ``name``, ``eye``, ``target``, ``fov_y_deg``, ``width``,
    ``height`` (the defaults the renderer uses filled in).

:func:`format_info` turns that dictionary into the plain-text report the command prints.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mrcheck.scene.importers.sniff import IMPORT_SUFFIXES
from mrcheck.scene.manifest import mesh_files, read_manifest
from mrcheck.scene.model import load_scene

# what Scene.camera uses for a viewpoint that leaves them out
DEFAULT_FOV_Y_DEG = 60.0
DEFAULT_SIZE = (1024, 768)


def _floats(values) -> list:
    return np.asarray(values, np.float64).tolist()


def describe(path, units: str | None = None) -> dict:
    """The facts of the scene at ``path`` as a JSON-ready dictionary (see the module docstring)."""
    path = Path(path)
    scene = load_scene(path, units=units)
    imported = scene.source.suffix.lower() in IMPORT_SUFFIXES
    if scene.source.suffix.lower() == ".toml":
        meshes = [table["mesh"] for table in read_manifest(scene.source)["parts"]]  # loader order
    elif imported:  # the import cache's GLB of each part
        meshes = [f"{path.name}: {part.name}" for part in scene.parts]
    else:
        meshes = [str(path)]
    files = {scene.source} if imported else {f for part in scene.parts for f in mesh_files(part.source) if f.is_file()}
    parts = []
    for part, mesh in zip(scene.parts, meshes):
        boxes = part.instance_bounds()
        parts.append(
            {
                "name": part.name,
                "mesh": mesh,
                "units": part.units,
                "instances": len(part.transforms),
                "triangles": part.triangle_count,
                "triangles_drawn": part.triangle_count * len(part.transforms),
                "bounds_m": [_floats(boxes[:, 0].min(axis=0)), _floats(boxes[:, 1].max(axis=0))],
                **_element_fields(part),
            }
        )
    views = []
    for name, vp in scene.viewpoints.items():
        views.append(
            {
                "name": name,
                "eye": _floats(vp["eye"]),
                "target": _floats(vp["target"]),
                "fov_y_deg": float(vp.get("fov_y_deg", DEFAULT_FOV_Y_DEG)),
                "width": int(vp.get("width", DEFAULT_SIZE[0])),
                "height": int(vp.get("height", DEFAULT_SIZE[1])),
            }
        )
    return {
        "scene": scene.name,
        "source": str(scene.source),
        "triangles": scene.triangle_count,
        "unique_triangles": sum(p.triangle_count for p in scene.parts),
        "instances": sum(len(p.transforms) for p in scene.parts),
        "bounds_m": [_floats(b) for b in scene.bounds()],
        "origin": _floats(scene.origin),
        "crs": scene.crs,
        "units_declared": sorted({p.units for p in scene.parts if p.units is not None}),
        "parts_without_units": [p.name for p in scene.parts if p.units is None],
        "files_bytes": sum(f.stat().st_size for f in files),
        "parts": parts,
        "viewpoints": views,
    }


def _element_fields(part) -> dict:
    """The IFC/STEP facts of a part and its instances (nothing for a part that has none)."""
    known = any(info.name or info.ifc_class or info.storey for info in part.instance_info)
    if not (known or part.ifc_class or part.storey):
        return {}
    return {
        "ifc_class": part.ifc_class,
        "storey": part.storey,
        "elements": [
            {"id": iid, "name": info.name, "ifc_class": info.ifc_class, "storey": info.storey}
            for iid, info in zip(part.instance_ids, part.instance_info)
        ],
    }


def _size(n: float) -> str:
    for unit in ("B", "KB", "MB"):
        if n < 1000:
            return f"{n} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} GB"


def _columns(header: list, rows: list, right: set) -> list[str]:
    """Rows of strings as aligned columns; the columns in ``right`` right-aligned (numbers)."""
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]

    def line(row):
        cells = [str(c).rjust(w) if i in right else str(c).ljust(w) for i, (c, w) in enumerate(zip(row, widths))]
        return "  ".join(cells).rstrip()

    return [line(header), line(["-" * w for w in widths]), *(line(r) for r in rows)]


def _point(p) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


def format_info(info: dict) -> str:
    """The plain-text report of :func:`describe`'s dictionary."""
    lo, hi = np.asarray(info["bounds_m"], np.float64)
    extent = hi - lo
    missing = info["parts_without_units"]
    lines = [
        f"scene       {info['scene']}",
        f"source      {info['source']}",
        f"parts       {len(info['parts'])} ({info['instances']} instances)",
        f"triangles   {info['triangles']:,} drawn, {info['unique_triangles']:,} unique (each mesh once)",
        f"files       {_size(info['files_bytes'])}",
        f"units       {', '.join(info['units_declared']) or 'none declared'}"
        + (f" (+ {len(missing)} part(s) as authored)" if missing else ""),
        f"bounds      x {lo[0]:.3f} .. {hi[0]:.3f}   y {lo[1]:.3f} .. {hi[1]:.3f}   z {lo[2]:.3f} .. {hi[2]:.3f} m",
        f"extent      {extent[0]:.3f} x {extent[1]:.3f} x {extent[2]:.3f} m (L x W x H)",
    ]
    if any(info.get("origin", (0, 0, 0))) or info.get("crs"):
        lines.append(
            "origin      "
            + ", ".join(f"{v:.3f}" for v in info["origin"])
            + " m"
            + (f" ({info['crs']})" if info.get("crs") else "")
            + "  (placements are relative to it)"
        )
    lines.append("")
    rows = [
        [
            p["name"],
            p["mesh"],
            p["units"] or "-",
            p["instances"],
            f"{p['triangles']:,}",
            f"{p['triangles_drawn']:,}",
            " x ".join(f"{e:.2f}" for e in np.subtract(p["bounds_m"][1], p["bounds_m"][0])),
        ]
        for p in info["parts"]
    ]
    header = ["part", "mesh", "units", "instances", "triangles", "drawn", "extent m"]
    if any("ifc_class" in p for p in info["parts"]):  # an imported model: what each part is, where
        header += ["class", "storey"]
        rows = [r + [p.get("ifc_class") or "-", p.get("storey") or "-"] for r, p in zip(rows, info["parts"])]
    lines += _columns(header, rows, right={3, 4, 5})
    if info["viewpoints"]:
        lines += ["", "viewpoints"]
        rows = [
            [v["name"], _point(v["eye"]), _point(v["target"]), f"{v['fov_y_deg']:g}", f"{v['width']} x {v['height']}"]
            for v in info["viewpoints"]
        ]
        lines += ["  " + line for line in _columns(["name", "eye", "target", "fov_y", "size"], rows, right={3})]
    if missing:
        # last, so it is what a terminal shows at the bottom: a part in mm read as metres is 1000x too big
        lines += [
            "",
            f"WARNING: {len(missing)} part(s) without declared units, coordinates taken as authored "
            f"(not metres): {', '.join(missing)}",
        ]
    return "\n".join(lines)


__all__ = ["describe", "format_info"]
