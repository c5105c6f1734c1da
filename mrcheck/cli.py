"""The ``mrcheck`` command line. Commands only; the work lives in the modules.

Exit status: 0 on success; 1 with a one-line ``error: ...`` on stderr when the input is bad
(file, option value, scene), when ``export`` finished but some shots failed, or on an internal
error (a bug: one line too, MRCHECK_DEBUG=1 shows the traceback); 2 for a malformed command
line (an unknown or missing option: click's usage message).
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import click

from .errors import DISPLAY_ERRORS, MrcheckError, bug_reason

EXIT_ERROR = 1

def _mode_choices() -> list[str]:
    from .renderer import MODES  # every render mode (the AO modes register themselves there)

    return [*MODES, "all"]


_MODE_CHOICES = _mode_choices()


class _Finite(click.ParamType):
    """click's float without nan and inf, which its FLOAT accepts: every float option of every
    command is this type, so that no check written as a comparison (``x >= 0``, ``x <= 1``) lets
    a NaN through or takes an infinite radius."""
    name = "float"

    def convert(self, value, param, ctx):
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number", param, ctx)
        return number


FINITE = _Finite()


def _positive(ctx, param, value):
    if value is not None and not value > 0:
        raise click.BadParameter(f"must be positive, got {value}")
    return value


def _size(ctx, param, value):
    from .review.guard import parse_size

    try:
        return parse_size(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def _odd_kernel(ctx, param, value):
    # checked here, not when the blur is built: that is after loading the scene, and never for phong
    from .blur import blur_size_problem   # the maximum is a uniform array's size: see there

    if problem := blur_size_problem(value):
        raise click.BadParameter(problem)
    return value


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mrcheck")
def cli():
    """mrcheck: planned factory CAD rendered from a calibrated camera, with vector-based SSAO
    (Scheer & Keutel), for mixed-reality discrepancy checks."""


@cli.command()
@click.argument("scene", metavar="SCENE")
@click.option("--view", metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option("--camera", "camera_path", metavar="CAM.json|CAM.yml",
              help="Camera JSON (K, size, distortion, world-to-camera R|t, OpenCV convention) or OpenCV YAML with R and t; "
                   "a registered SHOT.json works too.")
@click.option("--mode", type=click.Choice(_MODE_CHOICES), default="vector", show_default=True,
              help="phong = D1 (no AO), vector = D2 (Scheer & Keutel), ssao = D3 (standard SSAO); comparison modes crytek, "
                   "hbao, alchemy (world radius like ssao); all = D1|D2|D3 side by side, labelled.")
@click.option("--width", type=int, callback=_positive,
              help="Image width in pixels [default: the view's or camera's]; one side alone keeps the aspect ratio, "
                   "which a --camera's must keep.")
@click.option("--height", type=int, callback=_positive, help="Image height in pixels [default: the view's or camera's].")
@click.option("--samples", type=int, default=16, show_default=True, callback=_positive,
              help="AO samples per pixel (the paper uses 16, 36, 64, 128).")
@click.option("--radius-px", type=FINITE, callback=_positive,
              help="vector: sampling radius on screen, pixels at the output resolution [default: 2% of the image height].")
@click.option("--radius-fraction", type=FINITE, callback=_positive,
              help="vector: sampling radius as a fraction of the image height, instead of --radius-px [default: 0.02].")
@click.option("--radius", "radius_world", type=FINITE, default=0.2, show_default=True, callback=_positive,
              help="ssao: constant world radius in scene units (metres for parts with declared units).")
@click.option("--min-world-radius", type=FINITE, help="vector: clamp the world sampling radius from below (scene units).")
@click.option("--max-world-radius", type=FINITE, help="vector: clamp the world sampling radius from above (scene units).")
@click.option("--falloff", type=FINITE, default=1.0, show_default=True,
              help="c, the attenuation of o = cos / (1 + c (|v|/r)^2); larger = occlusion falls off faster with distance.")
@click.option("--intensity", type=FINITE, default=1.0, show_default=True,
              help="AO strength: 0 none, 0.5 weak ... 2 strong (the study stepped four levels, weak to strong).")
@click.option("--blur/--no-blur", default=True, show_default=True, help="Depth-aware bilateral blur of the AO buffer.")
@click.option("--blur-size", type=int, default=9, show_default=True, callback=_odd_kernel, help="Blur kernel size, odd, 3 to 255 (the paper uses 9 and 13).")
@click.option("--ao-scale", type=click.Choice(["1", "0.5"]), default="1", show_default=True,
              help="AO resolution: 1 full, 0.5 half resolution with depth-aware upsampling (the paper's 'Half Res.').")
@click.option("--ao-direct", is_flag=True, help="Let AO darken the direct light too (default: the ambient term only).")
@click.option("--light", type=click.Choice(["headlight", "sun"]), default="headlight", show_default=True,
              help="headlight: a light just above the camera; sun: a fixed direction from above.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the AO kernel and rotation tile (renders are reproducible).")
@click.option("--lod-px", type=FINITE, default=0.5, show_default=True,
              help="Level of detail: parts drawn 4+ times and single parts of 50 k+ triangles (robots) use a "
                   "simplified mesh where its measured error stays below this many pixels; 0 draws every part "
                   "at full detail.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]),
              help="Unit of a single mesh file SCENE (a manifest declares units per part); default: as authored.")
@click.option("-o", "--output", required=True, metavar="OUT.png", help="Output image (.png, .jpg, .tif).")
@click.option("--output-ao", metavar="AO.npy",
              help="Also write the AO term alone: .npy float32 (H, W) in [0,1], background 1, or 16-bit grey .png. "
                   "With --mode all, one file per AO mode, named AO_vector.npy, AO_ssao.npy.")
def render(scene, view, camera_path, mode, width, height, samples, radius_px, radius_fraction, radius_world,
           min_world_radius, max_world_radius, falloff, intensity, blur, blur_size, ao_scale, ao_direct, light,
           seed, lod_px, units, output, output_ao):
    """Render SCENE (a .toml manifest or one mesh file) from a named view or a calibrated camera.

    \b
    Examples:
      mrcheck render factory_scenes/sample_cell/scene.toml --view overview --mode all -o study.png
      mrcheck render hall.glb --units mm --camera shot.json --mode vector --no-blur -o v.png --output-ao ao.npy
    """
    from .commands import render_command
    from .renderer import DEFAULT_RADIUS_FRACTION

    if radius_px is not None and radius_fraction is not None:
        raise MrcheckError("give --radius-px or --radius-fraction, not both")
    _warn_unused_options(click.get_current_context(), mode)
    render_command(
        scene=scene, view=view, camera_path=camera_path, mode=mode, width=width, height=height, units=units,
        output=output, output_ao=output_ao,
        settings=dict(samples=samples, radius_px=radius_px, radius_fraction=radius_fraction or DEFAULT_RADIUS_FRACTION,
                      radius_world=radius_world,
                      min_world_radius=min_world_radius, max_world_radius=max_world_radius, falloff=falloff,
                      intensity=intensity, blur=blur, blur_size=blur_size, ao_scale=float(ao_scale),
                      ao_direct=ao_direct, light=light, seed=seed, lod_px=lod_px),
    )


# render options that only some modes read: given for a mode that ignores them, a warning
_AO_MODES = tuple(m for m in _MODE_CHOICES if m not in ("phong", "all"))
_WORLD_RADIUS_MODES = tuple(m for m in _AO_MODES if m != "vector")   # ssao and the comparison modes
_OPTION_MODES = {
    "radius_px": ("vector",), "radius_fraction": ("vector",), "min_world_radius": ("vector",),
    "max_world_radius": ("vector",), "radius_world": _WORLD_RADIUS_MODES, "samples": _AO_MODES,
    "falloff": _AO_MODES, "intensity": _AO_MODES, "blur": _AO_MODES, "blur_size": _AO_MODES,
    "ao_scale": _AO_MODES, "ao_direct": _AO_MODES, "seed": _AO_MODES,
}


def _warn_unused_options(ctx: click.Context, mode: str) -> None:
    """One warning line per option given on the command line that the chosen ``--mode`` (all:
    D1, D2, D3) does not read."""
    from .commands import STUDY_ORDER

    modes = STUDY_ORDER if mode == "all" else (mode,)
    for param in ctx.command.params:
        users = _OPTION_MODES.get(param.name)
        if users and not set(users) & set(modes) and \
                ctx.get_parameter_source(param.name) == click.core.ParameterSource.COMMANDLINE:
            option = "/".join(param.opts[-1:] + param.secondary_opts)  # --blur/--no-blur as one
            click.echo(f"warning: {option} has no effect in mode {'/'.join(modes)} (it applies to {', '.join(users)})",
                       err=True)


@cli.command()
@click.option("-o", "--output", "outdir", default="mrcheck-demo", show_default=True, metavar="DIR",
              help="Folder for the demo images.")
@click.option("--width", type=int, callback=_positive, help="Image width [default: each viewpoint's, 1024].")
@click.option("--height", type=int, callback=_positive, help="Image height [default: each viewpoint's, 768].")
def demo(outdir, width, height):
    """Render the embedded sample factory cell and the generator's shipped cell from each of
    their viewpoints in D1, D2 and D3, write PNGs (one per mode and a labelled side-by-side
    sheet per view; the generated cell's prefixed cell_) and print their paths."""
    from .commands import demo_command

    demo_command(Path(outdir), width, height)


@cli.command()
@click.option("--quick", is_flag=True,
              help="Leave out the sample cell's 1024x768 figures (AO passes, frames, blurs, composites), the 36- and "
                   "128-sample counts and the 10 M-triangle hall, and time 3 rounds instead of 5; every ratio is still "
                   "computed, its verdict indicative.")
@click.option("--json", "json_path", metavar="OUT.json",
              help="Also write every raw figure (with its peak memory) and the ratios (with their per-round ratios) as "
                   "JSON, before the table is printed; missing folders are created, an existing file is replaced.")
@click.option("--repeat", type=int, default=None, callback=_positive, help="Timed runs per figure after one warm-up [default: 5, --quick: 3].")
def bench(quick, json_path, repeat):
    """Measure the AO passes on this machine: every AO mode at full and half resolution, over
    the fetch floor, and its whole frame; the blurs and the composite; AO time at 1 M vs 10 M
    triangles; the geometry pass of the generated hall at 1, 10 and 20 M triangles at both
    sizes; the whole frame on the 1.5 M-triangle line scene against VTK's SSAO and Open3D's
    renderer with AO when they can run (./bootstrap.sh bench installs them). Prints a table of
    what it measured, with each figure's peak memory, and the issue's ratios with their spread
    over the rounds, each against its target.

    The generated halls are cached in the temporary directory ($TMPDIR, else /tmp) under
    mrcheck-bench/ (about 50 MB, made again when the generator changes); the peers' frames, their
    AO-off frames and logs and mrcheck's frame go to mrcheck-bench-peers/ beside it, replaced by
    each run."""
    from .bench import bench_command

    bench_command(quick=quick, json_path=json_path, repeat=repeat)


@cli.group()
def scene():
    """Factory scenes: generate procedural halls, make as-built variants, inspect a scene."""


@scene.command("generate")
@click.option("--preset", type=click.Choice(["cell", "line", "hall"]), required=True,
              help="cell: one robot cell; line: a production line with cells and racks; hall: a 200 x 80 x 12 m production hall.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Same seed, same files (byte for byte).")
@click.option("--size-m", nargs=3, type=FINITE, metavar="L W H", help="Hall length, width and height in metres [default: the preset's].")
@click.option("--target-triangles", type=int, callback=_positive, metavar="N",
              help="Triangles as rendered (instances counted), 50 k to 200 M: scales detail and repetition [default: the preset's].")
@click.option("--units-mix", is_flag=True,
              help="Write parts in mm, m and inches as CAD exports arrive (declared in the manifest), plus a variant "
                   "scene_unit_missing.toml in which one part's unit is not declared.")
@click.option("-o", "--output", "outdir", required=True, metavar="DIR", help="Folder for scene.toml and its meshes (replaced).")
def scene_generate(preset, seed, size_m, target_triangles, units_mix, outdir):
    """Write a procedural factory scene: a manifest plus GLB meshes, with real robots from their URDFs."""
    from factory_scenes.generator import generate

    manifest = generate(preset, Path(outdir), seed=seed, size_m=size_m, target_triangles=target_triangles,
                        units_mix=units_mix, progress=True)
    print(manifest)


@scene.command("asbuilt")
@click.argument("scene_path", metavar="SCENE")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Which perturbations (same seed, same variant).")
@click.option("-o", "--output", "outdir", required=True, metavar="DIR", help="Folder for the as-built scene and discrepancies.json.")
def scene_asbuilt(scene_path, seed, outdir):
    """Write a perturbed copy of a planned scene (objects moved, rotated, missing, added, replaced by
    another size) and discrepancies.json listing every change: ground truth for discrepancy checks."""
    from .asbuilt import make_asbuilt

    for path in make_asbuilt(Path(scene_path), Path(outdir), seed=seed):
        print(path)


@scene.command("info")
@click.argument("scene_path", metavar="SCENE")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable: triangles, unique_triangles, bounds_m, parts, viewpoints.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of a single mesh file SCENE.")
def scene_info(scene_path, as_json, units):
    """What a planner checks before rendering a CAD export: parts, units, instances, unique and
    instanced triangle counts, bounds in metres, viewpoints."""
    from .sceneinfo import describe, format_info

    info = describe(Path(scene_path), units=units)
    print(json.dumps(info, indent=2) if as_json else format_info(info))


@cli.command()
@click.argument("images", nargs=-1, required=True, metavar="IMAGES...")
@click.option("--board", required=True, metavar="SPEC",
              help="chessboard:COLSxROWS:SQUARE (inner corners, square size in metres) or "
                   "charuco:COLSxROWS:SQUARE:MARKER:DICT (squares, sizes in metres, OpenCV dictionary, e.g. DICT_6X6_250).")
@click.option("--min-views", type=int, default=None,
              help="Fewest usable views to calibrate from, at least 3: Zhang's method needs three photos of a flat "
                   "board to determine the camera [default: 5].")
@click.option("--max-view-error", type=FINITE, default=None, callback=_positive, metavar="PX",
              help="Reject views whose RMS reprojection error exceeds this and recalibrate, until every view kept is "
                   "within it [default: 3x the median view error of the first calibration, at least 1 px].")
@click.option("-o", "--output", required=True, metavar="CAM.json",
              help="Camera JSON (K, dist, width, height, rms, per-view errors); .yml/.yaml writes OpenCV FileStorage.")
def calibrate(images, board, min_views, max_view_error, output):
    """Calibrate a camera from photos of a chessboard or ChArUco board (cv2.calibrateCamera)."""
    from .calibration import calibrate_command

    calibrate_command(images=list(images), board=board, output=output, min_views=min_views,
                      max_view_error=max_view_error)


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--photo", required=True, metavar="P", help="The photo to register.")
@click.option("--intrinsics", required=True, metavar="CAM.json", help="Calibrated camera (JSON, or OpenCV YAML).")
@click.option("--markers", metavar="MAP.json", help="Marker map: surveyed world corners of ArUco/AprilTag markers and ChArUco boards.")
@click.option("--points", metavar="CORR.json", help="Manual correspondences: pixel <-> world point pairs (>= 4).")
@click.option("--max-error", type=FINITE, default=None, callback=_positive, metavar="PX",
              help="RANSAC inlier threshold in pixels [default: automatic].")
@click.option("-o", "--output", required=True, metavar="SHOT.json", help="The registered shot (camera JSON + photo, rms, method, ids used/rejected).")
def register(scene_path, photo, intrinsics, markers, points, max_error, output):
    """Find the camera pose of a photo in the factory, from markers or clicked correspondences."""
    from .registration import register_command

    register_command(scene=scene_path, photo=photo, intrinsics=intrinsics, markers=markers, points=points,
                     max_error=max_error, output=output)


@cli.command()
@click.argument("shot", metavar="SHOT.json")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene (manifest or mesh).")
@click.option("--mode", type=click.Choice(_MODE_CHOICES), default="vector", show_default=True,
              help="Shading of the CAD; all = the study's sheet: D1, D2, D3, each virtual and with the photo.")
@click.option("--alpha", type=FINITE, default=0.5, show_default=True, help="Photo opacity, 0 (CAD only) .. 1 (photo only).")
@click.option("--edges", is_flag=True, help="Draw CAD silhouette and crease edges over the photo.")
@click.option("--edge-color", default="ff00ff", show_default=True, metavar="RRGGBB", help="Colour of the CAD edges.")
@click.option("--intensity", type=FINITE, default=1.0, show_default=True, help="AO strength (0 none ... 2 strong).")
@click.option("--samples", type=int, default=16, show_default=True, callback=_positive, help="AO samples per pixel.")
@click.option("-o", "--output", required=True, metavar="OUT.png", help="Output image.")
def overlay(shot, scene_path, mode, alpha, edges, edge_color, intensity, samples, output):
    """Blend the CAD rendered from a registered shot over its photo, lens distortion included."""
    from .overlay import overlay_command

    _warn_unused_options(click.get_current_context(), mode)
    overlay_command(shot=shot, scene=scene_path, mode=mode, alpha=alpha, edges=edges, edge_color=edge_color,
                    intensity=intensity, samples=samples, output=output)


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option("--camera", "camera_path", metavar="CAM.json|CAM.yml",
              help="Camera JSON, or OpenCV YAML with R and t (as render --camera).")
@click.option("--width", type=int, callback=_positive, help="Image width [default: the view's or camera's].")
@click.option("--height", type=int, callback=_positive, help="Image height [default: the view's or camera's].")
@click.option("--rays", type=int, default=256, show_default=True, callback=_positive, help="Cosine-weighted hemisphere rays per pixel.")
@click.option("--radius-mode", type=click.Choice(["world", "screen"]), default="screen", show_default=True,
              help="world: a constant world radius (for ssao and the other world-radius modes); "
                   "screen: the vector method's per-pixel r_S = r_px * Z / f_y.")
@click.option("--radius", "radius_world", type=FINITE, default=None, callback=_positive, help="World radius (scene units) [default: 0.2].")
@click.option("--radius-px", type=FINITE, default=None, callback=_positive, help="Screen radius in pixels [default: 2% of the image height].")
@click.option("--falloff", type=FINITE, default=1.0, show_default=True, help="c of the attenuation 1 / (1 + c (d/r)^2), as in the render modes.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the ray directions.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of a single mesh file SCENE.")
@click.option("-o", "--output", required=True, metavar="REF.npy", help="Reference AO: .npy float32 (H, W), or 16-bit .png (as --output-ao).")
def reference(scene_path, view, camera_path, width, height, rays, radius_mode, radius_world, radius_px, falloff, seed,
              units, output):
    """Ray-traced reference AO (Open3D ray casting) for the pixels of a render, with the same AO
    definition as the method it judges."""
    from .reference import reference_command

    reference_command(scene=scene_path, view=view, camera_path=camera_path, width=width, height=height, rays=rays,
                      radius_mode=radius_mode, radius_world=radius_world, radius_px=radius_px, falloff=falloff,
                      seed=seed, units=units, output=output)


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", required=True, metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option("--samples", type=int, default=16, show_default=True, callback=_positive, help="AO samples per pixel for every mode.")
@click.option("--rays", type=int, default=256, show_default=True, callback=_positive, help="Reference rays per pixel.")
@click.option("--width", type=int, callback=_positive, help="Image width [default: the view's].")
@click.option("--height", type=int, callback=_positive, help="Image height [default: the view's].")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR", help="Folder for the figure, metrics.json and metrics.md.")
def compare(scene_path, view, samples, rays, width, height, outdir):
    """Render every AO mode and its ray-traced reference; write a figure (shaded, AO, signed error
    per mode) and metrics (MAE, RMSE, SSIM, false occlusion, distance retention, pass time)."""
    from .compare import compare_command

    compare_command(scene=scene_path, view=view, samples=samples, rays=rays, width=width, height=height,
                    outdir=outdir)


@cli.command()
@click.argument("job", metavar="JOB.toml")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR", help="Folder for every shot's outputs, manifest.json and report.html.")
@click.option("--workers", type=int, default=1, show_default=True, callback=_positive,
              help="Local worker processes, each with its own EGL context.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run the shots on a Dask distributed cluster (e.g. tcp://10.0.0.5:8786) instead of locally; "
                   "workers load the scene themselves from the path the job names.")
@click.option("--force", is_flag=True, help="Redo shots whose outputs are already complete (default: skip them).")
def export(job, outdir, workers, scheduler, force):
    """Batch overlays for a whole job: register every shot, render the modes, blend the photo at
    every alpha and AO intensity, write side-by-side sheets, a manifest and an HTML report."""
    from .export import export_command

    return export_command(job=job, outdir=outdir, workers=workers, scheduler=scheduler, force=force)


@cli.command()
@click.argument("target", metavar="(JOB.toml | OUTDIR | SCENE)")
@click.option("--shots", "shots_dir", metavar="DIR", help="With SCENE: a folder of registered SHOT.json files.")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to bind; any other than loopback needs a token. Requests must name this server in their "
                   "Host header (localhost, the address; on 0.0.0.0 also the machine's name), else 403.")
