"""The ``breachflow`` command-line program.

Each subcommand group lives in its own module of this package and exposes ``register(app)``; modules
are discovered automatically, so a new capability adds a file here and touches nothing else.
"""
from __future__ import annotations

import importlib
import pkgutil

import typer

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

@app.callback()
def _root() -> None:
    """Levee-breach closure simulation (see `breachflow COMMAND --help`)."""


for _mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
    if not _mod.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_mod.name}").register(app)


def main() -> None:
    """Console-script entry point; turns breachflow errors into a one-line message and exit code 2."""
    from ..errors import BreachflowError

    try:
        app()
    except BreachflowError as exc:
        from rich.console import Console

        from rich.markup import escape

        Console(stderr=True).print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False)
        raise SystemExit(2) from None
