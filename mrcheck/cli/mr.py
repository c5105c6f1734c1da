"""``mrcheck calibrate``, ``mrcheck register`` and ``mrcheck overlay``: mixed reality."""

from __future__ import annotations

import click

from mrcheck.cli.group import cli
from mrcheck.cli.messages import echo_lines, progress_bar, warning_line
from mrcheck.cli.options import FINITE, MODE_CHOICES, accumulate_option, positive, warn_unused_options
from mrcheck.render import settings as defaults


@cli.command()
@click.argument("images", nargs=-1, required=True, metavar="IMAGES...")
@click.option(
    "--board",
    required=True,
    metavar="SPEC",
    help="chessboard:COLSxROWS:SQUARE (inner corners, square size in metres) or "
    "charuco:COLSxROWS:SQUARE:MARKER:DICT (squares, sizes in metres, OpenCV dictionary, e.g. DICT_6X6_250).",
)
@click.option(
    "--min-views",
    type=int,
    default=None,
    help="Fewest usable views to calibrate from, at least 3: Zhang's method needs three photos of a flat "
    "board to determine the camera [default: 5].",
)
@click.option(
    "--max-view-error",
    type=FINITE,
    default=None,
    callback=positive,
    metavar="PX",
    help="Reject views whose RMS reprojection error exceeds this and recalibrate, until every view kept is "
    "within it [default: 3x the median view error of the first calibration, at least 1 px].",
)
@click.option(
    "-o",
    "--output",
    required=True,
    metavar="CAM.json",
    help="Camera JSON (K, dist, width, height, rms, per-view errors); .yml/.yaml writes OpenCV FileStorage.",
)
def calibrate(images, board, min_views, max_view_error, output):
    """Calibrate a camera from chessboard or ChArUco board photos.

    Zhang's method (cv2.calibrateCamera) on every photo the board is found in; outlier views
    are rejected and the camera calibrated again without them.

    \b
    Example:
      mrcheck calibrate photos/*.jpg --board chessboard:9x6:0.025 -o camera.json
    """
    from mrcheck.mr.calibration import calibrate_command

    done = calibrate_command(
        images=list(images),
        board=board,
        output=output,
        min_views=min_views,
        max_view_error=max_view_error,
        progress=progress_bar,
    )
    print("\n".join(done.report))
    if done.warning:
        warning_line(done.warning)
    print(f"wrote {done.output}")


@cli.command()
@click.argument("scene_path", metavar="SCENE")
@click.option("--photo", required=True, metavar="P", help="The photo to register.")
@click.option("--intrinsics", required=True, metavar="CAM.json", help="Calibrated camera (JSON, or OpenCV YAML).")
@click.option(
    "--markers",
    metavar="MAP.json",
    help="Marker map: surveyed world corners of ArUco/AprilTag markers and ChArUco boards.",
)
@click.option("--points", metavar="CORR.json", help="Manual correspondences: pixel <-> world point pairs (>= 4).")
@click.option(
    "--initial",
    metavar="ROUGH.json",
    help="A rough pose (any camera JSON with R and t: an earlier shot, `mrcheck scene camera`'s output) "
    "snapped onto the photo's edges (markerless; docs/edge-registration.md).",
)
@click.option(
    "--refine/--no-refine",
    default=None,
    help="Snap the pose of --markers/--points onto the photo's edges as well [default: no; with --initial always].",
)
@click.option(
    "--max-error",
    type=FINITE,
    default=None,
    callback=positive,
    metavar="PX",
    help="RANSAC inlier threshold in pixels [default: automatic; points: 3.72 x --click-sigma].",
)
@click.option(
    "--click-sigma",
    type=FINITE,
    default=1.5,
    show_default=True,
    callback=positive,
    metavar="PX",
    help="Noise of the clicked --points (px, 1 sigma): outlier threshold 3.72 x this (99.9 % of honest clicks).",
)
@click.option(
    "--silhouette",
    type=click.Choice(["auto", "on", "off"]),
    default="auto",
    show_default=True,
    help="The edge stage also matches parts' outlines by their colour regions: auto for the curved parts "
    "(scans, pipes, bottles: their faces meet at under 30 deg), on for every part, off for none "
    "(docs/edge-registration.md).",
)
@click.option(
    "-o",
    "--output",
    required=True,
    metavar="SHOT.json",
    help="The registered shot (camera JSON + photo, rms, method, ids used/rejected).",
)
def register(
    scene_path, photo, intrinsics, markers, points, initial, refine, max_error, click_sigma, silhouette, output
):
    """Find a photo's pose: markers, clicks or the CAD's edges.

    The pose of the calibrated camera in the factory, from surveyed markers (--markers),
    clicked pixel <-> world correspondences (--points), or a rough pose (--initial) whose CAD
    edges are snapped onto the photo's edges; writes SHOT.json.

    \b
    Example:
      mrcheck register hall/scene.toml --photo p1.jpg --intrinsics camera.json --markers map.json -o p1.json
      mrcheck scene camera hall/scene.toml --view aisle --intrinsics camera.json -o rough.json
      mrcheck register hall/scene.toml --photo p2.jpg --intrinsics camera.json --initial rough.json -o p2.json
    """
    from mrcheck.mr.register import register_command

    done = register_command(
        scene=scene_path,
        photo=photo,
        intrinsics=intrinsics,
        markers=markers,
        points=points,
        initial=initial,
        refine=refine,
        max_error=max_error,
        output=output,
        click_sigma=click_sigma,
        silhouette=silhouette,
    )
    echo_lines(done.summary())


