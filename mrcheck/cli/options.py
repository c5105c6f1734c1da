"""Option callbacks and choices shared by several commands."""

from __future__ import annotations

import math

import click


def mode_choices() -> list[str]:
    from mrcheck.render.settings import MODES  # every render mode

    return [*MODES, "all"]


MODE_CHOICES = mode_choices()


class Finite(click.ParamType):
    """click's float without nan and inf, which its FLOAT accepts: every float option of every
    command is this type, so that no check written as a comparison (``x >= 0``, ``x <= 1``) lets
    a NaN through or takes an infinite radius."""

    name = "float"

    def convert(self, value, param, ctx):
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number", param, ctx)
        return number


FINITE = Finite()


def positive(ctx, param, value):
    if value is not None and not value > 0:
        raise click.BadParameter(f"must be positive, got {value}")
    return value


def size(ctx, param, value):
    from mrcheck.apps.review.guard import parse_size

    try:
        return parse_size(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def odd_kernel(ctx, param, value):
    # checked here, not when the blur is built: that is after loading the scene, and never for phong
    from mrcheck.render.settings import (
        blur_size_problem,  # the maximum is a uniform array's size: see there
    )

    if problem := blur_size_problem(value):
        raise click.BadParameter(problem)
    return value


# render options that only some modes read: given for a mode that ignores them, a warning
AO_MODES = tuple(m for m in MODE_CHOICES if m not in ("phong", "all"))


def screen_radius_modes() -> tuple[str, ...]:
    from mrcheck.render.settings import SCREEN_RADIUS_MODES  # vector, gtao, vbao

    return SCREEN_RADIUS_MODES


SCREEN_RADIUS_MODES = screen_radius_modes()
WORLD_RADIUS_MODES = tuple(m for m in AO_MODES if m not in SCREEN_RADIUS_MODES)  # ssao and the other comparison modes


OPTION_MODES = {
    "radius_px": SCREEN_RADIUS_MODES,
    "radius_fraction": SCREEN_RADIUS_MODES,
    "min_world_radius": SCREEN_RADIUS_MODES,
    "max_world_radius": SCREEN_RADIUS_MODES,
    "radius_world": WORLD_RADIUS_MODES,
    "thickness": ("vbao",),
    "samples": AO_MODES,
    "falloff": AO_MODES,
    "intensity": AO_MODES,
    "blur": AO_MODES,
    "blur_size": AO_MODES,
    "ao_scale": AO_MODES,
    "ao_direct": AO_MODES,
    "seed": AO_MODES,
    "accumulate": AO_MODES,
}


def accumulate_option(default: int | None = 1, what: str = "Progressive AO"):
    """``--accumulate N`` of render, overlay, export (``default`` None: the job's key) and review
    (``what``: the frames it sets)."""
    from mrcheck.render.settings import MAX_ACCUMULATE

    shown = "" if default is not None else " [default: the job's `accumulate` key, 1]"
    return click.option(
        "--accumulate",
        type=int,
        default=default,
        show_default=default is not None,
        callback=positive,
        metavar="N",
        help=f"{what}: the mean of N AO frames, each with its own kernel orientation and a sub-pixel "
        "offset: removes the sampling noise and the moire of detail finer than a pixel (corrugated roof "
        f"decks); about N times the AO time, 1 to {MAX_ACCUMULATE}.{shown}",
    )


def warn_unused_options(ctx: click.Context, mode: str) -> None:
    """One warning line per option given on the command line that the chosen ``--mode`` (all:
    D1, D2, D3) does not read."""
    from mrcheck.render.views import STUDY_ORDER

    modes = STUDY_ORDER if mode == "all" else (mode,)
    for param in ctx.command.params:
        users = OPTION_MODES.get(param.name)
        if (
            users
            and not set(users) & set(modes)
            and ctx.get_parameter_source(param.name) == click.core.ParameterSource.COMMANDLINE
        ):
            option = "/".join(param.opts[-1:] + param.secondary_opts)  # --blur/--no-blur as one
            click.echo(
                f"warning: {option} has no effect in mode {'/'.join(modes)} (it applies to {', '.join(users)})",
                err=True,
            )
