"""``mrcheck reference``, ``mrcheck compare`` and ``mrcheck bench``: judging the rendering."""

from __future__ import annotations

import click

from mrcheck.cli.group import cli
from mrcheck.cli.options import FINITE, positive


@cli.command()
@click.option("--quick", is_flag=True,
              help="Leave out the sample cell's 1024x768 figures (AO passes, frames, blurs, composites), the 36- and "
                   "128-sample counts and the 10 M-triangle hall, and time 3 rounds instead of 5; every ratio is still "
                   "computed, its verdict indicative.")
@click.option("--json", "json_path", metavar="OUT.json",
              help="Also write every raw figure (with its peak memory) and the ratios (with their per-round ratios) as "
                   "JSON, before the table is printed; missing folders are created, an existing file is replaced.")
@click.option("--repeat", type=int, default=None, callback=positive, help="Timed runs per figure after one warm-up [default: 5, --quick: 3].")
@click.option("--edges", is_flag=True,
              help="Only the edge registration against OpenCV's RAPID tracker (cv2.rapid) on Open3D photos of the "
                   "crate scene and the generated cell: accuracy and time side by side (--quick: 3 cases each, else 10).")
def bench(quick, json_path, repeat, edges):
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
    each run.

    \b
    Example:
      mrcheck bench --quick --json bench.json
      mrcheck bench --edges --quick
    """
    if edges:
        from mrcheck.eval.edgebench import edge_bench

        for line in edge_bench(quick=quick, progress=lambda text: click.echo(text, err=True)):
            click.echo(line)
        return
    from mrcheck.eval.bench.run import bench_command

    bench_command(quick=quick, json_path=json_path, repeat=repeat)


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option("--camera", "camera_path", metavar="CAM.json|CAM.yml",
              help="Camera JSON, or OpenCV YAML with R and t (as render --camera).")
@click.option("--width", type=int, callback=positive, help="Image width [default: the view's or camera's].")
@click.option("--height", type=int, callback=positive, help="Image height [default: the view's or camera's].")
@click.option("--rays", type=int, default=256, show_default=True, callback=positive, help="Cosine-weighted hemisphere rays per pixel.")
@click.option("--radius-mode", type=click.Choice(["world", "screen"]), default="screen", show_default=True,
              help="world: a constant world radius (for ssao and the other world-radius modes); "
                   "screen: the vector method's per-pixel r_S = r_px * Z / f_y.")
@click.option("--radius", "radius_world", type=FINITE, default=None, callback=positive, help="World radius (scene units) [default: 0.2].")
@click.option("--radius-px", type=FINITE, default=None, callback=positive, help="Screen radius in pixels [default: 2% of the image height].")
@click.option("--falloff", type=FINITE, default=1.0, show_default=True, help="c of the attenuation 1 / (1 + c (d/r)^2), as in the render modes.")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the ray directions.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of a single mesh file SCENE.")
@click.option("-o", "--output", required=True, metavar="REF.npy", help="Reference AO: .npy float32 (H, W), or 16-bit .png (as --output-ao).")
def reference(scene_path, view, camera_path, width, height, rays, radius_mode, radius_world, radius_px, falloff, seed,
              units, output):
    """Ray-traced reference AO (Open3D ray casting) for the pixels of a render, with the same AO
    definition as the method it judges."""
    from mrcheck.eval.reference import reference_command

    reference_command(scene=scene_path, view=view, camera_path=camera_path, width=width, height=height, rays=rays,
                      radius_mode=radius_mode, radius_world=radius_world, radius_px=radius_px, falloff=falloff,
                      seed=seed, units=units, output=output)


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", required=True, metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option("--samples", type=int, default=16, show_default=True, callback=positive, help="AO samples per pixel for every mode.")
@click.option("--rays", type=int, default=256, show_default=True, callback=positive, help="Reference rays per pixel.")
@click.option("--width", type=int, callback=positive, help="Image width [default: the view's].")
@click.option("--height", type=int, callback=positive, help="Image height [default: the view's].")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR", help="Folder for the figure, metrics.json and metrics.md.")
def compare(scene_path, view, samples, rays, width, height, outdir):
    """Render every AO mode and its ray-traced reference; write a figure (shaded, AO, signed error
    per mode) and metrics (MAE, RMSE, SSIM, false occlusion, distance retention, pass time)."""
    from mrcheck.eval.compare import compare_command

    compare_command(scene=scene_path, view=view, samples=samples, rays=rays, width=width, height=height,
                    outdir=outdir)
