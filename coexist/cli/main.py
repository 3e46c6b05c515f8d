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
    """Entry point of the ``coexist`` console script: runs :func:`cli` with the program name ``coexist``."""
    cli(prog_name="coexist")
