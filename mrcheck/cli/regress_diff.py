"""``mrcheck regress diff OLD NEW -o REPORT/``: two revisions of a model, element by element and
in pictures.

Exit status (as ``regress check``: 1 when something changed): 0 no change, 1 changes found,
2 bad input (a file, an option value, a scene) with one ``error: ...`` line and nothing written.
"""

from __future__ import annotations

from pathlib import Path

import click

from mrcheck.cli.messages import progress_bar
from mrcheck.core.errors import MrcheckError

EXIT_CHANGES, EXIT_BAD_INPUT = 1, 2


class BadInputExits2(click.Command):
    """A command whose bad input -- a bad option value or a :class:`MrcheckError` -- prints one
    line and exits 2, so that its exit 1 means only "changes found"."""

    def make_context(self, info_name, args, parent=None, **extra):
        try:
            return super().make_context(info_name, args, parent=parent, **extra)
        except click.BadParameter as exc:
            if isinstance(exc, click.MissingParameter):
                raise  # a malformed command line: click's usage message, exit 2 as well
            _bad_input(" ".join(exc.format_message().split()))

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except MrcheckError as exc:
            _bad_input(str(exc))


def _bad_input(message: str):
    click.echo(f"error: {message}", err=True)
    raise click.exceptions.Exit(EXIT_BAD_INPUT)


@click.command("diff", cls=BadInputExits2)
@click.argument("old", metavar="OLD")
@click.argument("new", metavar="NEW")
@click.option("-o", "--output", "outdir", required=True, metavar="REPORT", help="Folder for the tables and pictures.")
@click.option(
    "--view",
    "views",
    multiple=True,
    metavar="NAME",
    help="A viewpoint to draw (repeatable) [default: every viewpoint of NEW].",
)
@click.option(
    "--width",
    type=click.IntRange(min=16, max=8192),
    default=800,
    show_default=True,
    help="Width of each view's picture in pixels (the height keeps the viewpoint's aspect).",
)
@click.option("--bcf", is_flag=True, help="Also write changes.bcfzip: one BCF 2.1 topic per change.")
@click.option("--no-pictures", is_flag=True, help="Only the element tables (no rendering).")
@click.option(
    "--tolerance-mm",
    type=click.FloatRange(min=0.0, max=1000.0),
    default=1.0,
    show_default=True,
    help="Moves, vertex differences and deformations up to this are no change.",
)
@click.option(
    "--tolerance-deg",
    type=click.FloatRange(min=0.0, max=180.0),
    default=0.1,
    show_default=True,
    help="Rotations up to this are no change.",
)
@click.pass_context
def diff(ctx, old, new, outdir, views, width, bcf, no_pictures, tolerance_mm, tolerance_deg):
    """Compare two revisions of a model: which elements changed, where, and in pictures.

    OLD and NEW are scenes or model files (IFC, STEP, glTF, a manifest). Elements are matched
    by id (IFC GlobalId; STEP assembly path; glTF node path; manifest instance id) and reported
    as added, removed,
    moved (offset in metres, rotation in degrees), changed geometry or unchanged in
    changes.csv and changes.json. Each view gets view-NAME.png: NEW in vector AO, added
    elements green, removed red (ghosted from OLD), moved amber with an arrow from the old
    position, changed geometry blue. Exit status: 0 no change, 1 changes found, 2 bad input.

    \b
    Example:
      mrcheck regress diff week48.ifc week49.ifc --bcf -o diff49
    """
    from mrcheck.apps.modeldiff.command import DiffSettings, diff_command

    settings = DiffSettings(
        views=tuple(views),
        width=width,
        bcf=bcf,
        pictures=not no_pictures,
        tolerance_m=tolerance_mm / 1000.0,
        tolerance_deg=tolerance_deg,
    )
    run = diff_command(Path(old), Path(new), Path(outdir), settings, progress_bar)
    for path in run.written:
        print(path)
    print(run.summary)
    ctx.exit(run.exit_code)
