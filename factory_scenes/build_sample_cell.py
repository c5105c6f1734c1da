"""Generate the embedded sample scene ``factory_scenes/sample_cell/``.

The scene is a small factory cell (floor slab 24 m x 16 m, steel hall frame 6 m high)
made for screen-space ambient occlusion: almost every part is a cluster of boxes and
cylinders that meet in concave creases, with small detail (bolts, nuts, rollers, welded
mesh wires, pallet slats, carton joints) next to large flat areas (floor, back wall).

Conventions: Z is up, world units are metres, the floor's top face is z = 0 and the cell
is centred on the world origin. Each part mesh is authored in its own frame (usually
origin at the centre of its footprint, on the floor; each builder's docstring says where)
and placed by the manifest's ``translate`` / ``rotate_deg`` or per-instance transforms.
The roller conveyor is deliberately authored in millimetres (``units = "mm"``) so that
the scene mixes CAD unit scales.

Run ``python factory_scenes/build_sample_cell.py``. It overwrites, next to itself::

    sample_cell/scene.toml             the manifest (format 1)
    sample_cell/meshes/*.glb           one mesh per part
    sample_cell/robots/kuka_iiwa/      KUKA LBR iiwa URDF + OBJ visuals from pybullet_data
    sample_cell/README.md

The output is deterministic (fixed dimensions, fixed seed for the carton jitter), so two
runs give byte-identical files.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import trimesh

if __package__ in (None, ""):  # run as a script: make the factory_scenes package importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

# the part builders and the writers are shared with the scene generator
from factory_scenes.generator.equipment import (
    PEDESTAL_TOP,
    bollard,
    control_cabinet,
    fence_layout,
    fence_panel,
    fence_post,
    machining_centre,
    robot_pedestal,
    roller_conveyor,
    workbench,
)
from factory_scenes.generator.geometry import (
    Z_TO_X,
    box_between,
    combine,
    i_profile,
    transformed,
    translation,
)
from factory_scenes.generator.glb import write_glb
from factory_scenes.generator.manifest import Part, manifest_text, place
from factory_scenes.generator.storage import PALLET_HEIGHT, carton_stack, eur_pallet
from factory_scenes.generator.structure import steel_column

OUT_DIR = Path(__file__).resolve().parent / "sample_cell"
# the shared data folder sits beside the repository checkout: ../shared/data/
DEFAULT_PYBULLET_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "robots" / "pybullet_data"
ROBOT_DIR = "robots/kuka_iiwa"

SEED = 1234  # carton jitter; fixed so rebuilds are byte-identical
MAX_TRIANGLES = 200_000  # budget for the whole scene, instances included

# Layout of the cell, metres (world frame). Shared by several parts, so named once.
COLUMN_GRID_X = (-9.0, 0.0, 9.0)
COLUMN_GRID_Y = (-7.0, 7.0)  # rows close to the slab edges keep views open
COLUMN_HEIGHT = 6.0
FENCE_RECT = (0.5, -5.0, 5.5, 0.0)  # x0, y0, x1, y1 of the robot cell fence
FENCE_PITCH = 1.0  # post spacing
FENCE_OPENINGS = ((0.5, -2.5), (3.0, -5.0))  # panel midpoints left open: conveyor, door
ROBOT_XY = (3.0, -2.5)
CONVEYOR_START = (-5.8, -2.5)  # world x, y of the conveyor's upstream end

# --------------------------------------------------------------------------------------
# Parts of this cell only (metres); the others come from factory_scenes.generator
# --------------------------------------------------------------------------------------


def floor_slab() -> trimesh.Trimesh:
    """Concrete slab 24 x 16 x 0.2 m, top face at z = 0."""
    return box_between((-12.0, -8.0, -0.2), (12.0, 8.0, 0.0))


def back_wall(length=22.0, height=3.0) -> trimesh.Trimesh:
    """Low clad wall as a backdrop: concrete plinth, ribbed sheet cladding, coping.

    Local frame: wall runs along x, its front face looks towards -y, origin at the
    middle of the front foot. The ribs (every 0.3 m) give a regular row of creases.
    """
    hl = length / 2.0
    pieces = [
        box_between((-hl, 0.0, 0.0), (hl, 0.2, height)),  # wall body
        box_between((-hl, -0.1, 0.0), (hl, 0.0, 0.4)),  # plinth step
        box_between((-hl, -0.06, height), (hl, 0.26, height + 0.06)),  # coping
    ]
    for x in np.arange(-hl + 0.15, hl, 0.3):
        pieces.append(box_between((x - 0.03, -0.04, 0.4), (x + 0.03, 0.0, height)))
    return combine(pieces)


def hall_beam(length=18.3) -> trimesh.Trimesh:
    """HEB 400 roof beam along x resting on the column caps; origin at its bottom centre."""
    beam = transformed(i_profile(length, 0.4, 0.3, 0.0135, 0.024), Z_TO_X)
    return transformed(beam, translation(-length / 2.0, 0.0, 0.2))


# --------------------------------------------------------------------------------------
# Scene description
# --------------------------------------------------------------------------------------

ROBOT_JOINTS = {  # radians: arm turned towards the conveyor end, elbow up
    "lbr_iiwa_joint_1": 0.25,
    "lbr_iiwa_joint_2": 0.95,
    "lbr_iiwa_joint_3": 0.2,
    "lbr_iiwa_joint_4": -1.25,
    "lbr_iiwa_joint_5": 0.3,
    "lbr_iiwa_joint_6": 1.0,
    "lbr_iiwa_joint_7": 0.6,
}

VIEWPOINTS = [
    {  # from the south-west corner, diagonally across the whole cell
        "name": "overview",
        "eye": [-11.4, -6.2, 1.7],
        "target": [4.0, -0.5, 0.3],
        "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 60.0,
        "width": 1024,
        "height": 768,
    },
    {  # outside the fence, looking through the open door at the robot on its pedestal
        "name": "robot",
        "eye": [3.4, -6.2, 1.7],
        "target": [3.0, -2.5, 0.75],
        "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 35.0,
        "width": 1024,
        "height": 768,
    },
    {  # behind the conveyor's upstream end, looking along the rollers into the cell
        "name": "conveyor",
        "eye": [-7.3, -2.8, 1.7],
        "target": [2.2, -2.5, 0.8],
        "up": [0.0, 0.0, 1.0],
        "fov_y_deg": 60.0,
        "width": 1024,
        "height": 768,
    },
]


def build_parts() -> list[Part]:
    """All parts of the cell with their colours and placements."""
    rng = np.random.default_rng(SEED)
    posts, panels = fence_layout(FENCE_RECT, FENCE_PITCH, FENCE_OPENINGS)
    pallets_full = [place(-4.6, -6.1), place(-3.2, -6.1), place(4.0, 6.0), place(5.4, 6.0, yaw_deg=180.0)]
    pallets_partial = [place(3.0, -1.0), place(6.8, 6.0)]
    pallets_empty = [place(-6.0, -6.1)] + [place(-1.6, -5.9, k * PALLET_HEIGHT, 90.0) for k in range(3)]
    cx, cy = CONVEYOR_START
    return [
        Part("floor", (0.55, 0.55, 0.52), floor_slab()),
        Part("back_wall", (0.70, 0.70, 0.68), back_wall(), translate=(0.0, 7.4, 0.0)),
        Part(
            "column",
            (0.35, 0.42, 0.52),
            steel_column(),
            instances=[place(x, y) for y in COLUMN_GRID_Y for x in COLUMN_GRID_X],
        ),
        Part(
            "hall_beam",
            (0.35, 0.42, 0.52),
            hall_beam(),
            instances=[place(0.0, y, COLUMN_HEIGHT) for y in COLUMN_GRID_Y],
        ),
        Part("conveyor", (0.40, 0.45, 0.50), roller_conveyor(), units="mm", translate=(cx, cy, 0.0)),
        Part("pallet", (0.55, 0.40, 0.25), eur_pallet(), instances=pallets_full + pallets_partial + pallets_empty),
        Part("cartons_full", (0.70, 0.52, 0.33), carton_stack(3, 0, rng), instances=pallets_full),
        Part("cartons_partial", (0.70, 0.52, 0.33), carton_stack(1, 4, rng), instances=pallets_partial),
        Part("fence_post", (0.90, 0.75, 0.10), fence_post(), instances=[place(float(x), float(y)) for x, y in posts]),
        Part(
            "fence_panel",
            (0.90, 0.75, 0.10),
            fence_panel(),
            instances=[place(float(m[0]), float(m[1]), 0.0, float(h)) for m, h in panels],
        ),
        Part("robot_pedestal", (0.30, 0.30, 0.32), robot_pedestal(), translate=(*ROBOT_XY, 0.0)),
        Part(
            "robot",
            (0.95, 0.45, 0.10),
            path=f"{ROBOT_DIR}/model.urdf",
            translate=(*ROBOT_XY, PEDESTAL_TOP),
            rotate_deg=(0.0, 0.0, 180.0),
            joints=ROBOT_JOINTS,
        ),
        Part("workbench", (0.35, 0.45, 0.40), workbench(), translate=(2.2, 6.9, 0.0)),
        Part(
            "machine", (0.75, 0.76, 0.78), machining_centre(), translate=(8.2, -2.5, 0.0), rotate_deg=(0.0, 0.0, -90.0)
        ),  # front towards the cell
        Part(
            "control_cabinet",
            (0.78, 0.78, 0.75),
            control_cabinet(),
            translate=(6.8, 0.6, 0.0),
            rotate_deg=(0.0, 0.0, 180.0),
        ),
        Part(
            "bollard",
            (0.95, 0.80, 0.05),
            bollard(),
            instances=[
                place(0.2, -5.3),
                place(5.8, -5.3),
                place(0.2, 0.3),
                place(5.8, 0.3),
                place(-6.3, -3.2),
                place(-10.2, -6.4),
            ],
        ),
    ]


# --------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------


def copy_robot(source: Path, dest: Path) -> None:
    """Copy the URDF, its visual meshes (+ their .mtl files) and the licence.

    Collision meshes (.stl) are not copied: the renderer only needs visuals, and
    yourdfpy does not load collision meshes unless asked to.
    """
    urdf = source / "kuka_iiwa" / "model.urdf"
    if dest.exists():
        shutil.rmtree(dest)
    (dest / "meshes").mkdir(parents=True)
    shutil.copyfile(urdf, dest / "model.urdf")
    shutil.copyfile(source / "LICENSE.txt", dest / "LICENSE.txt")
    meshes = ET.parse(urdf).getroot().iterfind("link/visual/geometry/mesh")
    for rel in sorted({m.get("filename") for m in meshes}):
        shutil.copyfile(urdf.parent / rel, dest / rel)
        if rel.endswith(".obj"):
            for line in (urdf.parent / rel).read_text().splitlines():
                if line.startswith("mtllib "):
                    mtl = Path(rel).parent / line.split(maxsplit=1)[1].strip()
                    shutil.copyfile(urdf.parent / mtl, dest / mtl)
    (dest / "SOURCE.md").write_text(ROBOT_SOURCE_MD)


def urdf_triangles(path: Path, joints: dict) -> int:
    """Triangle count of the posed URDF visuals (also proves it loads without .stl files)."""
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(path), build_collision_scene_graph=False, load_collision_meshes=False)
    unknown = set(joints) - set(urdf.actuated_joint_names)
    if unknown:
        raise ValueError(f"unknown joints in manifest: {sorted(unknown)}")
    urdf.update_cfg(joints)
    return sum(len(urdf.scene.geometry[n].faces) for n in urdf.scene.graph.nodes_geometry)


def readme_text(rows: list[tuple[str, str, int, int]], total: int) -> str:
    """README for the output folder; ``rows`` are (part, units, mesh triangles, copies)."""
    table = "\n".join(f"| {n} | {u} | {t:,} | {c} | {t * c:,} |" for n, u, t, c in rows)
    views = "\n".join(
        f"- `{v['name']}`: eye {v['eye']} -> target {v['target']}, {v['fov_y_deg']} deg vertical FOV"
        for v in VIEWPOINTS
    )
    return README_TEMPLATE.format(table=table, total=f"{total:,}", views=views)


DESCRIPTION = (
    "Factory cell, about 20 m x 14 m on a 24 m x 16 m slab: steel hall frame with bolted "
    "column feet, roller conveyor (authored in mm), EUR pallets with carton stacks, welded-mesh "
    "safety fence around a KUKA LBR iiwa on a pedestal, workbench, machining centre, control "
    "cabinet and bollards. Z up, metres."
)

ROBOT_SOURCE_MD = """\
# KUKA LBR iiwa model: source and licence

