"""The ``mrcheck`` click group that every command module adds its commands to."""

import click


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mrcheck")
def cli():
    """mrcheck: planned factory CAD rendered from a calibrated camera, with vector-based SSAO
    (Scheer & Keutel), for mixed-reality discrepancy checks."""
