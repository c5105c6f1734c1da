"""The ``mrcheck`` click group that every command module adds its commands to.

Help conventions (tests/test_cli_help.py holds every command to them): a command's docstring
starts with a one-line summary paragraph, which ``mrcheck --help`` lists in full (never cut with
"..."), and holds one copy-pasteable example in an ``Example:`` block.
"""

import click


class Group(click.Group):
    """A click group whose command list shows each command's whole summary paragraph."""

    group_class = type   # subgroups (``mrcheck scene``) list their commands the same way

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
def cli():
    """mrcheck: planned factory CAD rendered from a calibrated camera, with vector-based SSAO
    (Scheer & Keutel), for mixed-reality discrepancy checks.

    \b
    Example (then open mrcheck-demo/robot_study.png):
      mrcheck demo -o mrcheck-demo
    """
