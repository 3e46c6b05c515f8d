"""The ``coexist`` command group. Each subcommand parses options, calls the library, prints."""

from __future__ import annotations

import os

# The command line's linear algebra is on matrices of a few rows (one per group of identical zones); OpenBLAS's
# thread pool only costs there (measured on the default ramp: 0.1 s of CPU spinning beside 0.75 s of work, and
# slower on a busy machine). Set before numpy is first imported; a user's own setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import click  # noqa: E402

from coexist import __version__  # noqa: E402

#: each subcommand and where it lives: a command imports only its own module (start-up time)
COMMANDS = {
    "curves": ("curves", "curves"),
    "ramp": ("ramp", "ramp"),
    "coexistence": ("coexistence", "coexistence"),
    "phase-diagram": ("phase", "phase_diagram"),
    "fit": ("fit", "fit"),
    "scenes": ("scenes", "scenes"),
    "check": ("scenes", "check"),
    "accuracy": ("accuracy", "accuracy"),
    "sweep": ("sweep", "sweep"),
    "shape": ("shape", "shape"),
}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported when they are run (or listed by ``--help``)."""

    def list_commands(self, ctx):
        """The subcommands in the order of :data:`COMMANDS`."""
        return list(COMMANDS)

    def get_command(self, ctx, cmd_name):
        """The subcommand ``cmd_name``, imported now; None for an unknown name (click then says so)."""
        if cmd_name not in COMMANDS:
            return None
        import importlib

        module, attr = COMMANDS[cmd_name]
        return getattr(importlib.import_module(f"{__package__}.{module}"), attr)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="coexist")
def cli():
    """Inflated dielectric elastomer membranes: inflation curves, voltage actuation, phase coexistence.

    Data go to stdout (--json, --csv), progress and notes to stderr. Exit code 0 on success,
    2 for bad input, 1 when the physics or a solver fails (the message says why).
    """


def main():
    """Entry point of the ``coexist`` console script: runs :func:`cli` with the program name ``coexist``.

    Exit codes: 0 success, 2 bad input (click's usage errors and :class:`~coexist.errors.SceneError`: one line,
    ``Error: ...``, with a pointer to ``--help`` where click found the fault),
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
    except click.UsageError as exc:  # bad input: one line (click's own would add the usage and a hint above it)
        from .common import InputError

        where = exc.ctx.command_path if exc.ctx is not None else "coexist"
        hint = "" if isinstance(exc, InputError) else f" (see '{where} --help')"
        click.echo(f"Error: {exc.format_message()}{hint}", err=True)
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except RecursionError:
        click.echo("Error: the input is nested too deeply to be read", err=True)
        sys.exit(2)
    except Exception as exc:
        if os.environ.get("COEXIST_DEBUG"):
            raise
        import errno

        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.EROFS, errno.EFBIG):
            # not a bug: an output (a file, or stdout redirected to a full disk) could not be written; staged files
            # are already removed and existing ones untouched (Outputs)
            where = f" ({exc.filename})" if exc.filename else ""
            click.echo(f"Error: cannot write the output{where}: {exc.strerror or exc}", err=True)
            sys.exit(1)
        # a bug: say so in one line, keep the traceback for those who ask
        click.echo(
            f"internal error: {type(exc).__name__}: {exc} (please report it; COEXIST_DEBUG=1 shows where)", err=True
        )
        sys.exit(1)
    sys.exit(code if isinstance(code, int) else 0)
