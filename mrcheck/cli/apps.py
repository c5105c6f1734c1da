"""``mrcheck export``, ``review``, ``discrepancies`` and ``deviation``."""

from __future__ import annotations

import sys

import click

from mrcheck.cli.group import cli, pixel_count
from mrcheck.cli.messages import ProgressStream, console
from mrcheck.cli.options import FINITE, accumulate_option, positive, size
from mrcheck.render import settings as defaults

AUTHOR = click.option(
    "--author", metavar="NAME", help="Author of the BCF topics and comments written [default: the OS user]."
)


@cli.command()
@click.argument("job", metavar="JOB.toml")
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="OUTDIR",
    help="Folder for every shot's outputs, manifest.json and report.html.",
)
@click.option(
    "--workers",
    type=int,
    default=1,
    show_default=True,
    callback=positive,
    help="Local worker processes, each with its own EGL context.",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    help="Run the shots on a Dask distributed cluster (e.g. tcp://10.0.0.5:8786) instead of locally; "
    "workers load the scene themselves from the path the job names.",
)
@click.option("--force", is_flag=True, help="Redo shots whose outputs are already complete (default: skip them).")
@click.option(
    "--antialias/--no-antialias",
    default=None,
    help="Anti-aliased renders (4x MSAA) [default: the job's `antialias` key, true]; part of the "
    "shots' fingerprints, so a change redoes them.",
)
@accumulate_option(default=None)
def export(job, outdir, workers, scheduler, force, antialias, accumulate):
    """Batch overlays, sheets, manifest and report for a whole job.

    Register every shot of JOB.toml, render the modes, blend the photo at every alpha and AO
    intensity, write side-by-side sheets, a manifest and an HTML report.

    \b
    Example:
      mrcheck export job.toml -o out --workers 2
    """
    from mrcheck.apps.export.run import run_export

    bar = _ExportBar()
    try:
        with console():
            result = run_export(
                job=job,
                outdir=outdir,
                workers=workers,
                scheduler=scheduler,
                force=force,
                progress=bar,
                antialias=antialias,
                accumulate=accumulate,
            )
    finally:
        bar.close()
    for line in result.summary():
        click.echo(line)
    return 1 if result.failed else 0


class _ExportBar:
    """The export's progress on stderr: a bar on a terminal; in a pipe or log file one line per
    shot (count, name, status, ETA) instead of the bar's \\r frames."""

    def __init__(self):
        self.stream, self.bar = ProgressStream(sys.stderr), None

    def __call__(self, step) -> None:
        if self.bar is None:  # the start: the skipped shots are done already
            from tqdm import tqdm

            # disable=None: a bar on a terminal only
            self.bar = tqdm(
                total=step.total,
                initial=step.done,
                desc="export",
                unit="shot",
                file=self.stream,
                dynamic_ncols=True,
                disable=None,
            )
            return
        self.bar.update(1)
        if self.bar.disable:
            self.stream.write(
                f"export: {step.done}/{step.total} shots, {step.name} {step.status}, ETA {step.eta_s:.0f} s\n"
            )
        if step.failed:
            self.bar.set_postfix(failed=step.failed)
        if step.done == step.total:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@cli.command()