- Source: the `pybullet_data/kuka_iiwa/` folder of the **pybullet 3.2.7** wheel
  (Bullet Physics, https://github.com/bulletphysics/bullet3).
- Copied unchanged: `model.urdf`, `meshes/link_0.obj` ... `meshes/link_7.obj` and their
  `.mtl` files, and `LICENSE.txt` (pybullet_data's licence notice).
- Not copied: the collision meshes (`meshes/link_*.stl`) that the URDF's `<collision>`
  elements name. mrcheck renders visuals only; load the model with
  `yourdfpy.URDF.load(path, build_collision_scene_graph=False, load_collision_meshes=False)`
  (yourdfpy's defaults) and the missing `.stl` files are never opened.
- Licence: zlib (see `LICENSE.txt`). `model.urdf` also carries, in its header, the
  BSD-style notice of the original lbr_iiwa description by Robert Krug and Todor Stoyanov
  (AASS Research Center, Orebro University, 2015); it is kept unchanged in the file.
- Copied by `factory_scenes/build_sample_cell.py`.
"""

README_TEMPLATE = """\
# sample_cell: the embedded sample scene

Generated by `factory_scenes/build_sample_cell.py`; do not edit by hand. Rebuild with

    python factory_scenes/build_sample_cell.py

The KUKA model is copied from a pybullet_data folder, by default
`../shared/data/robots/pybullet_data` beside the repository; pass `--pybullet-data DIR` to use another copy.
Without one, the copy already in `robots/kuka_iiwa/` is kept.
The build is deterministic: running it twice gives byte-identical files.

## What is in it

A factory cell of about 20 m x 14 m on a 24 m x 16 m floor slab, built for screen-space
ambient occlusion: many concave creases and small details next to large flat areas.

- floor slab (top at z = 0) and a low ribbed back wall (3 m) as a backdrop;
- hall frame: six HEB 300 columns (6 m) with base plates, stiffeners and four anchor
  bolts each, two HEB 400 roof beams -- one mesh each, placed with `instances`;
- an 8 m roller conveyor (80 rollers, diameter 60 mm, 100 mm pitch) with C-channel
  frames, legs and a gear motor -- authored **in millimetres** (`units = "mm"`);
- EUR pallets (1.2 x 0.8 x 0.144 m, one mesh, 10 instances incl. a stack of three empty
  ones) with carton stacks (full and partial) on six of them;
- a welded-mesh safety fence (posts + panels, both instanced) around the robot, open
  where the conveyor enters and at the door;
- a KUKA LBR iiwa (URDF, posed by `joints`) on a steel pedestal;
- a workbench, a machining centre, a control cabinet and six bollards.

## Units and frames

Z is up, world units are metres, the floor's top face is z = 0 and the cell is centred
on the origin. Every mesh except `meshes/conveyor.glb` (millimetres) is in metres; the
manifest's `units` key says which. Part meshes are GLB with crease-angle normals.

## Parts and triangle counts

| part | units | triangles (mesh) | copies drawn | triangles drawn |
|---|---|---|---|---|
{table}

Total drawn: **{total}** triangles (budget 200,000).

## Viewpoints

{views}

## Licences

Everything except `robots/kuka_iiwa/` is generated by this project's script (MIT, like
mrcheck). The robot comes from the pybullet 3.2.7 wheel's `pybullet_data` under the zlib
licence; see `robots/kuka_iiwa/SOURCE.md` and `robots/kuka_iiwa/LICENSE.txt`.
"""


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--pybullet-data",
        type=Path,
        default=DEFAULT_PYBULLET_DATA,
        help="pybullet_data folder to copy the KUKA iiwa from",
    )
    args = parser.parse_args(argv)

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    (OUT_DIR / ".keep").unlink(missing_ok=True)
    robot_dest = OUT_DIR / ROBOT_DIR
    if (args.pybullet_data / "kuka_iiwa" / "model.urdf").is_file():
        copy_robot(args.pybullet_data, robot_dest)
    elif (robot_dest / "model.urdf").is_file():
        print(f"note: {args.pybullet_data} not found; keeping the robot already in {robot_dest}", file=sys.stderr)
    else:
        sys.exit(f"error: no kuka_iiwa/model.urdf under {args.pybullet_data} (use --pybullet-data)")

    mesh_dir = OUT_DIR / "meshes"
    if mesh_dir.exists():
        shutil.rmtree(mesh_dir)  # drop meshes of parts that no longer exist
    mesh_dir.mkdir()

    parts = build_parts()
    rows = []
    for part in parts:
        if part.mesh is not None:
            triangles = write_glb(part.mesh, OUT_DIR / part.mesh_path, part.name)
        else:
            triangles = urdf_triangles(OUT_DIR / part.mesh_path, part.joints or {})
        rows.append((part.name, part.units, triangles, max(len(part.instances), 1)))
    total = sum(triangles * copies for _, _, triangles, copies in rows)

    header = "# Generated by factory_scenes/build_sample_cell.py -- edit that script, not this file."
    (OUT_DIR / "scene.toml").write_text(manifest_text(parts, "sample_cell", DESCRIPTION, VIEWPOINTS, header))
    (OUT_DIR / "README.md").write_text(readme_text(rows, total))

    width = max(len(name) for name, *_ in rows)
    for name, units, triangles, copies in rows:
        print(f"{name:<{width}}  {units:>2}  {triangles:>7,} tri  x{copies:<3} = {triangles * copies:>8,}")
    print(f"{'total':<{width}}  {total:>31,} triangles (incl. instances)")
    if total > MAX_TRIANGLES:
        sys.exit(f"error: {total:,} triangles exceed the budget of {MAX_TRIANGLES:,}")


if __name__ == "__main__":
    main()
