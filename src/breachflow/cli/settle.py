"""``breachflow settle``: the report's settling-sphere validation (docs/validation.md, *Settling spheres*, Fig 5.2)."""
from __future__ import annotations

from pathlib import Path
from typing import List

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def settle(
        diameter: List[str] = typer.Option(["3 mm", "10 mm", "80 mm"], help="sphere diameters (with units)"),
        density: str = typer.Option("7800 kg/m^3", help="particle density"),
        drag_law: List[str] = typer.Option(["report", "clift_gauvin", "morrison"], help="drag laws to compare"),
        dt: str = typer.Option("1e-5 s", help="time step of the DEM integrator"),
        duration: str = typer.Option("1 s", help="simulated time"),
        integrator: str = typer.Option("report", help="DEM integrator or free-flight method (dopri5, rk4)"),
        out: Path = typer.Option(Path("settling"), "--out", "-o", help="output directory (NetCDF, CSV, PNG)"),
    ) -> None:
        """Spheres settling from rest in still water: velocity–time curves, plot, terminal velocities."""
        from rich.table import Table

        from ..progress import Progress
        from ._common import QUIET, console, level

        from ..studies.validation import drag_crisis_time, save_settling, settling_curves
        from ..units import to_si

        ds_ = [to_si(d, name="--diameter", kind="length", default_unit="m", positive=True) for d in diameter]
        con = console()
        with Progress("settling", unit="records", console=con, quiet=level() <= QUIET) as bar:
            def progress(j, r, n):
                bar.update(j * n + r, total=len(drag_law) * n, note=drag_law[j])

            ds = settling_curves(ds_, to_si(density, name="--density", kind="density", positive=True), tuple(drag_law),
                             dt=to_si(dt, name="--dt", kind="time", default_unit="s", positive=True),
                             duration=to_si(duration, name="--duration", kind="time", default_unit="s", positive=True),
                             integrator=integrator, progress=progress)
        paths = save_settling(ds, out)
        table = Table(title="settling spheres")
        for col in ("drag law", "D (mm)", "v(end) m/s", "v_t root m/s", "C_D < 0.3 at (s)"):
            table.add_column(col)
        for law in ds["drag_law"].values:
            for d in ds["diameter"].values:
                t_c = drag_crisis_time(ds, law, d)
                table.add_row(str(law), f"{d * 1e3:g}",
                              f"{float(ds['velocity'].sel(drag_law=law, diameter=d)[-1]):.4f}",
                              f"{float(ds['terminal_velocity'].sel(drag_law=law, diameter=d)):.4f}",
                              "-" if t_c is None else f"{t_c:.3f}")
        con.print(table)
        for kind, p in paths.items():
            con.print(f"{kind}: {p}", highlight=False)
