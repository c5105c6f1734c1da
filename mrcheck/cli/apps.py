"""``mrcheck export``, ``review``, ``discrepancies`` and ``deviation``."""

from __future__ import annotations

import click

from mrcheck.cli.group import cli
from mrcheck.cli.options import FINITE, positive, size


@cli.command()
@click.argument("job", metavar="JOB.toml")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR", help="Folder for every shot's outputs, manifest.json and report.html.")
@click.option("--workers", type=int, default=1, show_default=True, callback=positive,
              help="Local worker processes, each with its own EGL context.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run the shots on a Dask distributed cluster (e.g. tcp://10.0.0.5:8786) instead of locally; "
                   "workers load the scene themselves from the path the job names.")
@click.option("--force", is_flag=True, help="Redo shots whose outputs are already complete (default: skip them).")
def export(job, outdir, workers, scheduler, force):
    """Batch overlays for a whole job: register every shot, render the modes, blend the photo at
    every alpha and AO intensity, write side-by-side sheets, a manifest and an HTML report."""
    from mrcheck.apps.export.run import export_command

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
@click.option("--max-body", default="1MiB", show_default=True, metavar="SIZE", callback=size,
              help="Refuse request bodies larger than this (413), e.g. 256KiB; at least 64KiB.")
def review(target, shots_dir, host, port, token, db, suggestions, max_body):
    """Review shots in the browser: photo and CAD blended, modes, zoom, discrepancy markers with a
    category, severity and note, the CAD part under the cursor; exports an HTML report and CSV."""
    from mrcheck.apps.review.app import serve

    serve(target, shots_dir=shots_dir, host=host, port=port, token=token, db=db, suggestions=suggestions,
          max_body=max_body)


@cli.command()
@click.argument("shot", metavar="SHOT.json")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option("--tolerance-px", type=FINITE, default=None, callback=positive,
              help="How far (px) a photo edge may lie from a CAD edge and still support it [default: automatic].")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="Folder for heatmap.png, suspects.json (ranked parts, for the review tool) and suspects.md.")
def discrepancies(shot, scene_path, tolerance_px, outdir):
    """Point at the CAD parts the photo disagrees with: CAD silhouette and crease edges against the
    photo's edges, per part, with a heat map and a ranked list of suspects."""
    from mrcheck.apps.discrepancies.detector import discrepancies_command

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
    from mrcheck.apps.deviation import deviation_command

    deviation_command(scan=scan, scene=scene_path, shot=shot, units=units, outdir=outdir)


@cli.command()
@click.argument("video", metavar="VIDEO")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option("--intrinsics", required=True, metavar="CAM.json", help="The video camera's calibration (JSON, or OpenCV YAML).")
@click.option("--initial", required=True, metavar="ROUGH.json", help="The first frame's rough pose (camera JSON with R and t).")
@click.option("--poses", metavar="POSES.jsonl", help="Per-frame poses, RMS, support, uncertainty, lost flag [default: OUT.poses.jsonl].")
@click.option("--alpha", type=FINITE, default=0.5, show_default=True, help="Photo opacity in the overlay, 0 (CAD only) .. 1.")
@click.option("-o", "--output", required=True, metavar="OUT.mp4", help="The overlay video (vector AO, half-resolution AO).")
def track(video, scene_path, intrinsics, initial, poses, alpha, output):
    """Snap the CAD onto every frame of a video (each frame from the previous ones' constant-velocity
    prediction), write the overlay video and the poses; frames whose support collapses are marked lost.

    \b
    Example:
      mrcheck track walk.mp4 --scene hall/scene.toml --intrinsics cam.json --initial rough.json -o walk_overlay.mp4
    """
    from tqdm import tqdm

    from mrcheck.apps.track import track_command

    with tqdm(unit="frame", desc="track", leave=False) as bar:
        def progress(done, total):
            bar.total = total or None
            bar.update(done - bar.n)

        result = track_command(video, scene_path, intrinsics, initial, output, poses=poses, alpha=alpha,
                               progress=progress)
    click.echo(f"tracked {len(result.frames)} frames in {result.seconds:.1f} s ({result.fps:.2f} frames/s); "
               f"lost: {', '.join(map(str, result.lost)) or 'none'}")
    for frame in result.frames:
        if frame.lost:
            click.echo(f"  frame {frame.frame} lost ({frame.reason}): its pose is the prediction, not trusted")
    click.echo(f"wrote {output}")