@click.option("--port", type=click.IntRange(1, 65535), default=8765, show_default=True, help="Port to listen on.")
@click.option("--token", metavar="TOKEN", help="Require this token (generated and printed when --host is not loopback).")
@click.option("--db", metavar="FILE", help="SQLite file of the review's markers [default: review.sqlite in OUTDIR, "
              "beside JOB.toml, or in DIR for SCENE --shots DIR]; the render cache .review-cache/ goes beside it.")
@click.option("--suggestions", multiple=True, metavar="[NAME=]SUSPECTS.json",
              help="Import the suggested markers of an `mrcheck discrepancies` run (repeatable; NAME picks the shot).")
@click.option("--max-body", default="1MiB", show_default=True, metavar="SIZE", callback=_size,
              help="Refuse request bodies larger than this (413), e.g. 256KiB; at least 64KiB.")
def review(target, shots_dir, host, port, token, db, suggestions, max_body):
    """Review shots in the browser: photo and CAD blended, modes, zoom, discrepancy markers with a
    category, severity and note, the CAD part under the cursor; exports an HTML report and CSV."""
    from .review.app import serve

    serve(target, shots_dir=shots_dir, host=host, port=port, token=token, db=db, suggestions=suggestions,
          max_body=max_body)


@cli.command()
@click.argument("shot", metavar="SHOT.json")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option("--tolerance-px", type=FINITE, default=None, callback=_positive,
              help="How far (px) a photo edge may lie from a CAD edge and still support it [default: automatic].")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="Folder for heatmap.png, suspects.json (ranked parts, for the review tool) and suspects.md.")
