"""``breachflow growth``: breach length vs development time by the report's empirical equations (docs/theory.md, *Breach growth*)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def growth(
        equation: List[str] = typer.Option(["all"], "--equation", "-e", help="Growth equation name or number (2.2-2.8, resio_*); repeat; 'all'."),
        levee_height: Optional[str] = typer.Option(None, help="Levee height h_L, e.g. '10 ft' (default: the typical breach's 7.6 m)."),
        crown_width: str = typer.Option("3 m", help="Levee crown width b."),
        side_slope: float = typer.Option(3.0, help="Levee side slopes 1V:mH, m (both sides)."),
        surge_height: Optional[str] = typer.Option(None, help="Water height h_W (default: the levee height, water at the crest)."),
        hours: List[str] = typer.Option(["0.5 h", "1 h", "2 h", "4 h", "8 h"], "--time", "-t", help="Development times to tabulate (repeat)."),
        max_length: Optional[str] = typer.Option(None, help="Cap: a length ('60 m') or a maximum-length equation (2.9, 2.10, 2.11 / nagy ...)."),
        plot: Optional[Path] = typer.Option(None, help="Write Fig 2.15-style growth curves to this PNG (default levees: the report's 3.0 m and 4.6 m; with --levee-height that levee)."),
        plot_hours: float = typer.Option(8.0, help="Time axis length of the plot (h)."),
    ) -> None:
        """Breach length B vs development time t_D (report Table 2.8) and maximum breach length (Table 2.9)."""
        import warnings

        from ..errors import BreachflowError, BreachflowWarning
        from ._common import cli_flags, console as _console
        from ..scenario import LeveeGeometry, breach_length, max_breach_length, typical_breach
        from ..scenario.report import growth_table, max_length_table

        console = _console()
        if levee_height is None:
            levee = typical_breach().levee
            note = "typical breach levee (7.6 m, crown 3.0 m, 1V:4H)"
        else:
            try:
                levee = LeveeGeometry.from_input(height=levee_height, crown_width=crown_width, flood_slope=side_slope,
                                                 protected_slope=side_slope)
            except BreachflowError as exc:
                raise cli_flags(exc, {"height": "--levee-height", "crown_width": "--crown-width",
                                      "flood_slope": "--side-slope", "protected_slope": "--side-slope"})
            note = f"levee h_L = {levee.height:.2f} m, crown {levee.crown_width:.2f} m, 1V:{side_slope:g}H"
        eq = equation[0] if len(equation) == 1 and equation[0] != "all" else ("all" if equation == ["all"] else equation)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BreachflowWarning)
            try:
                da = breach_length(eq if eq != "all" else "all", list(hours), surge_height=surge_height, levee=levee,
                                   max_length=max_length)
            except BreachflowError as exc:
                raise cli_flags(exc, {"surge_height": "--surge-height", "max_length": "--max-length",
                                      "development_time": "--time", "equation": "--equation"})
        h_w = surge_height or f"{levee.height:.6g} m"
        console.print(growth_table(da, title=f"Breach length B (m) vs development time t_D — {note}, h_W = {h_w}"))
        for w in caught:
            console.print(f"[yellow]note:[/] {w.message}")
        console.print(max_length_table(max_breach_length("all", h_w), title=f"Maximum breach length for h_W = {h_w}"))
        if plot is not None:
            from ..scenario.plots import growth_chart

            levees = None if levee_height is None else [levee]
            growth_chart(plot, levees=levees, surge_height=surge_height, equations=eq, hours=plot_hours,
                         max_length=max_length)
            console.print(f"wrote {plot}")
