"""``mrcheck scene generate | import | asbuilt | camera | info``."""

from __future__ import annotations

import json
from pathlib import Path

import click

from mrcheck.cli.group import cli
from mrcheck.cli.messages import progress_bar
from mrcheck.cli.options import FINITE, positive


@cli.group()
def scene():
    """Factory scenes: generate, import, as-built variants, inspect.

    \b
    Example:
      mrcheck scene info factory_scenes/sample_cell/scene.toml
    """


@scene.command("generate")
@click.option(
    "--preset",
    type=click.Choice(["cell", "line", "hall"]),
    required=True,
    help="cell: one robot cell; line: a production line with cells and racks; hall: a 200 x 80 x 12 m production hall.",
)
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Same seed, same files (byte for byte)."
)
@click.option(
    "--size-m",
    nargs=3,
    type=FINITE,
    metavar="L W H",
    help="Hall length, width and height in metres [default: the preset's].",
)
@click.option(
    "--target-triangles",
    type=int,
    callback=positive,
    metavar="N",
    help="Triangles as rendered (instances counted), 50 k to 200 M: scales detail and repetition "
    "[default: the preset's].",
)
@click.option(
    "--units-mix",
    is_flag=True,
    help="Write parts in mm, m and inches as CAD exports arrive (declared in the manifest), plus a variant "
    "scene_unit_missing.toml in which one part's unit is not declared.",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["glb", "ifc"]),
    default="glb",
    show_default=True,
    help="glb: scene.toml plus GLB meshes; ifc: the same scene as one IFC4 file, scene.ifc (mapped type "
    "shapes, columns as IfcColumn, racks as IfcFurnishingElement).",
)
@click.option(
    "-o", "--output", "outdir", required=True, metavar="DIR", help="Folder for scene.toml and its meshes (replaced)."
)
def scene_generate(preset, seed, size_m, target_triangles, units_mix, fmt, outdir):
    """Write a procedural factory scene (GLB meshes, or IFC4).

    A manifest plus GLB meshes, with real robots from their URDFs; the same preset and seed
    give the same files, byte for byte. --format ifc writes the same scene as scene.ifc.

    \b
    Examples:
      mrcheck scene generate --preset line --seed 3 -o line3
      mrcheck scene generate --preset hall --target-triangles 5000000 --format ifc -o hall_ifc
    """
    from factory_scenes.generator import generate
    from factory_scenes.generator.ifc import generate_ifc

    if fmt == "ifc" and units_mix:
        raise click.BadParameter("--units-mix writes GLB meshes in mixed units; an IFC file declares one unit")
    write = generate_ifc if fmt == "ifc" else generate
    options = {"units_mix": units_mix} if fmt == "glb" else {}
    print(
        write(
            preset, Path(outdir), seed=seed, size_m=size_m, target_triangles=target_triangles, progress=True, **options
        )
    )


@scene.command("import")
@click.argument("model", metavar="MODEL.ifc|.step|.stp")
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="DIR",
    help="Folder for scene.toml, meshes/ and README.md (an earlier import there is replaced).",
)
@click.option(
    "--coordinates",
    type=click.Choice(["model", "map"]),
    default="model",
    show_default=True,
    help="IFC: keep the model's own coordinates, or place it at its map coordinates (IfcMapConversion, "
    "else the site placement); the scene keeps the offset as its float64 origin.",
)
@click.option(
    "--tolerance-px",
    type=FINITE,
    default=0.5,
    show_default=True,
    callback=positive,
    help="STEP tessellation: chord error in pixels of a 1024-pixel, 60-degree view at --at-distance.",
)
@click.option(
    "--at-distance",
    "distance_m",
    type=FINITE,
    default=2.0,
    show_default=True,
    callback=positive,
    metavar="M",
    help="STEP tessellation: the viewing distance --tolerance-px is stated at (metres).",
)
@click.option("--threads", type=click.IntRange(min=1), help="Geometry threads [default: every core].")
@click.option(
    "--units",
    type=click.Choice(["mm", "cm", "m", "in", "ft"]),
    help="IFC: the unit the file's coordinates are in, instead of the one it declares (metres when it declares "
    "none) [default: as declared].",
)
def scene_import(model, outdir, coordinates, tolerance_px, distance_m, threads, units):
    """Import an IFC or STEP model as a normal mrcheck scene.

    IFC2X3, IFC4, IFC4X3 (IfcOpenShell) and STEP AP203, AP214, AP242 (OpenCascade): one part
    per distinct shape, instances with the GlobalId or assembly path as id. Every command also
    takes the model file itself (imported once, then cached).

    \b
    Examples:
      mrcheck scene import hall.ifc --coordinates map -o hall_scene
      mrcheck scene import conveyor.step --tolerance-px 0.25 -o conveyor_scene
    """
    from mrcheck.scene.importers import ImportSettings
    from mrcheck.scene.importers.cache import import_scene

    settings = ImportSettings(
        coordinates=coordinates, tolerance_px=tolerance_px, distance_m=distance_m, threads=threads, units=units
    )
    result = import_scene(Path(model), Path(outdir), settings, progress_bar)
    click.echo(result.summary(), err=True)
    print(result.manifest)


@scene.command("asbuilt")
@click.argument("scene_path", metavar="SCENE")
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=0,
    show_default=True,
    help="Which perturbations (same seed, same variant).",
)
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="DIR",
    help="Folder for the as-built scene and discrepancies.json.",
)
def scene_asbuilt(scene_path, seed, outdir):
    """Write a perturbed as-built copy of a scene and its changes.

    A copy of a planned scene with objects moved, rotated, missing, added or replaced by
    another size, and discrepancies.json listing every change: ground truth for discrepancy
    checks.

    \b
    Example:
      mrcheck scene asbuilt factory_scenes/sample_cell/scene.toml --seed 2 -o built2
    """
    from mrcheck.scene.asbuilt import make_asbuilt

    for path in make_asbuilt(Path(scene_path), Path(outdir), seed=seed, progress=progress_bar):
        print(path)


@scene.command("camera")
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", required=True, metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option(
    "--intrinsics",
    metavar="CAM.json",
    help="The photo's calibrated camera (size, K, distortion) [default: the viewpoint's own].",
)
@click.option(
    "-o", "--output", required=True, metavar="ROUGH.json", help="Camera JSON (or .yml/.yaml OpenCV YAML) with R and t."
)
def scene_camera(scene_path, view, intrinsics, output):
    """Write a named viewpoint as a camera file.

    The viewpoint's pose with the photo's intrinsics: the rough start of a markerless
    registration (mrcheck register --initial).

    \b
    Example:
      mrcheck scene camera factory_scenes/cell/scene.toml --view overview --intrinsics cam.json -o rough.json
    """
    from mrcheck.mr.edgeshot import scene_camera_command

    print(scene_camera_command(scene_path, view, intrinsics=intrinsics, output=output))


@scene.command("info")
@click.argument("scene_path", metavar="SCENE")
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Machine-readable: triangles, unique_triangles, bounds_m, parts, viewpoints.",
)
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of a single mesh file SCENE.")
def scene_info(scene_path, as_json, units):
    """Parts, units, triangles, bounds and viewpoints of a scene.

    What a planner checks before rendering a CAD export: parts, units, instances, unique and
    instanced triangle counts, bounds in metres, viewpoints.

    \b
    Example:
      mrcheck scene info hall.glb --units mm --json
    """
    from mrcheck.scene.info import describe, format_info

    info = describe(Path(scene_path), units=units)
    print(json.dumps(info, indent=2) if as_json else format_info(info))