def discrepancies(shot, scene_path, tolerance_px, outdir):
    """Point at the CAD parts the photo disagrees with: CAD silhouette and crease edges against the
    photo's edges, per part, with a heat map and a ranked list of suspects."""
    from .discrepancies import discrepancies_command

    discrepancies_command(shot=shot, scene=scene_path, tolerance_px=tolerance_px, outdir=outdir)


@cli.command()
@click.argument("scan", metavar="SCAN")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option("--shot", metavar="SHOT.json", help="Colour the deviations on this shot's render / overlay too.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of the scan's coordinates [default: as the scene, metres].")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR", help="Folder for deviations, the coloured images and the per-part list.")
def deviation(scan, scene_path, shot, units, outdir):
    """Signed cloud-to-mesh distances from a laser scan (PLY, PCD, XYZ) to the planned CAD, per
    point and per part (as CloudCompare's C2M)."""
    from .deviation import deviation_command

    deviation_command(scan=scan, scene=scene_path, shot=shot, units=units, outdir=outdir)


def _name_safe_streams() -> None:
    """File names that are not valid UTF-8 (surrogate escapes) print without UnicodeEncodeError:
    on stdout as their original bytes, as ls and find print them to a pipe (a printed output
    path stays usable by a script); on stderr, where a person reads them, as ``\\xNN``
    (:func:`mrcheck.errors.display`)."""
    for stream, errors in ((sys.stdout, "surrogateescape"), (sys.stderr, DISPLAY_ERRORS)):
        if hasattr(stream, "reconfigure"):   # a TextIOWrapper (not a test's StringIO)
            stream.reconfigure(errors=errors)


