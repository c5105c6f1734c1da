"""``mrcheck render`` and ``mrcheck demo``."""

from __future__ import annotations

from pathlib import Path

import click

from mrcheck.cli.group import cli
from mrcheck.cli.options import (
    FINITE,
    MODE_CHOICES,
    accumulate_option,
    odd_kernel,
    positive,
    warn_unused_options,
)
from mrcheck.core.errors import MrcheckError
from mrcheck.render import settings as defaults

FIRST_DEMO_IMAGE = "robot_study.png"  # the sample cell's robot in D1 | D2 | D3: creases and contacts (README's picture)


@cli.command()
@click.argument("scene", metavar="SCENE")
@click.option("--view", metavar="NAME", help="Named viewpoint of the scene manifest.")
@click.option(
    "--camera",
    "camera_path",
    metavar="CAM.json|CAM.yml",
    help="Camera JSON (K, size, distortion, world-to-camera R|t, OpenCV convention) or OpenCV YAML with R and t; "
    "a registered SHOT.json works too.",
)
@click.option(
    "--mode",
    type=click.Choice(MODE_CHOICES),
    default="vector",
    show_default=True,
    help="phong = D1 (no AO), vector = D2 (Scheer & Keutel), ssao = D3 (standard SSAO); comparison modes crytek, "
    "hbao, alchemy (world radius like ssao), gtao, vbao (screen radius like vector); "
    "all = D1|D2|D3 side by side, labelled.",
)
@click.option(
    "--width",
    type=int,
    callback=positive,
    help="Image width in pixels [default: the view's or camera's]; one side alone keeps the aspect ratio, "
    "which a --camera's must keep.",
)
@click.option("--height", type=int, callback=positive, help="Image height in pixels [default: the view's or camera's].")
@click.option(
    "--samples",
    type=int,
    default=defaults.DEFAULT_SAMPLES,
    show_default=True,
    callback=positive,
    help="AO samples per pixel (the paper uses 16, 36, 64, 128).",
)
@accumulate_option()
@click.option(
    "--radius-px",
    type=FINITE,
    callback=positive,
    help="vector, gtao, vbao: sampling radius on screen, pixels at the output resolution "
    f"[default: {defaults.DEFAULT_RADIUS_FRACTION:.0%} of the image height].",
)
@click.option(
    "--radius-fraction",
    type=FINITE,
    callback=positive,
    help="vector, gtao, vbao: sampling radius as a fraction of the image height, instead of --radius-px "
    f"[default: {defaults.DEFAULT_RADIUS_FRACTION}].",
)
@click.option(
    "--radius",
    "radius_world",
    type=FINITE,
    default=defaults.DEFAULT_RADIUS_WORLD,
    show_default=True,
    callback=positive,
    help="ssao: constant world radius in scene units (metres for parts with declared units).",
)
@click.option(
    "--min-world-radius",
    type=FINITE,
    help="vector, gtao, vbao: clamp the world sampling radius from below (scene units).",
)
@click.option(
    "--max-world-radius",
    type=FINITE,
    help="vector, gtao, vbao: clamp the world sampling radius from above (scene units).",
)
@click.option(
    "--falloff",
    type=FINITE,
    default=defaults.DEFAULT_FALLOFF,
    show_default=True,
    help="c, the attenuation of o = cos / (1 + c (|v|/r)^2); larger = occlusion falls off faster with distance.",
)
@click.option(
    "--thickness",
    type=FINITE,
    default=defaults.DEFAULT_THICKNESS,
    show_default=True,
    callback=positive,
    help="vbao: assumed thickness of every surface, in units of the world sampling radius.",
)
@click.option(
    "--intensity",
    type=FINITE,
    help="AO strength: 0 none, 0.5 weak ... 2 strong (the study stepped four levels, weak to strong) "
    f"[default: {defaults.MODE_INTENSITIES['vector']:g} for vector, matching the ray-traced reference "
    f"on the shipped scenes; {defaults.DEFAULT_INTENSITY:g} for the other modes].",
)
@click.option(
    "--blur/--no-blur",
    default=defaults.DEFAULT_BLUR_ON,
    show_default=True,
    help="Depth-aware bilateral blur of the AO buffer.",
)
@click.option(
    "--blur-size",
    type=int,
    default=defaults.DEFAULT_BLUR_SIZE,
    show_default=True,
    callback=odd_kernel,
    help=f"Blur kernel size, odd, 3 to {defaults.MAX_BLUR_SIZE} (the paper uses 9 and 13).",
)
@click.option(
    "--ao-scale",
    type=click.Choice([f"{s:g}" for s in defaults.AO_SCALES]),
    default=f"{defaults.DEFAULT_AO_SCALE:g}",
    show_default=True,
    help="AO resolution: 1 full, 0.5 half resolution with depth-aware upsampling (the paper's 'Half Res.').",
)
@click.option("--ao-direct", is_flag=True, help="Let AO darken the direct light too (default: the ambient term only).")
@click.option(
    "--antialias/--no-antialias",
    default=defaults.DEFAULT_ANTIALIAS,
    show_default=True,
    help="Anti-aliased edges: 4x multisampled geometry (MSAA), edge pixels shaded per surface, the AO once per "
    "pixel; off with --ao-scale 0.5.",
)
@click.option(
    "--tone",
    type=click.Choice(defaults.TONES),
    default=defaults.DEFAULT_TONE,
    show_default=True,
    help="filmic: light surfaces roll off below white; clip: linear light clipped at white (no tone curve).",
)
@click.option(
    "--light",
    type=click.Choice(defaults.LIGHTS),
    default=defaults.DEFAULT_LIGHT,
    show_default=True,
    help="headlight: a light just above the camera; sun: a fixed direction from above.",
)
@click.option(
    "--seed",
    type=click.IntRange(min=0),
    default=defaults.DEFAULT_SEED,
    show_default=True,
    help="Seed of the AO kernel and rotation tile (renders are reproducible).",
)
@click.option(
    "--lod-px",
    type=FINITE,
    default=defaults.DEFAULT_LOD_PX,
    show_default=True,
    help="Level of detail: parts drawn 4+ times and single parts of 50 k+ triangles (robots) use a "
    "simplified mesh where its measured error stays below this many pixels; 0 draws every part "
    "at full detail.",
)
@click.option(
    "--units",
    type=click.Choice(["mm", "cm", "m", "in", "ft"]),
    help="Unit of a single mesh file SCENE (a manifest declares units per part); default: as authored.",
)
@click.option("-o", "--output", required=True, metavar="OUT.png", help="Output image (.png, .jpg, .tif).")
@click.option(
    "--output-ao",
    metavar="AO.npy",
    help="Also write the AO term alone: .npy float32 (H, W) in [0,1], background 1, or 16-bit grey .png. "
    "With --mode all, one file per AO mode, named AO_vector.npy, AO_ssao.npy.",
)
def render(
    scene,
    view,
    camera_path,
    mode,
    width,
    height,
    samples,
    accumulate,
    radius_px,
    radius_fraction,
    radius_world,
    min_world_radius,
    max_world_radius,
    falloff,
    thickness,
    intensity,
    blur,
    blur_size,
    ao_scale,
    ao_direct,
    antialias,
    tone,
    light,
    seed,
    lod_px,
    units,
    output,
    output_ao,
):
    """Render a scene from a named view or a calibrated camera.

    SCENE is a .toml manifest or one mesh file; the camera is a named viewpoint of the manifest
    (--view) or a calibrated camera file (--camera).

    \b
    Examples:
      mrcheck render factory_scenes/sample_cell/scene.toml --view overview --mode all -o study.png
      mrcheck render hall.glb --units mm --camera shot.json --mode vector --no-blur -o v.png --output-ao ao.npy
      mrcheck render factory_scenes/sample_cell/scene.toml --view robot --mode vbao --thickness 0.5 -o vbao.png
      mrcheck render hall/scene.toml --view aisle --accumulate 16 -o aisle.png
    """
    from mrcheck.render.views import render_command

    if radius_px is not None and radius_fraction is not None:
        raise MrcheckError("give --radius-px or --radius-fraction, not both")
    warn_unused_options(click.get_current_context(), mode)
    written = render_command(
        scene=scene,
        view=view,
        camera_path=camera_path,
        mode=mode,
        width=width,
        height=height,
        units=units,
        output=output,
        output_ao=output_ao,
        settings=dict(
            samples=samples,
            accumulate=accumulate,
            radius_px=radius_px,
            radius_fraction=radius_fraction or defaults.DEFAULT_RADIUS_FRACTION,
            radius_world=radius_world,
            min_world_radius=min_world_radius,
            max_world_radius=max_world_radius,
            falloff=falloff,
            thickness=thickness,
            intensity=intensity,
            blur=blur,
            blur_size=blur_size,
            ao_scale=float(ao_scale),
            ao_direct=ao_direct,
            light=light,
            seed=seed,
            lod_px=lod_px,
            antialias=antialias,
            tone=tone,
        ),
    )
    for path in written:
        click.echo(path)


