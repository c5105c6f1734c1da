"""The command line's help: ``mrcheck --help`` lists every command's whole summary, every
command's --help holds one example that the command line accepts, and ``mrcheck demo`` says
which image to open first."""

from __future__ import annotations

import shlex
from pathlib import Path

import click
import pytest

from mrcheck.cli import main
from mrcheck.cli.group import cli


def _commands(group: click.Group, prefix=()):
    """(path of names, command) of every command and group below ``group``."""
    ctx = click.Context(group)
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        yield (*prefix, name), command
        if isinstance(command, click.Group):
            yield from _commands(command, (*prefix, name))


COMMANDS = list(_commands(cli))


def _summary(command: click.Command) -> str:
    """The first paragraph of the docstring, on one line."""
    return " ".join(command.help.split("\n\n")[0].split())


def test_every_command_is_covered():
    names = {" ".join(path) for path, _ in COMMANDS}
    assert {
        "render",
        "demo",
        "calibrate",
        "register",
        "overlay",
        "export",
        "review",
        "discrepancies",
        "deviation",
        "bench",
        "reference",
        "compare",
        "scene",
        "scene generate",
        "scene asbuilt",
        "scene info",
    } <= names


@pytest.mark.parametrize("group_path", [(), ("scene",)], ids=["mrcheck", "scene"])
def test_the_command_list_shows_each_summary_in_full(capsys, group_path):
    """Not cut with "...": each command's one-line summary is there, whole (wrapped at most)."""
    assert main([*group_path, "--help"]) == 0
    listing = " ".join(capsys.readouterr().out.split("Commands:", 1)[1].split())
    for path, command in COMMANDS:
        if path[:-1] == group_path:
            summary = _summary(command)
            assert f"{path[-1]} {summary}" in listing
            assert not summary.endswith("...") and len(summary) <= 62, summary  # one line of an 80-column list


@pytest.mark.parametrize("path", [path for path, _ in COMMANDS], ids=" ".join)
def test_every_command_help_has_an_example_the_command_line_accepts(capsys, path):
    assert main([*path, "--help"]) == 0
    lines = capsys.readouterr().out.splitlines()
    heading = next(i for i, line in enumerate(lines) if line.strip().startswith("Example"))
    example = lines[heading + 1].strip()
    words = shlex.split(example)
    assert words[0] == "mrcheck", example
    # a group's example runs one of its commands; a command's example runs that command
    assert tuple(words[1 : 1 + len(path)]) == path or (path and words[1] == path[0]), example
    # click parses it: every option exists and every value has its type (files are not opened)
    command, args = cli, words[1:]
    while isinstance(command, click.Group):
        command, args = command.get_command(click.Context(command), args[0]), args[1:]
    command.make_context(words[1], list(args), resilient_parsing=False)


@pytest.mark.slow
def test_demo_says_which_image_to_open_first(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path), "--width", "64", "--height", "48"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    first = Path(err[-1].split("open ", 1)[1].split(" first:", 1)[0])
    assert first == tmp_path.resolve() / "robot_study.png" and first.is_file()  # the one README.md names first
    assert "D1 | D2 | D3" in err[-1]
