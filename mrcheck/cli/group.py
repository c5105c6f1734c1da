"""The ``mrcheck`` click group that every command module adds its commands to.

Help conventions (tests/test_cli_help.py holds every command to them): a command's docstring
starts with a one-line summary paragraph, which ``mrcheck --help`` lists in full (never cut with
"..."), and holds one copy-pasteable example in an ``Example:`` block.
"""

import click


def pixel_count(value: str) -> int:
    """The pixels of a ``--max-pixels`` value (``64MP``, ``50M``, ``12000000``)."""
    from mrcheck.core.images import parse_pixels

    try:
        return parse_pixels(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


class Group(click.Group):
    """A click group whose command list shows each command's whole summary paragraph."""

    group_class = type  # subgroups (``mrcheck scene``) list their commands the same way

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = []
        for name in self.list_commands(ctx):
            command = self.get_command(ctx, name)
            if command is not None and not command.hidden:
                rows.append((name, command.get_short_help_str(limit=1_000_000)))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(cls=Group, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mrcheck")
@click.option(
    "--package-path",
    multiple=True,
    metavar="DIR",
    help="Where URDF meshes named package://NAME/... are found: the package folder NAME or the folder "
    "holding it (repeatable; before a manifest's package_path and ROS_PACKAGE_PATH).",
)
@click.option(
    "--coordinates",
    type=click.Choice(["model", "map"]),
    default="model",
    show_default=True,
    help="IFC files given as SCENE: keep the model's own coordinates, or place it at its map coordinates "
    "(IfcMapConversion, else the site placement).",
)
@click.option(
    "--max-pixels",
    default="64MP",
    show_default=True,
    metavar="PIXELS",
    callback=lambda ctx, param, value: pixel_count(value),
    help="Refuse photos (and video frames) of more pixels than this, from their header before decoding "
    "(e.g. 100MP); review has its own --max-pixels.",
)
def cli(package_path, coordinates, max_pixels):
    """mrcheck: planned factory CAD rendered from a calibrated camera, with vector-based SSAO
    (Scheer & Keutel), for mixed-reality discrepancy checks.

    Every SCENE may be a manifest, a mesh file, a URDF, or an IFC/STEP model itself (imported
    once, then cached).

    \b
    Example (then open mrcheck-demo/robot_study.png):
      mrcheck demo -o mrcheck-demo
    """
    from mrcheck.core.images import set_max_pixels
    from mrcheck.scene.importers.records import set_default_settings
    from mrcheck.scene.packages import set_package_path

    set_package_path(package_path)
    set_max_pixels(max_pixels)
    set_default_settings(coordinates=coordinates)