def main(argv=None) -> int:
    _name_safe_streams()
    try:
        result = cli.main(args=argv, prog_name="mrcheck", standalone_mode=False)
    except MrcheckError as exc:
        click.echo(f"error: {exc}", err=True)
        return EXIT_ERROR
    except click.MissingParameter as exc:  # a malformed command line: usage and exit 2, below
        exc.show()
        return exc.exit_code
    except click.BadParameter as exc:
        # a bad option value is bad input like a bad file: one line and exit 1, not the usage text
        click.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
        return EXIT_ERROR
    except click.exceptions.Abort:
        click.echo("error: aborted", err=True)
        return EXIT_ERROR
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except KeyboardInterrupt:
        click.echo("error: interrupted", err=True)
        return 130
    except BrokenPipeError:  # the reader went away (`mrcheck ... | head`): nobody to tell, stop quietly
        # and point stdout at /dev/null, or Python's flush at exit reports the broken pipe again
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):   # no file descriptor (a captured stdout)
            pass
        return EXIT_ERROR
    except Exception as exc:  # a bug, not bad input: still one line; the traceback on request
        if os.environ.get("MRCHECK_DEBUG"):
            raise
        click.echo(f"error: internal error, please report it: {bug_reason(exc)} "
                   "(MRCHECK_DEBUG=1 shows the traceback)", err=True)
        return EXIT_ERROR
    # a command may return its own exit status (export: 1 when any shot failed)
    return result if isinstance(result, int) else 0


if __name__ == "__main__":
    sys.exit(main())
