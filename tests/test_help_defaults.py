"""Every command-line option that sets a field of :class:`RenderSettings` says, in its ``--help``,
what the setting's default is: the option's own default equals the field's, every ``[default: ...]``
that click or the help text shows agrees with it, and the anti-aliasing options describe the
anti-aliasing the renderer does (``MSAA_SAMPLES``-times multisampled, not supersampled).

``test_a_help_that_contradicts_a_default_is_caught`` runs the same check on a command written
wrong on purpose."""

from __future__ import annotations

import dataclasses
import re

import click
import pytest

from mrcheck.cli.group import cli
from mrcheck.render import settings as defaults
from mrcheck.render.antialias import MSAA_SAMPLES
from mrcheck.render.settings import RenderSettings

FIELD_DEFAULTS = {f.name: f.default for f in dataclasses.fields(RenderSettings)}

# options named like a RenderSettings field that set something else
NOT_RENDER_SETTINGS = {
    ("reference", "seed"),  # the reference's ray directions
    ("scene generate", "seed"),  # the generated scene
    ("scene asbuilt", "seed"),  # the as-built perturbations
    ("review", "accumulate"),  # the AO frames of a navigated view at rest, not the shots' renders
}

# fields whose default is None, decided per frame: the numbers a help may name as their default
DERIVED_DEFAULTS = {
    "radius_px": {defaults.DEFAULT_RADIUS_FRACTION * 100},  # "2% of the image height"
    "intensity": {defaults.MODE_INTENSITIES["vector"], defaults.DEFAULT_INTENSITY},
}

DEFAULT_TEXT = re.compile(r"\[default: ([^\]]*)\]")
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?")
# "4x MSAA", "4x multisampled", "2x2 supersampled": how many samples a pixel's edges get
SAMPLE_CLAIM = re.compile(r"(\d+)x(\d+)?\s*(?:MSAA|multisampl|supersampl)", re.IGNORECASE)


def _commands(group: click.Group, prefix: tuple[str, ...] = ()):
    ctx = click.Context(group)
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        if isinstance(command, click.Group):
            yield from _commands(command, (*prefix, name))
        else:
            yield " ".join((*prefix, name)), command


def _has_default(value) -> bool:
    return value is not None and not repr(value).startswith("Sentinel.")  # click 8.2+: UNSET


def _agrees(value, expected) -> bool:
    if isinstance(expected, bool):
        return value is expected or str(value).lower() == str(expected).lower()
    if isinstance(expected, (int, float)):
        try:
            return float(value) == float(expected)
        except (TypeError, ValueError):
            return False
    return str(value) == str(expected)


def _bool_words(option: click.Option, text: str) -> set[bool]:
    """The booleans a default's text names: true/false, or the flag's own names."""
    words = set(re.findall(r"[\w-]+", text.lower()))
    named = set()
    if words & {"true", *(o.lstrip("-") for o in option.opts)}:
        named.add(True)
    if words & {"false", *(o.lstrip("-") for o in option.secondary_opts)}:
        named.add(False)
    return named


def _default_text_problems(option: click.Option, field: str, text: str) -> list[str]:
    expected = FIELD_DEFAULTS[field]
    shown = text.split(";")[0].strip()  # click appends "; x>=0" for ranges
    if isinstance(expected, bool):
        named = _bool_words(option, shown)
        if named and named != {expected}:
            return [f"says [default: {shown}], the setting's default is {expected}"]
        return []
    if expected is None:
        allowed = DERIVED_DEFAULTS.get(field, set())
        wrong = [n for n in NUMBER.findall(shown) if float(n) not in allowed]
        return [f"says [default: {shown}], the setting's default is one of {sorted(allowed)}"] if wrong else []
    if isinstance(expected, (int, float)):
        numbers = NUMBER.findall(shown)
        if not numbers or not any(float(n) == float(expected) for n in numbers):
            return [f"says [default: {shown}], the setting's default is {expected:g}"]
        return []
    if shown != str(expected):
        return [f"says [default: {shown}], the setting's default is {expected}"]
    return []


def _sample_claim_problems(help_text: str) -> list[str]:
    if "supersampl" in help_text.lower():
        return [f"calls the anti-aliasing supersampling: it is {MSAA_SAMPLES}x MSAA"]
    return [
        f"describes the anti-aliasing as {claim.group(0)!r}: it is {MSAA_SAMPLES}x MSAA"
        for claim in SAMPLE_CLAIM.finditer(help_text)
        if claim.group(2) is not None or int(claim.group(1)) != MSAA_SAMPLES
    ]


def contradictions(name: str, command: click.Command) -> list[str]:
    """Every place where ``command``'s --help contradicts a RenderSettings default."""
    ctx = click.Context(command, info_name=name)
    problems = []
    for option in command.params:
        field = option.name
        if not isinstance(option, click.Option) or field not in FIELD_DEFAULTS or (name, field) in NOT_RENDER_SETTINGS:
            continue
        where = f"{name} {option.opts[0]}"
        expected = FIELD_DEFAULTS[field]
        if _has_default(option.default) and not _agrees(option.default, expected):
            problems.append(f"{where}: default {option.default!r}, the setting's default is {expected!r}")
        record = option.get_help_record(ctx)
        help_text = record[1] if record else ""
        for text in DEFAULT_TEXT.findall(help_text):
            problems += [f"{where}: {p}" for p in _default_text_problems(option, field, text)]
        if field == "antialias":
            problems += [f"{where}: {p}" for p in _sample_claim_problems(help_text)]
    return problems


COMMANDS = list(_commands(cli))


def test_the_render_commands_are_checked():
    checked = {name for name, command in COMMANDS if any(p.name in FIELD_DEFAULTS for p in command.params)}
    assert {"render", "overlay", "reference", "compare", "review", "export"} <= checked


@pytest.mark.parametrize("name,command", COMMANDS, ids=[name for name, _ in COMMANDS])
def test_help_agrees_with_the_settings_defaults(name, command):
    assert contradictions(name, command) == []


def _bad_command() -> click.Command:
    @click.command()
    @click.option("--samples", type=int, default=defaults.DEFAULT_SAMPLES + 16, show_default=True)
    @click.option("--blur-size", type=int, default=defaults.DEFAULT_BLUR_SIZE, help="Kernel size [default: 13].")
    @click.option("--radius-px", type=float, help="Radius [default: 5% of the image height].")
    @click.option(
        "--antialias/--no-antialias",
        default=defaults.DEFAULT_ANTIALIAS,
        help="Anti-aliased edges (2x2 supersampled geometry and shading).",
    )
    @click.option("--tone", default=defaults.DEFAULT_TONE, help="Tone curve [default: clip].")
    def bad(samples, blur_size, radius_px, antialias, tone):
        """A command whose help is wrong about five defaults."""

    return bad


def test_a_help_that_contradicts_a_default_is_caught():
    problems = contradictions("bad", _bad_command())
    assert [p.split(":")[0] for p in problems] == [
        "bad --samples",  # the option's default
        "bad --samples",  # and click's [default: 32] that shows it
        "bad --blur-size",
        "bad --radius-px",
        "bad --antialias",
        "bad --tone",
    ], problems


def test_a_help_that_agrees_passes():
    @click.command()
    @click.option("--samples", type=int, default=defaults.DEFAULT_SAMPLES, show_default=True)
    @click.option("--antialias/--no-antialias", default=True, show_default=True, help=f"{MSAA_SAMPLES}x MSAA.")
    def good(samples, antialias):
        """A command whose help is right."""

    assert contradictions("good", good) == []
