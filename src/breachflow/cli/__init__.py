"""The ``breachflow`` command-line program.

Each subcommand group lives in its own module of this package and exposes ``register(app)``; modules
are discovered automatically, so a new capability adds a file here and touches nothing else.
"""
from __future__ import annotations

import importlib
import pkgutil

import typer
import typer.rich_utils

from . import _help
from ._common import help_width

_help.install()

if help_width() is not None and typer.rich_utils.MAX_WIDTH is None:  # TERMINAL_WIDTH, if set, wins
    typer.rich_utils.MAX_WIDTH = help_width()

app = typer.Typer(
    name="breachflow",
    help=(
        "Levee-breach closure: closure windows, breach growth, hydrodynamic snapshots, "
        "shallow-water and DEM simulation of dropped masses."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

def _version(value: bool) -> None:
    if value:
        from .. import __version__
        from ..provenance import git_commit

        commit = git_commit()
        typer.echo(f"breachflow {__version__}" + (f" (git {commit})" if commit else ""))
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the breachflow version (and git commit) and exit."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Only warnings and errors on the console "
                               "(a run's run.log still gets everything)."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="More detail, and full tracebacks on errors."),
) -> None:
    """Levee-breach closure simulation (see `breachflow COMMAND --help`)."""
    from . import _common

    if quiet and verbose:
        raise typer.BadParameter("--quiet and --verbose exclude each other")
    _common.reset()
    _common.set_level(_common.QUIET if quiet else _common.VERBOSE if verbose else _common.NORMAL)
    _common.install_warning_hook()


for _mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _mod.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_mod.name}").register(app)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point (also ``python -m breachflow``): breachflow errors become a one-line
    message and exit code 2 (``--verbose``: with the traceback); so does a full disk anywhere."""
    import errno
    import sys

    from ..errors import BreachflowError, DiskFullError
    from .. import provenance
    from . import _common

    argv = list(sys.argv[1:] if argv is None else argv)
    provenance.set_command(argv)
    try:
        app(args=argv, prog_name="breachflow")
    except (BreachflowError, OSError) as exc:
        if isinstance(exc, OSError) and not isinstance(exc, BreachflowError):
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
                raise
            exc = DiskFullError(exc.filename or "?", exc.strerror or "")
        from rich.markup import escape

        con = _common.err_console()
        if _common.level() >= _common.VERBOSE:
            import traceback

            con.print(escape("".join(traceback.format_exception(exc))), level=_common.QUIET, highlight=False)
        msg = f"[bold red]error:[/] {escape(str(exc))}"
        if isinstance(exc, DiskFullError):
            msg += "\nfree some space and run the command again (a closure run continues where it stopped with --resume)"
        con.print(msg, level=_common.QUIET, highlight=False)
        out = _common.console()
        if out._log_file is not None:
            out._log.print(f"error: {exc}")
        _common.reset()
        raise SystemExit(2) from None
    finally:
        _common.reset()
