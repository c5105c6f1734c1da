"""The ``mrcheck`` click group that every command module adds its commands to."""

import click


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mrcheck")
@click.option("--package-path", multiple=True, metavar="DIR",
              help="Where URDF meshes named package://NAME/... are found: the package folder NAME or the folder "
                   "holding it (repeatable; before a manifest's package_path and ROS_PACKAGE_PATH).")
@click.option("--coordinates", type=click.Choice(["model", "map"]), default="model", show_default=True,
              help="IFC files given as SCENE: keep the model's own coordinates, or place it at its map coordinates "
                   "(IfcMapConversion, else the site placement).")
def cli(package_path, coordinates):
    """mrcheck: planned factory CAD rendered from a calibrated camera, with vector-based SSAO
    (Scheer & Keutel), for mixed-reality discrepancy checks.

    Every SCENE may be a manifest, a mesh file, a URDF, or an IFC/STEP model itself (imported
    through a cache). Example: mrcheck --package-path ~/ws/src scene info robot.urdf"""
    from mrcheck.scene.importers.records import set_default_settings
    from mrcheck.scene.packages import set_package_path

    set_package_path(package_path)
    set_default_settings(coordinates=coordinates)