@cli.command()
@click.argument("shot", metavar="SHOT.json")
@click.option("--scene", "scene_path", required=True, metavar="SCENE", help="The planned scene (manifest or mesh).")
@click.option(
    "--mode",
    type=click.Choice(MODE_CHOICES),
    default="vector",
    show_default=True,
    help="Shading of the CAD; all = the study's sheet: D1, D2, D3, each virtual and with the photo.",
)
@click.option(
    "--alpha", type=FINITE, default=0.5, show_default=True, help="Photo opacity, 0 (CAD only) .. 1 (photo only)."
)
@click.option("--edges", is_flag=True, help="Draw CAD silhouette and crease edges over the photo.")
@click.option("--edge-color", default="ff00ff", show_default=True, metavar="RRGGBB", help="Colour of the CAD edges.")
@click.option(
    "--intensity",
    type=FINITE,
    help="AO strength (0 none ... 2 strong) [default: "
    f"{defaults.MODE_INTENSITIES['vector']:g} for vector, {defaults.DEFAULT_INTENSITY:g} for the other modes].",
)
@click.option(
    "--antialias/--no-antialias",
    default=defaults.DEFAULT_ANTIALIAS,
    show_default=True,
    help="Anti-aliased CAD edges (4x multisampled geometry, edge pixels shaded per surface).",
)
@click.option(
    "--samples",
    type=int,
    default=defaults.DEFAULT_SAMPLES,
    show_default=True,
    callback=positive,
    help="AO samples per pixel.",
)
@accumulate_option()
@click.option("-o", "--output", required=True, metavar="OUT.png", help="Output image.")
def overlay(shot, scene_path, mode, alpha, edges, edge_color, intensity, antialias, samples, accumulate, output):
    """Blend the CAD rendered from a registered shot over its photo.

    The planned CAD rendered from the shot's camera, distorted like its lens, blended over the
    photo; --mode all writes the study's sheet (D1, D2, D3, each virtual and over the photo).

    \b
    Example:
      mrcheck overlay p1.json --scene hall/scene.toml --mode vector --alpha 0.4 --edges -o p1_overlay.png
    """
    from mrcheck.core.output import write_image
    from mrcheck.mr.shot import overlay_shot

    warn_unused_options(click.get_current_context(), mode)
    image = overlay_shot(
        shot=shot,
        scene=scene_path,
        mode=mode,
        alpha=alpha,
        edges=edges,
        edge_color=edge_color,
        intensity=intensity,
        samples=samples,
        output=output,
        antialias=antialias,
        accumulate=accumulate,
    )
    print(write_image(output, image))