@cli.command()
@click.option(
    "-o",
    "--output",
    "outdir",
    default="mrcheck-demo",
    show_default=True,
    metavar="DIR",
    help="Folder for the demo images.",
)
@click.option("--width", type=int, callback=positive, help="Image width [default: each viewpoint's, 1024].")
@click.option("--height", type=int, callback=positive, help="Image height [default: each viewpoint's, 768].")
def demo(outdir, width, height):
    """Render the shipped sample scenes in D1, D2 and D3.

    The embedded sample factory cell and the generator's shipped cell, from each of their
    viewpoints in D1, D2 and D3: PNGs (one per mode and a labelled side-by-side sheet per view;
    the generated cell's prefixed cell_), their paths printed. Which to open first is said at
    the end: DIR/robot_study.png.

    \b
    Example:
      mrcheck demo -o mrcheck-demo --width 640
    """
    from mrcheck.cli.messages import progress_bar
    from mrcheck.render.views import demo_command

    demo_command(Path(outdir), width, height, on_written=click.echo, progress=progress_bar)
    first = Path(outdir).resolve() / FIRST_DEMO_IMAGE
    if first.is_file():
        click.echo(
            f"open {first} first: the sample cell's robot in D1 | D2 | D3 (Phong without AO | "
            "vector SSAO | standard SSAO) side by side; every *_study.png is such a sheet",
            err=True,
        )
