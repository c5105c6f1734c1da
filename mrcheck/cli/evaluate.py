"""``mrcheck reference``, ``mrcheck compare`` and ``mrcheck bench``: judging the rendering."""

from __future__ import annotations

import click

from mrcheck.cli.group import cli
from mrcheck.cli.options import FINITE, positive
from mrcheck.render import settings as defaults


@cli.command()
@click.option(
    "--quick",
    is_flag=True,
    help="Leave out the sample cell's 1024x768 figures (AO passes, frames, blurs, composites), the 36- and "
    "128-sample counts and the 10 M-triangle hall, and time 3 rounds instead of 5; every ratio is still "
    "computed, its verdict indicative.",
)
@click.option(
    "--json",
    "json_path",
    metavar="OUT.json",
    help="Also write every raw figure (with its peak memory) and the ratios (with their per-round ratios) as "
    "JSON (with --track: every run), before the table is printed; missing folders are created, an "
    "existing file is replaced.",
)
@click.option(
    "--repeat",
    type=int,
    default=None,
    callback=positive,
    help="Timed runs per figure after one warm-up [default: 5, --quick: 3].",
)
@click.option(
    "--edges",
    is_flag=True,
    help="Only the edge registration against OpenCV's RAPID tracker (cv2.rapid) on Open3D photos of the "
    "crate scene and the generated cell: accuracy and time side by side (--quick: 3 cases each, else 10).",
)
@click.option(
    "--track",
    is_flag=True,
    help="Only `mrcheck track` on walk videos made here (Open3D photos, 640x480): the cell's robot_cell and "
    "overview views walked three ways and the crates, 24 frames each, --repeat rounds [default: 3] "
    "(--quick: two walks of 12 frames, one round): frames/s, the first frame's seconds, the errors "
    "against the true path.",
)
@click.option(
    "--outline",
    is_flag=True,
    help="With --track: the walks tracked with `mrcheck track --outline` (the parts' outlines fitted too).",
)
@click.option(
    "--real",
    is_flag=True,
    help="Only the markerless registration (against cv2.rapid, same starts) and `track` on the shared real data "
    "(../shared/data/real: LM-O, M3T, the box and tea box videos; each set absent is skipped, saying so), "
    "photo 000819 of LM-O held out and reported apart; see docs/real-data.md (--quick: a few starts and 5 "
    "frames of the tea box).",
)
@click.option(
    "--accumulate",
    is_flag=True,
    help="Only progressive AO (--accumulate N) on the generated hall's aisle view (5 M triangles, 640x480; "
    "--quick: 320x240, fewer rays): 1 to 16 frames against the converged render and the ray-traced "
    "references, seconds per render; see docs/rendering.md.",
)
def bench(quick, json_path, repeat, edges, track, outline, real, accumulate):
    """Measure the AO passes and frames on this machine.

    Every AO mode at full and half resolution, over
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
      mrcheck bench --track --json track.json
      mrcheck bench --track --outline --repeat 1
      mrcheck bench --real --json real.json
      mrcheck bench --accumulate --quick
    """
    if edges + track + real + accumulate > 1:
        raise click.UsageError("--edges, --track, --real and --accumulate are separate benches: give one of them")
    if outline and not track:
        raise click.UsageError("--outline goes with --track (the walks tracked with `track --outline`)")
    if accumulate:
        _accumulate_bench(quick, json_path)
        return
    if real:
        from mrcheck.eval.realbench import real_bench, summary_lines

        result = real_bench(quick=quick, json_path=json_path, progress=lambda text: click.echo(text, err=True))
        for line in summary_lines(result):
            click.echo(line)
        return
    if track:
        _track_bench(quick, repeat, json_path, outline)
        return
    if edges:
        from mrcheck.eval.edgebench import edge_bench

        for line in edge_bench(quick=quick, progress=lambda text: click.echo(text, err=True)):
            click.echo(line)
        return
    from mrcheck.eval.bench.run import bench_command

    result = bench_command(
        quick=quick, json_path=json_path, repeat=repeat, hall=_hall_generator(), progress=_progress_bar()
    )
    click.echo(result.text)
    if result.json_path is not None:
        click.echo(result.json_path)


def _accumulate_bench(quick, json_path) -> None:
    from mrcheck.eval.accbench import FULL, QUICK, accumulate_bench, table_lines
    from mrcheck.eval.bench.figures import HALL_SEED, HALL_VIEW
    from mrcheck.eval.bench.scenes import hall_scene_path

    triangles = 5_000_000  # the hall preset's own budget (mrcheck scene generate --preset hall)
    click.echo(f"generating or reusing the {triangles / 1e6:g} M-triangle hall ...", err=True)
    scene = hall_scene_path(_hall_generator(), triangles, HALL_SEED)
    size = QUICK if quick else FULL
    rows = accumulate_bench(scene, HALL_VIEW, size, json_path=json_path, progress=lambda t: click.echo(t, err=True))
    for line in table_lines(rows, f"hall {HALL_VIEW} {size.width}x{size.height}"):
        click.echo(line)


def _track_bench(quick, repeat, json_path, outline) -> None:
    from mrcheck.eval.trackbench import track_bench

    _, lines = track_bench(
        quick=quick, rounds=repeat, json_path=json_path, progress=_progress_bar("frame"), outline=outline
    )
    for line in lines:
        click.echo(line)


