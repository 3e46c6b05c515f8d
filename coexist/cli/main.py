"""The ``coexist`` command group. Each subcommand parses options, calls the library, prints."""

from __future__ import annotations

import click

from coexist import __version__

from .accuracy import accuracy
from .coexistence import coexistence
from .curves import curves
from .fit import fit
from .phase import phase_diagram
from .ramp import ramp
from .scenes import check, scenes


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="coexist")
def cli():
    """Inflated dielectric elastomer membranes: inflation curves, voltage actuation, phase coexistence.

    Data go to stdout (--json, --csv), progress and notes to stderr. Exit code 0 on success,
    2 for bad input, 1 when the physics or a solver fails (the message says why).
    """


cli.add_command(curves)
cli.add_command(ramp)
cli.add_command(coexistence)
cli.add_command(phase_diagram)
cli.add_command(fit)
cli.add_command(scenes)
cli.add_command(check)
cli.add_command(accuracy)


def main():
    """Entry point of the ``coexist`` console script: runs :func:`cli` with the program name ``coexist``.

    Exit codes: 0 success, 2 bad input (click's usage errors and :class:`~coexist.errors.SceneError`),
    1 when the physics or a solver fails, 130 when interrupted (Ctrl-C). An unexpected exception (a bug)
    is one line on stderr with exit code 1; ``COEXIST_DEBUG=1`` shows its traceback.
    """
    import os
    import sys

    try:
        code = cli.main(prog_name="coexist", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("interrupted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except RecursionError:
        click.echo("Error: the input is nested too deeply to be read", err=True)
        sys.exit(2)
    except Exception as exc:  # a bug: say so in one line, keep the traceback for those who ask
        if os.environ.get("COEXIST_DEBUG"):
            raise
        click.echo(
            f"internal error: {type(exc).__name__}: {exc} (please report it; COEXIST_DEBUG=1 shows where)", err=True
        )
        sys.exit(1)
    sys.exit(code if isinstance(code, int) else 0)
