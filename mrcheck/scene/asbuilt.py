"""``mrcheck scene asbuilt``: a perturbed copy of a planned scene, and the list of what differs.

Ground truth for discrepancy checks: the planned scene says where things should be, the
as-built variant is what a photo of the real hall would show, and ``discrepancies.json`` says
exactly what changed. The same planned scene and seed always give byte-identical files.

Output folder::

    OUTDIR/scene.toml          the as-built manifest (format 1, as mrcheck.scene.model reads it)
    OUTDIR/discrepancies.json  the changes, below
    OUTDIR/...                 copies of every file the meshes need (URDF folders with their
                               meshes and licence files too), in the planned scene's layout, so
                               the folder is self-contained and can be moved anywhere
    OUTDIR/external/<n>/...    the same for meshes outside the planned scene's folder, one
                               numbered folder per folder they come from (see :func:`_layout`)

A new variant in the folder of an earlier one replaces only what that one wrote (its manifest,
its report and the folders its meshes are in); other files there stay.

``discrepancies.json``::

    {"planned": "/abs/path/of/the/planned/scene.toml",
     "seed": 0,
     "excluded_parts": [{"part": "floor", "reason": "largest footprint"}, ...],
     "discrepancies": [
       {"id": "pallet#3", "part": "pallet", "kind": "moved", "magnitude": 0.734, "unit": "m",
        "detail": {"vector": [dx, dy, 0.0], "from": [x, y, z], "to": [x, y, z]}},
       ...]}

``id`` is the instance id of :attr:`mrcheck.scene.model.Part.instance_ids`, the same in both scenes.
``from``, ``to``, ``position`` and ``pivot`` points are world coordinates (metres for parts with
declared units); a "base" point is the centre of the bottom face of an instance's bounding box.

=========  =========================================================  ==========  =====
kind       change                                                      magnitude   unit
=========  =========================================================  ==========  =====
moved      translated horizontally by 0.05 .. 2 m; detail: ``vector``  distance    m
           (dx, dy, 0), ``from`` and ``to`` (base points)
rotated    turned about the vertical axis through ``pivot`` by         abs. angle  deg
           ``angle_deg`` (signed, counter-clockwise seen from above),
           5 .. 90 deg; the pivot is the part's own origin when it lies
           inside the instance's footprint (a robot's base, a pallet's
           centre), else the footprint centre
missing    the instance is not in the as-built scene;                  null        null
           detail: ``position`` (base point it had)
added      a new instance (a new id) of an existing part, standing     null        null
           free on the floor; detail: ``position`` (base point),
           ``template`` (the instance it copies, shifted horizontally)
replaced   replaced by another size: scaled uniformly by 0.7 .. 0.9 or  scale       null
           1.1 .. 1.4 about its base point (``pivot``); written as a
           part of its own (``new_part``) with ``scale``, same mesh
=========  =========================================================  ==========  =====

Which instances change (all drawn from the seed, with Python's ``random``, whose stream does
not depend on the platform): ``max(round(10 % of the instances), 5)`` changes, one of each kind
first, the rest of random kinds (a scene of fewer than 5 instances gets one). Each part is as
likely to be picked as any other, however many instances it has. A kind that no instance can
take under the rules below is skipped with a warning. Never changed, listed in
``excluded_parts``: the part with the largest single bounding-box footprint (the floor slab,
or a hall shell) and every part whose name contains one of :data:`STRUCTURE_WORDS` (floor,
slab, wall, roof, ceiling, column, beam, hall) -- the building is not what an as-built check
is about. So that nothing floats and nothing sinks, the changes keep physical sense:

- only an instance with nothing standing on it or hanging from it is moved, rotated, removed
  or replaced (a pallet carrying cartons, a fence post holding panels and the robot's pedestal
  stay put); one that hangs from another (a fence panel between posts) can only go missing;
- moved and added instances stand on the floor (their base at the lowest base of the scene's
  objects), stay inside the floor's footprint, keep a clear gap to everything else and stay
  out of the 3 m around the foot of each viewpoint's eye (there they would hide the view);
- rotated and replaced instances still stand on what they stood on (the robot on its
  pedestal, cartons on their pallet) and run into nothing else;
- every change is horizontal or about a vertical axis or the base, so no base moves vertically.

An instance gets at most one change. The manifest keeps every untouched part as it was (mesh
paths rewritten relative to OUTDIR); a part with a changed instance gets an explicit ``id`` on
every instance so the ids of the others stay what they were.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from pathlib import Path, PurePosixPath

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import check_not_inputs, check_writable_ancestor
from mrcheck.core.progress import Progress, no_progress, showing_progress
from mrcheck.scene.asbuilt_plan import (
    DECIMALS,
    KINDS,
    SHARE,
    STRUCTURE_WORDS,
    Planner,
    base_point,
    change_kinds,
    classify,
    excluded_parts,
    planned_instances,
    rounded,
    unique_name,
)
from mrcheck.scene.manifest import (
    dumps_manifest,
    mesh_files,
    notice_files,
    read_manifest,
    write_generated,
)
from mrcheck.scene.model import load_scene

__all__ = ["make_asbuilt", "KINDS", "STRUCTURE_WORDS", "SHARE"]


# -- writing -----------------------------------------------------------------------------------------
def _record(kind, inst, change, new_id, new_part) -> dict:
    if kind == "moved":
        shift = rounded(change.shift)
        detail = {"vector": shift, "from": rounded(base_point(inst.box)), "to": rounded(base_point(inst.box) + shift)}
        return _entry(inst, kind, round(float(np.hypot(*change.shift[:2])), DECIMALS), "m", detail)
    if kind == "rotated":
        detail = {"angle_deg": change.angle_deg, "axis": [0.0, 0.0, 1.0], "pivot": rounded(change.pivot)}
        return _entry(inst, kind, abs(change.angle_deg), "deg", detail)
    if kind == "missing":
        return _entry(inst, kind, None, None, {"position": rounded(base_point(inst.box))})
    if kind == "added":
        detail = {"position": rounded(base_point(inst.box) + change.shift), "template": inst.id}
        return {**_entry(inst, kind, None, None, detail), "id": new_id}
    detail = {"scale": change.scale, "pivot": rounded(change.pivot), "new_part": new_part}
    return _entry(inst, kind, change.scale, None, detail)


def _entry(inst, kind, magnitude, unit, detail) -> dict:
    return {"id": inst.id, "part": inst.part, "kind": kind, "magnitude": magnitude, "unit": unit, "detail": detail}


def _asbuilt_tables(tables, scene, changes) -> tuple[list, list]:
    """The as-built [[parts]] tables and the discrepancy records, in manifest order."""
    by_id = {inst.id: (kind, inst, change) for kind, inst, change, _ in changes if kind != "added"}
    added: dict[str, list] = {}
    for kind, inst, change, new_id in changes:
        if kind == "added":
            added.setdefault(inst.part, []).append((inst, change, new_id))
    names = {p.name for p in scene.parts}
    records, out = [], []
    for part, table in zip(scene.parts, tables):
        # an unnamed part is named by its position (part3), which dropping or adding parts would change
        table = {"name": part.name, **table}
        originals = table.get("instances") or [{}]
        touched = added.get(part.name) or any(i in by_id for i in part.instance_ids)
        if not touched:
            out.append(table)
            continue
        kept, replacements = [], []
        plain = {k: v for k, v in table.items() if k != "instances"}
        for iid, inst_table in zip(part.instance_ids, originals):
            kind, inst, change = by_id.get(iid, (None, None, None))
            new_part = None
            if kind is None:
                kept.append({"id": iid, **{k: v for k, v in inst_table.items() if k != "id"}})
            elif kind in ("moved", "rotated"):
                kept.append({"id": iid, **change.table(inst_table)})
            elif kind == "replaced":
                # another size is another product: a part of its own, same mesh, with a scale
                new_part = unique_name(f"{part.name}-replaced-", names)
                replacements.append({**plain, "name": new_part, "instances": [{"id": iid, **change.table(inst_table)}]})
            if kind is not None:
                records.append(_record(kind, inst, change, None, new_part))
        for inst, change, new_id in added.get(part.name, []):
            template = originals[inst.index]
            kept.append({"id": new_id, **change.table(template)})
            records.append(_record("added", inst, change, new_id, None))
        if kept:  # a part left with no instance is dropped: an empty list would mean one, untransformed
            out.append({**plain, "instances": kept})
        out += replacements
    records.sort(key=lambda r: (KINDS.index(r["kind"]), r["id"]))
    return out, records


def _layout(manifest: Path, tables) -> dict:
    """{part mesh string: [(source file, path in OUTDIR)]}, the mesh file first.

    A part whose files all lie in the manifest's folder keeps its path there. Any other (mesh =
    "../shared/x.glb", "/data/robots/pybullet_data/kuka_iiwa/model.urdf") goes to
    ``external/<n>/``, n = 1, 2, ... for each folder holding such parts' files (the outermost of
    nested ones, in path order), laid out as in that folder: a URDF keeps its meshes and its
    package's licence where its relative paths expect them, and the variant does not mirror
    the file system from ``/``.
    """
    home = Path(os.path.normpath(manifest.parent.absolute()))
    files, inside = {}, {}
    for table in tables:
        mesh = manifest.parent / table["mesh"]
        found = mesh_files(mesh)
        inside[table["mesh"]] = all(home in f.parents for f in found)
        # a licence above the scene's folder for a part inside it (a robot.urdf beside
        # scene.toml) would be the licence of whatever project holds the scene: left out
        notices = [n for n in notice_files(mesh) if not inside[table["mesh"]] or home in n.parents]
        files[table["mesh"]] = list(dict.fromkeys(found + notices))
    roots: list[Path] = []
    for root in sorted(
        {Path(os.path.commonpath([f.parent for f in found])) for mesh, found in files.items() if not inside[mesh]},
        key=lambda p: p.parts,
    ):  # a folder before those inside it
        if not any(r == root or r in root.parents for r in roots):
            roots.append(root)
    layout = {}
    for mesh, found in files.items():
        if inside[mesh]:
            layout[mesh] = [(f, f.relative_to(home).as_posix()) for f in found]
        else:
            n, root = next((n, r) for n, r in enumerate(roots, 1) if r == found[0].parent or r in found[0].parents)
            layout[mesh] = [(f, f"external/{n}/{f.relative_to(root).as_posix()}") for f in found]
    return layout


def _check_outdir(outdir: Path, manifest: Path):
    out, home = outdir.resolve(), manifest.parent.resolve()
    if out == home:
        raise MrcheckError("the output folder is the planned scene's own folder; pick another", outdir)
    if out in home.parents:
        raise MrcheckError("the output folder contains the planned scene, which replacing it would delete", outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError("the output is a file, not a folder", outdir)
    check_writable_ancestor(outdir)  # fail before the work, not after it
    if outdir.is_dir() and any(outdir.iterdir()) and not (outdir / "discrepancies.json").is_file():
        # only an earlier as-built variant's files (or an empty folder's nothing) are replaced
        raise MrcheckError("the output folder exists and is not an as-built variant (no discrepancies.json)", outdir)


def _earlier_entries(outdir: Path) -> set:
    """Top-level entries an earlier variant in ``outdir`` wrote: its manifest, its report and
    the first folder (or file) of each mesh path its manifest names. Regenerating replaces
    these and nothing else there."""
    names = {"scene.toml", "discrepancies.json"}
    try:
        parts = read_manifest(outdir / "scene.toml").get("parts", [])
    except MrcheckError:  # missing or unreadable: only the two fixed names are the variant's
        return names
    for part in parts if isinstance(parts, list) else []:
        mesh = part.get("mesh") if isinstance(part, dict) else None
        if isinstance(mesh, str) and mesh:
            first = PurePosixPath(mesh).parts[0]
            if first not in ("/", "..", "."):  # a variant's paths are relative and inside it
                names.add(first)
    return names


def make_asbuilt(scene_path, outdir, seed: int = 0, progress: Progress = no_progress) -> list[Path]:
    """Write the as-built variant of the planned manifest ``scene_path`` for ``seed`` into
    ``outdir`` (replacing an earlier variant there); returns [scene.toml, discrepancies.json].
    ``progress``: shows choosing the changes and copying the meshes (and, given at all, loading
    the scene, :func:`mrcheck.scene.model.load_scene`)."""
    with showing_progress(progress):  # the scene's loading shown by the same display
        scene = load_scene(Path(scene_path), progress=progress is not no_progress)
    # absolute first: `-o .` and `-o ../here` from inside the folder name the same folder
    manifest, outdir = scene.source, Path(os.path.abspath(outdir))
    if manifest.suffix.lower() != ".toml":
        raise MrcheckError(
            "an as-built variant is made from a scene manifest (.toml), not a single mesh file", manifest
        )
    _check_outdir(outdir, manifest)
    data = read_manifest(manifest)
    tables = data["parts"]
    layout = _layout(manifest, tables)
    # every top-level entry written or replaced in OUTDIR (its meshes/, external/ ...) goes as a whole
    stale = _earlier_entries(outdir)
    entries = stale | {PurePosixPath(name).parts[0] for files in layout.values() for _, name in files}
    check_not_inputs(
        [],
        [
            ("the planned scene", manifest),
            *((f"a file of part mesh {mesh}", [f for f, _ in files]) for mesh, files in layout.items()),
        ],
        folders=[outdir / name for name in sorted(entries)],
    )

    instances = planned_instances(scene, tables)
    excluded = excluded_parts(scene)
    floor_part = next(name for name, why in excluded.items() if why == "largest footprint")
    if all(i.part in excluded for i in instances):
        raise MrcheckError(
            f"nothing to change: every part is floor or hall structure ({', '.join(excluded)})", manifest
        )
    floor_z = classify(instances, floor_part, excluded)
    floor_boxes = scene.parts[[p.name for p in scene.parts].index(floor_part)].instance_bounds()
    region = np.array([floor_boxes[:, 0, :2].min(axis=0), floor_boxes[:, 1, :2].max(axis=0)])
    eyes = [vp["eye"] for vp in scene.viewpoints.values()]
    planner = Planner(instances, excluded, floor_part, floor_z, region, eyes, seed)
    changes = planner.plan(change_kinds(len(instances), planner.rng), progress)
    parts, records = _asbuilt_tables(tables, scene, changes)

    used = sorted({pair for table in parts for pair in layout[table["mesh"]]})  # not the meshes of dropped parts
    for table in parts:
        table["mesh"] = layout[table["mesh"]][0][1]
    planned = str(manifest.resolve())
    header = (
        f"As-built variant of {planned}\nmade by `mrcheck scene asbuilt --seed {seed}`: "
        "every change is listed in discrepancies.json."
    )
    name = str(data.get("name", manifest.stem))
    description = f"As built (seed {seed}) of {name}. {data.get('description', '')}".strip()
    out_data = {"format": 1, **data, "name": f"{name}_asbuilt_{seed}", "description": description, "parts": parts}
    report = {
        "planned": planned,
        "seed": seed,
        "excluded_parts": [{"part": name, "reason": why} for name, why in excluded.items()],
        "discrepancies": records,
    }

    def fill(tmp: Path):
        with contextlib.closing(progress(used, "copying meshes", "file")) as files:
            for source, name in files:
                target = tmp / name
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(source, target)
        (tmp / "scene.toml").write_text(dumps_manifest(out_data, header))
        (tmp / "discrepancies.json").write_text(json.dumps(report, indent=2) + "\n")

    write_generated(outdir, fill, stale=stale)
    return [outdir / "scene.toml", outdir / "discrepancies.json"]