@click.argument("target", metavar="(JOB.toml | OUTDIR | SCENE)")
@click.option("--shots", "shots_dir", metavar="DIR", help="With SCENE: a folder of registered SHOT.json files.")
@click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address to bind; any other than loopback needs a token. Requests must name this server in their "
    "Host header (localhost, the address; on 0.0.0.0 also the machine's name), else 403.",
)
@click.option("--port", type=click.IntRange(1, 65535), default=8765, show_default=True, help="Port to listen on.")
@click.option(
    "--token", metavar="TOKEN", help="Require this token (generated and printed when --host is not loopback)."
)
@click.option(
    "--db",
    metavar="FILE",
    help="SQLite file of the review's markers [default: review.sqlite in OUTDIR, "
    "beside JOB.toml, or in DIR for SCENE --shots DIR]; the render cache .review-cache/ goes beside it.",
)
@click.option(
    "--suggestions",
    multiple=True,
    metavar="[NAME=]SUSPECTS.json",
    help="Import the suggested markers of an `mrcheck discrepancies` run (repeatable; NAME picks the shot).",
)
@click.option(
    "--max-body",
    default="1MiB",
    show_default=True,
    metavar="SIZE",
    callback=size,
    help="Refuse request bodies larger than this (413), e.g. 256KiB; at least 64KiB.",
)
@click.option(
    "--max-upload",
    default="64MiB",
    show_default=True,
    metavar="SIZE",
    callback=size,
    help='Refuse photos and camera files uploaded by "Add photo", and BCF files imported, larger than this (413).',
)
@click.option(
    "--max-pixels",
    default="64MP",
    show_default=True,
    metavar="PIXELS",
    callback=lambda ctx, param, value: pixel_count(value),
    help="Refuse photos of more pixels than this, from their header before decoding (e.g. 100MP).",
)
@click.option(
    "--antialias/--no-antialias",
    default=True,
    show_default=True,
    help="Anti-aliased CAD renders (4x MSAA; --no-antialias: about 1.3-1.5x faster).",
)
@AUTHOR
@accumulate_option(default=defaults.REST_ACCUMULATE, what="Navigate, a view at rest")
@click.option(
    "--tls-cert",
    metavar="CERT.pem",
    help="Serve HTTPS with this certificate (PEM; a chain, the server's first), with --tls-key. A tablet's "
    "browser gives the page its camera only over HTTPS.",
)
@click.option("--tls-key", metavar="KEY.pem", help="The private key of --tls-cert (PEM, without a passphrase).")
@click.option(
    "--marker-map",
    metavar="MAP.json",
    help="The markers in the hall (the marker map of `register --markers`): Live can start from the markers in view.",
)
@click.option(
    "--self-signed",
    is_flag=True,
    help="Serve HTTPS with a certificate made for this machine, kept in review-tls/ beside the database and "
    "reused while it is valid; prints the file to trust on the tablet and how.",
)
@click.option(
    "--live-intrinsics",
    metavar="CAM.json",
    help="Live tracks with this camera's intrinsics (camera JSON or OpenCV YAML, with distortion; the page "
    "sends frames at its size) and each shot's pose [default: the camera the page's Calibrate saved in "
    "review-camera/ beside the database, else each shot's own].",
)
@click.option(
    "--board",
    metavar="SPEC",
    help="The board the page's Calibrate looks for, as mrcheck calibrate's --board: chessboard:COLSxROWS:SQUARE "
    "(inner corners) or charuco:COLSxROWS:SQUARE:MARKER:DICT [default: the page asks].",
)
def review(
    target,
    shots_dir,
    host,
    port,
    token,
    db,
    suggestions,
    max_body,
    max_upload,
    max_pixels,
    antialias,
    author,
    accumulate,
    tls_cert,
    tls_key,
    marker_map,
    self_signed,
    live_intrinsics,
    board,
):
    """Review shots in the browser and mark discrepancies.

    Photo and CAD blended, modes, zoom, discrepancy markers with a category, severity and note,
    the CAD part under the cursor; exports an HTML report and CSV. "Add photo" registers a new
    photo by clicking 4+ points on it and on the CAD, and saves it as a shot. "Navigate" moves
    through the CAD from a shot's pose (the server renders every view; --accumulate: the AO frames
    of a view at rest). --self-signed or --tls-cert serve it over HTTPS, which a tablet's camera
    needs. "Live" checks through the device's camera; "Calibrate" calibrates that camera from a
    chessboard held in front of it (--board) and Live then uses it (or --live-intrinsics).

    \b
    Example:
      mrcheck review out --suggestions p1=suspects/suspects.json
      mrcheck review out --host 0.0.0.0 --self-signed
      mrcheck review out --host 0.0.0.0 --self-signed --board chessboard:9x6:0.025
      mrcheck review out --host 0.0.0.0 --self-signed --live-intrinsics tablet.json
    """
    from mrcheck.apps.review.server import start
    from mrcheck.apps.review.tls import TlsOptions

    with console():  # skipped shots and registration warnings at start-up, internal errors while serving
        server = start(
            target,
            shots_dir=shots_dir,
            host=host,
            port=port,
            token=token,
            db=db,
            suggestions=suggestions,
            max_body=max_body,
            max_upload=max_upload,
            antialias=antialias,
            max_pixels=max_pixels,
            author=author,
            accumulate=accumulate,
            tls=TlsOptions(tls_cert, tls_key, self_signed),
            marker_map=marker_map,
            live_intrinsics=live_intrinsics,
            board=board,
        )
        try:
            for line in server.messages():
                click.echo(line)
        except BaseException:
            server.close()
            raise
        server.run()


@cli.command()
@click.argument("shot", metavar="SHOT.json")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option(
    "--tolerance-px",
    type=FINITE,
    default=None,
    callback=positive,
    help="How far (px) a photo edge may lie from a CAD edge and still support it [default: automatic].",
)
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="OUTDIR",
    help="Folder for heatmap.png, suspects.json (ranked parts, for the review tool), suspects.md and "
    "suspects.bcfzip (BCF 2.1).",
)
@AUTHOR
def discrepancies(shot, scene_path, tolerance_px, outdir, author):
    """Rank the CAD parts the photo disagrees with, with a heat map.

    CAD silhouette and crease edges against the photo's edges, per part, with a heat map and a
    ranked list of suspects.

    \b
    Example:
      mrcheck discrepancies p1.json --scene hall/scene.toml -o suspects
    """
    from mrcheck.apps.bcf import default_author
    from mrcheck.apps.discrepancies.command import discrepancies_command

    with console():
        run = discrepancies_command(
            shot=shot, scene=scene_path, tolerance_px=tolerance_px, outdir=outdir, author=author or default_author()
        )
    click.echo(run.summary)
    for path in run.paths:
        click.echo(path)


