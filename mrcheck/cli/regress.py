"""``mrcheck regress``: image regression tests of a model (issue 43): ``record`` and ``check``
the agreed views of a scene here, ``diff`` two revisions element by element
(:mod:`mrcheck.cli.regress_diff`).

Exit status of ``regress check``: 0 when every view is within tolerance, 1 when any view
changed (each named), 2 on bad input (a missing baseline, an unreadable scene, a bad option):
the group turns every one-line error of its commands into exit 2, as pytest-mpl's and a
compiler's callers expect (1 is "the test failed"). ``diff`` does the same in its own command
class.
"""

from __future__ import annotations

import click

from mrcheck.cli.group import Group, cli
from mrcheck.cli.messages import progress_bar
from mrcheck.cli.options import FINITE
from mrcheck.cli.regress_diff import diff
from mrcheck.core.errors import MrcheckError

EXIT_CHANGED = 1
EXIT_BAD_INPUT = 2


class RegressGroup(Group):
    """A group whose commands exit 2 on bad input (``MrcheckError``, a bad option value)."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except MrcheckError as exc:
            click.echo(f"error: {exc}", err=True)
        except click.BadParameter as exc:
            click.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
        raise click.exceptions.Exit(EXIT_BAD_INPUT)


@cli.group(cls=RegressGroup)
def regress():
    """Image regression tests: record, check views; diff revisions.

    \b
    Example:
      mrcheck regress record factory_scenes/sample_cell/scene.toml -o baseline/
      mrcheck regress check factory_scenes/sample_cell/scene.toml --baseline baseline/ -o report/
      mrcheck regress diff week48.ifc week49.ifc -o diff49
    """


regress.add_command(diff)


def workers_options(command):
    """``--workers N`` and ``--scheduler ADDRESS``, as ``mrcheck export`` has them."""
    command = click.option(
        "--scheduler",
        metavar="ADDRESS",
        help="Render the views on a Dask distributed cluster (e.g. tcp://10.0.0.5:8786); its workers load the "
        "scene themselves from the path given.",
    )(command)
    return click.option(
        "--workers",
        type=click.IntRange(min=1),
        default=1,
        show_default=True,
        help="Local worker processes rendering the views, each with its own EGL context.",
    )(command)


def _client(scheduler):
    """The Dask client of ``--scheduler`` (a bad address is a one-line error before any work), or None."""
    if not scheduler:
        return None
    from mrcheck.apps.export.execute import connect

    return connect(scheduler)


def _modes(ctx, param, value):
    from mrcheck.render.settings import MODES

    modes = [m.strip() for m in value.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES]
    if not modes or unknown:
        raise click.BadParameter(f"unknown mode(s) {', '.join(unknown) or value!r} (use {', '.join(MODES)})")
    return tuple(dict.fromkeys(modes))


@regress.command("record")
@click.argument("scene", metavar="SCENE")
@click.option(
    "--views",
    multiple=True,
    metavar="NAME,...|CAM.json",
    help="Views to record: viewpoint names of the scene (comma-separated) or camera files (camera JSON, "
    "OpenCV YAML, SHOT.json); repeatable [default: every viewpoint of the scene].",
)
@click.option(
    "--modes",
    default="phong,vector",
    show_default=True,
    callback=_modes,
    help="Render modes, comma-separated (phong, vector, ssao, ...).",
)
@click.option("--width", type=click.IntRange(min=1), default=640, show_default=True, help="Image width in pixels.")
@click.option("--height", type=click.IntRange(min=1), default=480, show_default=True, help="Image height in pixels.")
@click.option(
    "-o", "--output", "outdir", required=True, metavar="BASELINE/", help="Baseline folder (new or mrcheck's)."
)
@workers_options
def regress_record(scene, views, modes, width, height, outdir, workers, scheduler):
    """Render a scene's views and write them as a baseline.

    Writes one PNG per view and mode, each view's id buffer (which element every pixel shows)
    and baseline.json (mrcheck version, settings, GL renderer, pixel hashes, the cameras, the
    scene's content stamp). Commit the folder; `regress check` compares against it.

    \b
    Example:
      mrcheck regress record factory_scenes/sample_cell/scene.toml --views overview,conveyor -o baseline/
    """
    from mrcheck.apps.regress.run import record

    client = _client(scheduler)
    baseline = record(scene, outdir, views, modes, (width, height), None, progress_bar, workers, client)
    click.echo(f"{baseline.folder}: {len(baseline.views)} view(s) x {len(baseline.modes)} mode(s) recorded")


@regress.command("check")
@click.argument("scene", metavar="SCENE")
@click.option("--baseline", "baseline_dir", required=True, metavar="BASELINE/", help="A folder `regress record` wrote.")
@click.option("-o", "--output", "outdir", required=True, metavar="REPORT/", help="Report folder (new or mrcheck's).")
@click.option("--max-mean", type=FINITE, help="Mean FLIP error allowed per view and mode [default: 0.03].")
@click.option("--max-p999", type=FINITE, help="99.9th percentile of the FLIP map allowed [default: 0.15].")
@click.option("--pixel-flip", type=FINITE, help="FLIP error above which a pixel counts as changed [default: 0.2].")
@click.option(
    "--max-changed",
    type=FINITE,
    help="Fraction of the pixels that may count as changed [default: 0.0001, 31 px at 640x480].",
)
@workers_options
def regress_check(scene, baseline_dir, outdir, max_mean, max_p999, pixel_flip, max_changed, workers, scheduler):
    """Render a baseline's views again; name what changed, where.

    Each view and mode is compared with NVIDIA's FLIP; a view changed when a mode's mean or
    99.9th percentile or its count of changed pixels is over tolerance. Writes REPORT/report.html
    (baseline / now / difference side by side), REPORT/junit.xml and the images. Exit 0: every
    view within tolerance; 1: a view changed; 2: bad input.

    \b
    Example:
      mrcheck regress check factory_scenes/sample_cell/scene.toml --baseline baseline/ -o report/
    """
    from mrcheck.apps.regress.compare import Tolerances
    from mrcheck.apps.regress.run import check

    given = {"mean": max_mean, "percentile_max": max_p999, "pixel_flip": max_pixel_check(pixel_flip)}
    given["max_changed"] = max_pixel_check(max_changed)
    tolerances = Tolerances(**{k: v for k, v in given.items() if v is not None})
    client = _client(scheduler)
    result = check(scene, baseline_dir, outdir, tolerances, progress_bar, workers, client)
    for line in result.summary():
        click.echo(line)
    click.echo(f"report: {result.report}")
    return 0 if result.passed else EXIT_CHANGED


def max_pixel_check(value):
    if value is not None and not 0 <= value <= 1:
        raise click.BadParameter(f"must be between 0 and 1, got {value}")
    return value