def _hall_generator():
    """The bench's halls come from the factory_scenes generator, which only the CLI imports."""
    from pathlib import Path

    import factory_scenes.generator as generator
    from factory_scenes.generator.ifc import write_ifc
    from mrcheck.eval.bench.scenes import HallGenerator

    return HallGenerator(generator.generate, Path(generator.__file__).parent, write_ifc)


def _progress_bar(unit: str = "figure"):
    """The bench's progress as a tqdm bar on stderr: (how many ``unit`` done, planned, the last label)."""
    import sys

    from tqdm import tqdm

    bar = None

    def progress(done: int, total: int, label: str) -> None:
        nonlocal bar
        if bar is None:
            bar = tqdm(total=total, desc="bench", unit=unit, file=sys.stderr)
        bar.total = total
        if label:
            bar.set_postfix_str(label, refresh=False)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()

    return progress


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option(
    "--camera",
    "camera_path",
    metavar="CAM.json|CAM.yml",
    help="Camera JSON, or OpenCV YAML with R and t (as render --camera).",
)
@click.option("--width", type=int, callback=positive, help="Image width [default: the view's or camera's].")
@click.option("--height", type=int, callback=positive, help="Image height [default: the view's or camera's].")
@click.option(
    "--rays",
    type=int,
    default=256,
    show_default=True,
    callback=positive,
    help="Cosine-weighted hemisphere rays per pixel.",
)
@click.option(
    "--radius-mode",
    type=click.Choice(["world", "screen"]),
    default="screen",
    show_default=True,
    help="world: a constant world radius (for ssao and the other world-radius modes); "
    "screen: the vector method's per-pixel r_S = r_px * Z / f_y.",
)
@click.option(
    "--radius",
    "radius_world",
    type=FINITE,
    default=None,
    callback=positive,
    help=f"World radius (scene units) [default: {defaults.DEFAULT_RADIUS_WORLD}].",
)
@click.option(
    "--radius-px",
    type=FINITE,
    default=None,
    callback=positive,
    help=f"Screen radius in pixels [default: {defaults.DEFAULT_RADIUS_FRACTION:.0%} of the image height].",
)
@click.option(
    "--falloff",
    type=FINITE,
    default=defaults.DEFAULT_FALLOFF,
    show_default=True,
    help="c of the attenuation 1 / (1 + c (d/r)^2), as in the render modes.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed of the ray directions.")
@click.option("--units", type=click.Choice(["mm", "cm", "m", "in", "ft"]), help="Unit of a single mesh file SCENE.")
@click.option(
    "-o",
    "--output",
    required=True,
    metavar="REF.npy",
    help="Reference AO: .npy float32 (H, W), or 16-bit .png (as --output-ao).",
)
def reference(
    scene_path,
    view,
    camera_path,
    width,
    height,
    rays,
    radius_mode,
    radius_world,
    radius_px,
    falloff,
    seed,
    units,
    output,
):
    """Ray-traced reference AO for the pixels of a render.

    Open3D ray casting, with the same AO definition as the method it judges.

    \b
    Example:
      mrcheck reference factory_scenes/sample_cell/scene.toml --view overview --width 256 -o ref.npy
    """
    from mrcheck.cli.messages import progress_bars
    from mrcheck.eval.reference import PROGRESS_STAGE, reference_command

    with progress_bars({PROGRESS_STAGE: "ray"}) as progress:
        run = reference_command(
            scene=scene_path,
            view=view,
            camera_path=camera_path,
            width=width,
            height=height,
            rays=rays,
            radius_mode=radius_mode,
            radius_world=radius_world,
            radius_px=radius_px,
            falloff=falloff,
            seed=seed,
            units=units,
            output=output,
            progress=progress,
        )
    click.echo(run.path)
    click.echo(run.timing_line(), err=True)  # stdout carries only the path, as the other commands'


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--view", required=True, metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option(
    "--samples",
    type=int,
    default=defaults.DEFAULT_SAMPLES,
    show_default=True,
    callback=positive,
    help="AO samples per pixel for every mode.",
)
@click.option("--rays", type=int, default=256, show_default=True, callback=positive, help="Reference rays per pixel.")
@click.option("--width", type=int, callback=positive, help="Image width [default: the view's].")
@click.option("--height", type=int, callback=positive, help="Image height [default: the view's].")
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="OUTDIR",
    help="Folder for the figure, metrics.json and metrics.md.",
)
def compare(scene_path, view, samples, rays, width, height, outdir):
    """Every AO mode against its ray-traced reference, with metrics.

    Render every AO mode and its ray-traced reference; write a figure (shaded, AO, signed error
    per mode) and metrics (MAE, RMSE, SSIM, false occlusion, distance retention, pass time).

    \b
    Example:
      mrcheck compare factory_scenes/sample_cell/scene.toml --view overview --width 320 -o cmp
    """
    from mrcheck.cli.messages import progress_bars
    from mrcheck.eval import compare as comparison
    from mrcheck.eval.reference import PROGRESS_STAGE as REFERENCE_STAGE

    with progress_bars({comparison.PROGRESS_STAGE: "mode", REFERENCE_STAGE: "ray"}) as progress:
        run = comparison.compare_command(
            scene=scene_path,
            view=view,
            samples=samples,
            rays=rays,
            width=width,
            height=height,
            outdir=outdir,
            progress=progress,
        )
    for path in run.paths:
        click.echo(path)
    for line in run.table():
        click.echo(line)
