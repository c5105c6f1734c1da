"""The ``mrcheck`` command line. Commands only; the work lives in the layers below.

One module per command group (``render``, ``scene``, ``mr``, ``apps``, ``evaluate``), sharing
``group`` (the click group and its help conventions), ``options`` (option types and checks) and
``messages`` (warnings as ``warning: ...`` lines, progress bars). A command parses its options,
calls one function of a lower layer and prints what it returns. Public API: :func:`main`.

Exit status: 0 on success; 1 with a one-line ``error: ...`` on stderr when the input is bad
(file, option value, scene), when ``export`` finished but some shots failed, or on an internal
error (a bug: one line too, MRCHECK_DEBUG=1 shows the traceback); 2 for a malformed command
line (an unknown or missing option: click's usage message).
"""

from __future__ import annotations

import os
import sys

import click

from mrcheck.cli import apps, evaluate, mr, regress, render, scene  # noqa: F401  (they add their commands)
from mrcheck.cli.group import cli
from mrcheck.cli.messages import progress_bar, warning_lines
from mrcheck.core.errors import DISPLAY_ERRORS, MrcheckError, bug_reason
from mrcheck.core.progress import showing_progress

EXIT_ERROR = 1


def _name_safe_streams() -> None:
    """File names that are not valid UTF-8 (surrogate escapes) print without UnicodeEncodeError:
    on stdout as their original bytes, as ls and find print them to a pipe (a printed output
    path stays usable by a script); on stderr, where a person reads them, as ``\\xNN``
    (:func:`mrcheck.core.errors.display`)."""
    for stream, errors in ((sys.stdout, "surrogateescape"), (sys.stderr, DISPLAY_ERRORS)):
        if hasattr(stream, "reconfigure"):  # a TextIOWrapper (not a test's StringIO)
            stream.reconfigure(errors=errors)


def main(argv=None) -> int:
    _name_safe_streams()
    try:
        # the code's warnings as "warning: ..." lines on stderr; its deep loops' progress as bars
        with warning_lines(), showing_progress(progress_bar):
            result = cli.main(args=argv, prog_name="mrcheck", standalone_mode=False)
    except MrcheckError as exc:
        click.echo(f"error: {exc}", err=True)
        return EXIT_ERROR
    except click.MissingParameter as exc:  # a malformed command line: usage and exit 2, below
        exc.show()
        return exc.exit_code
    except click.BadParameter as exc:
        # a bad option value is bad input like a bad file: one line and exit 1, not the usage text
        click.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
        return EXIT_ERROR
    except click.exceptions.Abort:
        click.echo("error: aborted", err=True)
        return EXIT_ERROR
    except click.ClickException as exc:
        exc.show()
        return exc.exit_code
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except KeyboardInterrupt:
        click.echo("error: interrupted", err=True)
        return 130
    except BrokenPipeError:  # the reader went away (`mrcheck ... | head`): nobody to tell, stop quietly
        # and point stdout at /dev/null, or Python's flush at exit reports the broken pipe again
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):  # no file descriptor (a captured stdout)
            pass
        return EXIT_ERROR
    except Exception as exc:  # a bug, not bad input: still one line; the traceback on request
        if os.environ.get("MRCHECK_DEBUG"):
            raise
        click.echo(
            f"error: internal error, please report it: {bug_reason(exc)} (MRCHECK_DEBUG=1 shows the traceback)",
            err=True,
        )
        return EXIT_ERROR
    # a command may return its own exit status (export: 1 when any shot failed)
    return result if isinstance(result, int) else 0


if __name__ == "__main__":
    sys.exit(main())
