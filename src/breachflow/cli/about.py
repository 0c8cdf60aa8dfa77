"""``breachflow version``: version and the registered plug-ins."""
from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def version() -> None:
        """Print the breachflow version."""
        from .. import __version__

        typer.echo(f"breachflow {__version__}")
