"""``breachflow run [SCENARIO.toml]``: the main job, the closure simulation (SPEC §7).

Without a file it runs the embedded default closure scenario. A scenario file with closure sections
(``[site]``, ``[hydro]``, ``[dem]``, ``[fluid]``, ``[placement]``, ``[criteria]``, ``[closure]``) runs the
closure; one with only calculator sections (``[flood]``, ``[polder]``, ``[breach]``...) runs the
scenario calculator. ``breachflow model-problem`` is the calculator on the report's model problem
(Table 2.5) and the typical breach's growth; ``breachflow combine`` turns a run directory into one archive.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def run_model_problem(console=None, plot: Path | None = None, output: Path | None = None):
    """Print the model problem's closure windows and the typical breach's growth; return the results."""
    from rich.console import Console

    from ..scenario import model_problem, typical_breach, typical_breach_growth
    from ..scenario.report import growth_table, max_length_table, window_table

    console = console or Console()
    results = model_problem()
    console.print(window_table([r.window for r in results], [r.name.replace("model problem, ", "") for r in results],
                               title="Model problem (report Table 2.5; SPEC §2: t_I = d_I / r_P = 10.0 h)"))
    scene = typical_breach()
    growth, max_len, time_to = typical_breach_growth(scene)
    console.print(growth_table(growth, time_to=time_to, title=(
        f"Typical breach (SPEC §3): levee {scene.levee.height} m, crown {scene.levee.crown_width} m, "
        f"1V:{scene.levee.flood_slope:g}H (A_L = {scene.levee.area:.0f} m²), water at the crest: "
        "breach length B (m) vs development time t_D")))
    console.print(max_length_table(max_len, title=f"Maximum breach length for h_W = {scene.surge_height:g} m (Table 2.9)"))
    if plot is not None:
        from ..scenario.plots import window_chart

        window_chart([r.window for r in results], plot, titles=[r.name for r in results])
        console.print(f"wrote {plot}")
    if output is not None:
        _write(results, output, console)
    return results


def _write(results, output: Path, console) -> None:
    import xarray as xr

    from ..scenario.io import write_netcdf

    if len(results) == 1:
        ds = results[0].window
    else:
        names = [r.name for r in results]
        ds = xr.concat([r.window for r in results], dim=xr.DataArray(names, dims="case", name="case"),
                       coords="minimal", compat="override", join="outer")
    write_netcdf(ds, output)
    console.print(f"wrote {output}")


CLOSURE_SECTIONS = {"site", "hydro", "dem", "fluid", "placement", "criteria", "closure"}


def _run_calculator(scenario: Path, plot, output, console) -> None:
    from ..scenario import run_scenario
    from ..scenario.report import growth_table, max_length_table, window_grid_table, window_table

    result = run_scenario(scenario)
    if result.description:
        console.print(f"[bold]{result.name}[/]: {result.description}")
    if result.window is not None:
        ds = result.window
        if ds["closure_window"].ndim == 0:
            console.print(window_table([ds], [result.name]))
        else:
            console.print(window_grid_table(ds, title=f"Breach closure window — {result.name}"))
    if result.growth is not None:
        console.print(growth_table(result.growth))
    if result.max_length is not None and result.max_length.ndim == 1:
        console.print(max_length_table(result.max_length))
    if plot is not None and result.window is not None:
        from ..scenario.plots import window_chart

        window_chart(result.window, plot, titles=[result.name])
        console.print(f"wrote {plot}")
    if output is not None and result.window is not None:
        _write([result], output, console)


def _is_closure(scenario: Path) -> bool:
    import tomllib

    try:
        data = tomllib.loads(scenario.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError):
        return True  # let the closure loader report the problem with file and line
    return bool(CLOSURE_SECTIONS & set(data))


def run_closure_cli(scenario: Path | None, out: Path, resume: bool, overwrite: bool, plots: bool, console) -> None:
    """The closure run with a live progress line per cycle and a summary table."""
    from rich.table import Table

    from ..cycle.main import run_closure

    def progress(rep):
        from rich.markup import escape

        crit = escape("[" + ", ".join(f"{c.name} {c.value:.3g}{' met' if c.satisfied else ''}" for c in rep.criteria) + "]")
        console.print(f"[bold]cycle {rep.cycle:3d}[/]  masses {rep.masses:4d}  max speed {rep.max_speed:5.2f} m/s  "
                      f"breach Q {rep.breach_discharge:7.2f} m³/s  DEM {rep.dem_steps} steps"
                      f"{'' if rep.dem_converged else ' (cycle time limit)'}  {rep.hydro}  {crit}  "
                      f"{rep.wall_time:.1f} s", highlight=False)

    console.print(f"closure run: {'embedded default scenario' if scenario is None else scenario} → {out}")
    res = run_closure(scenario, out, resume=resume, overwrite=overwrite, progress=progress, plots=plots)
    summary = Table(title="closure summary", show_header=False)
    summary.add_column("quantity")
    summary.add_column("value")
    for k, v in res.table_rows():
        summary.add_row(k, v)
    console.print(summary)
    for p in res.plots:
        console.print(f"wrote {p}")


def register(app: typer.Typer) -> None:
    @app.command()
    def run(
        scenario: Optional[Path] = typer.Argument(None, help="Scenario TOML file (default: the embedded closure scenario)."),
        out: Path = typer.Option(Path("runs/default"), "--out", help="Run directory of a closure run."),
        resume: bool = typer.Option(False, "--resume", help="Continue a closure run from its last complete cycle."),
        overwrite: bool = typer.Option(False, "--overwrite", help="Replace a previous run in --out."),
        no_plots: bool = typer.Option(False, "--no-plots", help="Do not draw the plan-view and progress PNGs."),
        plot: Optional[Path] = typer.Option(None, help="Calculator scenarios: write the Fig 2.6-style chart to this PNG."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Calculator scenarios: write the window to NetCDF."),
    ) -> None:
        """Run the closure simulation (default: the embedded scenario), or a calculator-only scenario file."""
        from rich.console import Console

        console = Console()
        if scenario is not None and not _is_closure(scenario):
            _run_calculator(scenario, plot, output, console)
            return
        if scenario is None and not resume and not overwrite and (out / "manifest.json").exists():
            overwrite = True  # the default command is meant to be re-runnable as is
        run_closure_cli(scenario, out, resume, overwrite, not no_plots, console)

    @app.command("model-problem")
    def model_problem_cmd(
        plot: Optional[Path] = typer.Option(None, help="Write the Fig 2.6-style closure-window chart to this PNG."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Write the closure-window Dataset to NetCDF."),
    ) -> None:
        """The report's model problem (Table 2.5, hurricane and riverine) and the typical breach's growth."""
        run_model_problem(plot=plot, output=output)

    @app.command()
    def combine(
        run_dir: Path = typer.Argument(..., help="A closure run directory."),
        output: Path = typer.Option(..., "--output", "-o", help="Archive NetCDF to write."),
    ) -> None:
        """Combine a closure run's cycles into one NetCDF archive (trajectories in group 'trajectories')."""
        from ..output import RunDirectory

        rd = RunDirectory(run_dir)
        problems = rd.verify()
        if problems:
            raise typer.BadParameter("; ".join(problems))
        typer.echo(f"wrote {rd.combine(output)} ({len(rd.completed_cycles())} cycles)")
