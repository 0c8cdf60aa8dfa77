"""``breachflow window``: closure window of a breach (docs/theory.md, *Closure window*), as a table and optionally a chart."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def window(
        surge_height: Optional[str] = typer.Option(None, help="Flood water height above ground at the breach at the crest, h_W, e.g. '2.8 m', '9.2 ft'."),
        fall_rate: Optional[str] = typer.Option(None, help="Flood stage fall rate after the crest, e.g. '40 cm/hr'."),
        rise_rate: Optional[str] = typer.Option(None, help="Flood stage rise rate before the crest (default: the fall rate)."),
        preset: Optional[str] = typer.Option(None, help="Flood preset from the report's Tables 2.3/2.4, e.g. 'katrina_2005' (see --list-presets)."),
        hydrograph: Optional[Path] = typer.Option(None, help="Measured flood-side stage CSV: 'time [h], stage [ft]'."),
        polder_area: Optional[str] = typer.Option(None, help="Polder area A_P, e.g. '800 ha', '2000 acre'."),
        inundation_depth: Optional[str] = typer.Option(None, help="Permissible average inundation depth d_I, e.g. '90 cm'."),
        discharge: Optional[str] = typer.Option(None, help="Breach discharge Q_D, e.g. '200 m^3/s', '7060 cfs'."),
        breach_length: Optional[str] = typer.Option(None, help="Breach length B; with --mean-velocity gives Q_D = h_W B v."),
        mean_velocity: Optional[str] = typer.Option(None, help="Mean velocity through the breach (default 3 m/s)."),
        pump_capacity: str = typer.Option("0 m^3/s", help="Polder pumping capacity Q_P."),
        breach_time: str = typer.Option("0 h", help="Breach time relative to the crest (negative: before)."),
        flood_duration: Optional[str] = typer.Option(None, help="How long the flood lasts after the crest."),
        wind: Optional[Path] = typer.Option(None, help="Wind-speed CSV 'time [h], speed [m/s]' relative to the crest."),
        wind_limit: str = typer.Option("land", help="Crane wind limit: 'land' (13 m/s), 'ship' (25 m/s) or a speed."),
        scenario: Optional[Path] = typer.Option(None, help="Take the inputs from a scenario TOML file (options override)."),
        plot: Optional[Path] = typer.Option(None, help="Write a Fig 2.6-style chart to this PNG file."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Write the result Dataset to NetCDF."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        list_presets: bool = typer.Option(False, "--list-presets", help="List the flood presets and exit."),
    ) -> None:
        """Closure window: breach balance time t_Q, polder inundation time t_I, window t_B = min(t_Q, t_I)."""
        from ..scenario import closure_window, load_scenario
        from ..scenario.report import window_grid_table, window_table
        from ._common import console as _console, pick_out

        console = _console()
        output = pick_out(out, output)
        if list_presets:
            _print_presets(console)
            return
        kwargs: dict = {}
        if scenario is not None:
            kwargs.update(load_scenario(scenario).window_kwargs())
        given = {
            "surge_height": surge_height, "fall_rate": fall_rate, "rise_rate": rise_rate, "preset": preset,
            "polder_area": polder_area, "inundation_depth": inundation_depth, "breach_discharge": discharge,
            "breach_length": breach_length, "mean_velocity": mean_velocity, "flood_duration": flood_duration,
        }
        from ..scenario.plausibility import check_value

        for option, value in {**given, "discharge": discharge, "pump_capacity": pump_capacity}.items():
            check_value(option, value)  # "5 parsecs" is a length, but no breach's
        if hydrograph is not None:
            given["hydrograph"] = hydrograph
            for key in ("surge_height", "fall_rate", "rise_rate", "preset"):
                kwargs.pop(key, None)
        if breach_length is not None:
            kwargs.pop("breach_discharge", None)
        if discharge is not None:
            kwargs.pop("breach_length", None)
            kwargs.pop("mean_velocity", None)
        kwargs.update({k: v for k, v in given.items() if v is not None})
        if scenario is None or pump_capacity != "0 m^3/s":
            kwargs["pump_capacity"] = pump_capacity
        if scenario is None or breach_time != "0 h":
            kwargs["breach_time"] = breach_time
        if wind is not None:
            kwargs.update(wind=wind, wind_limit=wind_limit)
        missing = [k for k in ("polder_area", "inundation_depth") if k not in kwargs]
        if missing:
            raise typer.BadParameter(f"missing {', '.join('--' + m.replace('_', '-') for m in missing)}")
        from ..errors import BreachflowError
        from ._common import cli_flags, flags_of

        try:
            ds = closure_window(**kwargs)
        except BreachflowError as exc:
            names = flags_of(k for k, v in given.items() if v is not None)
            names.update({"breach_discharge": "--discharge", "pump_capacity": "--pump-capacity",
                          "breach_time": "--breach-time", "wind_limit": "--wind-limit"})
            raise cli_flags(exc, names)
        if ds["closure_window"].ndim == 0:
            console.print(window_table([ds], ["value"], title="Breach closure window (docs/theory.md, Closure window)"))
        else:
            console.print(window_grid_table(ds))
        if output is not None:
            from ..scenario.io import write_netcdf

            write_netcdf(ds, output)
            console.print(f"wrote {output}")
        if plot is not None:
            from ..scenario.plots import window_chart

            window_chart(ds, plot)
            console.print(f"wrote {plot}")


def _print_presets(console) -> None:
    from rich.table import Table

    from ..scenario import flood_presets

    table = Table(title="Flood presets (report Tables 2.3, 2.4; generic)", title_justify="left")
    table.add_column("name", no_wrap=True)
    table.add_column("event")
    for col in ("rise cm/h", "fall cm/h", "h_W m"):
        table.add_column(col, justify="right")
    for p in flood_presets():
        where = ", ".join(x for x in (p.location, p.date) if x)
        table.add_row(p.key, p.event + (f" ({where})" if where else ""), f"{p.rise_rate * 3.6e5:.3g}",
                      f"{p.fall_rate * 3.6e5:.3g}", "—" if p.surge_height is None else f"{p.surge_height:g}")
    console.print(table)