@cli.command()
@click.argument("scan", metavar="SCAN")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option("--shot", metavar="SHOT.json", help="Colour the deviations on this shot's render / overlay too.")
@click.option(
    "--units",
    type=click.Choice(["mm", "cm", "m", "in", "ft"]),
    help="Unit of the scan's coordinates [default: the unit of a LAS/LAZ file's CRS, else metres].",
)
@click.option(
    "--per-element",
    is_flag=True,
    help="Also a status per CAD instance (installed, out of tolerance, not found, not enough data, occluded; "
    "not found needs an E57 scan's scanner positions): elements.csv, elements.json, elements.png and "
    "elements.bcfzip (BCF 2.1).",
)
@click.option(
    "--tolerance-mm",
    type=FINITE,
    default=20.0,
    show_default=True,
    callback=positive,
    help="With --per-element: how far (mm) an element may be off and still be in tolerance.",
)
@click.option(
    "--search-mm",
    type=FINITE,
    default=100.0,
    show_default=True,
    callback=positive,
    help="With --per-element: scan points farther (mm) from every CAD surface are clutter.",
)
@click.option(
    "-o",
    "--output",
    "outdir",
    required=True,
    metavar="OUTDIR",
    help="Folder for deviations, the coloured images and the per-part list.",
)
@AUTHOR
def deviation(scan, scene_path, shot, units, per_element, tolerance_mm, search_mm, outdir, author):
    """Signed distances from a laser scan to the planned CAD.

    Signed cloud-to-mesh distances from a laser scan (E57 with every scan's pose, LAS/LAZ at
    map coordinates, PLY, PCD, XYZ) to the planned CAD, per point and per part (as
    CloudCompare's C2M); with --per-element a tolerance status per element (docs/discrepancies.md).

    \b
    Example:
      mrcheck deviation hall.e57 --scene hall/scene.toml --shot p1.json -o deviation
      mrcheck deviation hall.e57 --scene hall/scene.toml --per-element --tolerance-mm 10 -o deviation
    """
    from mrcheck.apps.bcf import default_author
    from mrcheck.apps.deviation.command import PerElement, deviation_command

    settings = PerElement(tolerance_mm, search_mm, author or default_author()) if per_element else None
    with console():
        run = deviation_command(
            scan=scan, scene=scene_path, shot=shot, units=units, outdir=outdir, per_element=settings
        )
    click.echo(run.outdir)
    click.echo(run.summary, err=True)


@cli.command()
@click.argument("video", metavar="VIDEO")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene.")
@click.option(
    "--intrinsics", required=True, metavar="CAM.json", help="The video camera's calibration (JSON, or OpenCV YAML)."
)
@click.option(
    "--initial", required=True, metavar="ROUGH.json", help="The first frame's rough pose (camera JSON with R and t)."
)
@click.option(
    "--poses",
    metavar="POSES.jsonl",
    help="Per-frame pose, RMS, support, uncertainty, lost flag [default: OUT.poses.jsonl].",
)
@click.option(
    "--alpha", type=FINITE, default=0.5, show_default=True, help="Photo opacity in the overlay, 0 (CAD only) .. 1."
)
@click.option(
    "--outline",
    is_flag=True,
    help="Also fit the parts' outlines, matched by their colour regions, on every frame: can hold a few "
    "objects filmed in colour where the edges alone slide off; fails in dense scenes of many parts "
    "(docs/edge-registration.md).",
)
@click.option(
    "-o", "--output", required=True, metavar="OUT.mp4", help="The overlay video (vector AO at half resolution)."
)
def track(video, scene_path, intrinsics, initial, poses, alpha, outline, output):
    """Snap the CAD onto every frame of a video.

    Each frame starts from the previous frames' constant-velocity prediction and is snapped onto
    its edges; writes the overlay video and the poses. Frames whose support collapses are marked
    lost (docs/edge-registration.md).

    \b
    Example:
      mrcheck track walk.mp4 --scene hall/scene.toml --intrinsics cam.json --initial rough.json -o walk_overlay.mp4
      mrcheck track box.mp4 --scene box/scene.toml --intrinsics cam.json --initial shot.json --outline -o box_out.mp4
    """
    from mrcheck.apps.track import track_command
    from mrcheck.cli.messages import progress_bars

    with console(), progress_bars({"track": "frame"}) as bars:
        result = track_command(
            video,
            scene_path,
            intrinsics,
            initial,
            output,
            poses=poses,
            alpha=alpha,
            progress=lambda done, total: bars("track", done, max(total, done)),
            outline=outline,
        )
    click.echo(result.summary_line())
    click.echo(result.stage_line())
    for line in result.lost_lines():
        click.echo(line)
    click.echo(f"wrote {output}")
