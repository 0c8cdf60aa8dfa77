"""``breachflow run [SCENARIO.toml]``: the main job, the closure simulation (docs/theory.md, *The closure cycle*).

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

    from ..scenario import model_problem, typical_breach, typical_breach_growth
    from ..scenario.report import growth_table, max_length_table, window_table

    if console is None:
        from ._common import console as _console

        console = _console()
    results = model_problem()
    console.print(window_table([r.window for r in results], [r.name.replace("model problem, ", "") for r in results],
                               title="Model problem (report Table 2.5; docs/theory.md, Closure window: t_I = d_I / r_P = 10.0 h)"))
    scene = typical_breach()
    growth, max_len, time_to = typical_breach_growth(scene)
    console.print(growth_table(growth, time_to=time_to, title=(
        f"Typical breach (docs/theory.md, Breach growth): levee {scene.levee.height:.4g} m, crown {scene.levee.crown_width:.4g} m, "
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


DEFAULT_OUT = Path("runs/default")


def check_run_target(scenario: Path | None, out: Path, resume: bool, overwrite: bool) -> bool:
    """Decide, before anything is written, whether ``breachflow run`` may use *out*; returns *overwrite*.

    The caller holds the directory's lock (:meth:`~breachflow.io.RunDirectory.lock`). A run directory
    is never replaced without ``--overwrite``, whatever its scenario (the embedded default included) and
    state (finished, or stopped after some cycles): it is refused with the flags that would continue or
    replace it. ``--resume`` needs a run."""
    from ..cycle.main import default_scenario_text
    from ..errors import InputError
    from ..io import RunDirectory
    from ..io.rundir import scenario_hash

    rd = RunDirectory(out)
    if resume and overwrite:
        raise InputError("--resume continues a run and --overwrite replaces it: give one of them")
    if resume:
        if not rd.exists():
            raise InputError(f"{out}: nothing to resume (no run there); start it without --resume")
        return False
    if not rd.exists() or overwrite:
        return overwrite
    man = rd.manifest()
    is_default = man.get("scenario_sha256") == scenario_hash(default_scenario_text())
    meta = man.get("metadata", {})
    what = ("the embedded default scenario" if is_default else
            f"scenario {meta.get('scenario_path') or str(out / 'scenario.toml')!r}")
    done = len(man.get("cycles", []))
    state = "finished" if man.get("finished") else "unfinished"
    given = "" if scenario is None else f" with {scenario}"
    raise InputError(
        f"{out} holds a run of {what} ({state}, {done} cycle(s) complete, started {man.get('created', '?')}); "
        f"refusing to replace it{given}. Use --resume to continue it, --overwrite to replace it, "
        f"or another --out directory")


def run_closure_cli(scenario: Path | None, out: Path, resume: bool, overwrite: bool, plots: bool, console,
                    check: bool = True) -> None:
    """The closure run with a live progress line per cycle and a summary table; the console output (and
    warnings) also go to ``OUT/run.log``. With *check* (and ``[check] enabled``) the verdict is checked on
    other placement seeds and the next finer grid (:mod:`breachflow.ensemble.check`)."""
    from ..cycle.main import run_closure
    from ..progress import Progress
    from ._common import QUIET, VERBOSE, fmt, level

    # the scenario's set-up and the steady flow through the open breach come before cycle 1
    first = Progress("set-up and steady flow through the open breach (before cycle 1)", console=console,
                     quiet=level() <= QUIET)

    def progress(rep):
        from rich.markup import escape

        first.__exit__(None, None, None)

        crit = escape("[" + ", ".join(f"{c.name} {c.value:.3g}{' met' if c.satisfied else ''}" for c in rep.criteria) + "]")
        console.print(f"[bold]cycle {rep.cycle:3d}[/]  masses {rep.masses:4d}  max speed {rep.max_speed:5.2f} m/s  "
                      f"breach Q {rep.breach_discharge:7.2f} m³/s (seepage {rep.seepage_discharge:.2f})  "
                      f"gap speed {rep.gap_mean_speed:.2f} mean / {rep.gap_max_speed:.2f} max m/s  DEM {rep.dem_steps} steps"
                      f"{'' if rep.dem_converged else ' (cycle time limit)'}  {rep.hydro}  {crit}  "
                      f"{f'lost {rep.lost_cycle} ({rep.lost_cycle_tonnage:.1f} t)  ' if rep.lost_cycle else ''}"
                      f"{rep.wall_time:.1f} s", highlight=False)
        console.print(f"           tonnage {fmt(rep.tonnage, 't')}, operation time {fmt(rep.operation_time / 3600, 'h')}, "
                      f"stability: {rep.stability}, {rep.left_domain} left the domain", level=VERBOSE, highlight=False)
        if rep.verdict:
            console.print(f"[bold red]{escape(rep.verdict)}[/]", highlight=False)

    name = "embedded default scenario" if scenario is None and not resume else (
        f"scenario stored in {out}" if scenario is None else str(scenario))

    def on_start(run):  # the scenario is parsed and checked, the run directory started
        rd = run.rundir
        console.attach_log(rd.path / "run.log")
        console.print(f"closure run: {name} → {out}", highlight=False)
        for p in rd.swept:
            console.print(f"removed {p.name} (left by an interrupted run)", highlight=False)
        if resume:
            man = rd.manifest()
            last = rd.last_cycle()
            if man.get("finished") or (man["cycles"] and man["cycles"][-1]["summary"].get("closed")):
                console.print(f"the run in {out} is already finished after cycle {last}; nothing to do "
                              "(--overwrite runs it again)", highlight=False)
            elif last:
                console.print(f"resuming after cycle {last}", highlight=False)
                first.label = f"cycle {last + 1} (resumed after cycle {last})"  # no set-up: its flow is stored
            else:
                console.print("resuming: no cycle was complete, starting at cycle 1", highlight=False)

    try:
        with first:
            # with the check, the run's start state goes where the check's extra seeds take it from; the run
            # itself always solves it (a file the scenario names may have changed since an earlier run)
            from ..ensemble.check import START_STATES

            res = run_closure(scenario, out, resume=resume, overwrite=overwrite, progress=progress, plots=plots,
                              on_start=on_start, start_states=Path(out) / "check" / START_STATES if check else None,
                              take_start=False)
        rows = res.table_rows()
        checked = _check_cli(out, overwrite, console) if check else None
        if check and checked is None:  # [check] enabled = false: no extra seed takes the run's start state
            _drop_start_states(Path(out))
        if checked is not None:
            # the run's own "closed" stands only when the check confirms it (docs/verdict-check.md)
            # the run's own outcome is kept, but not called "closed" (docs/verdict-check.md)
            rows = [(k, v if k != "closure achieved" or checked.robust or not res.closed else
                     f"this run only (seed and cell size of the scenario): {str(v).replace('closed (', 'the dam held (', 1)}"
                     f"; verdict check: {checked.statement}")
                    for k, v in rows]
            rows += checked.rows() + [("check wall / CPU time", f"{checked.wall_time:.1f} s / {checked.cpu_time:.1f} s"),
                                      ("check results", str(Path(out) / "check.nc"))]
        console.print(summary_table(rows))
        if res.plan is not None:
            from ..cycle.plan import plan_lines

            for line in plan_lines(res.plan):
                console.print(line, highlight=False, markup=False)
        for p in res.plots:
            console.print(f"wrote {p}", highlight=False)
    except BaseException as exc:
        if console._log_file is not None:
            console._log.print(f"error: {type(exc).__name__}: {exc}")
        raise
    finally:
        console.detach_log()


def _drop_start_states(out: Path) -> None:
    """Remove the run's start state kept for a verdict check that does not run (and ``check/`` if it is
    then empty)."""
    import shutil

    from ..ensemble.check import START_STATES

    shutil.rmtree(out / "check" / START_STATES, ignore_errors=True)
    if (out / "check").is_dir() and not any((out / "check").iterdir()):
        (out / "check").rmdir()


def _check_cli(out: Path, overwrite: bool, console):
    """Run the verdict check of the finished run in *out* (unless ``[check] enabled = false``: None) and
    return its :class:`~breachflow.ensemble.check.CheckResult`."""
    from ..ensemble.check import CheckSection, run_check
    from ..io import RunDirectory
    from ..scenario import parse_scenario

    rd = RunDirectory(out)
    text = rd.scenario_text()
    path = rd.manifest().get("metadata", {}).get("scenario_path")
    path = Path(path) if path and Path(path).is_file() else None
    section = parse_scenario(text, path=path).get("check") or CheckSection()
    if not section.enabled:
        return None
    console.print("verdict check: other placement seeds and the next finer grid ([check]; --no-check skips it)",
                  highlight=False, markup=False)
    return run_check(out, text, path, section=section, console=console, fresh=overwrite)


def register(app: typer.Typer) -> None:
    @app.command()
    def run(
        scenario: Optional[Path] = typer.Argument(None, help="Scenario TOML file (default: the embedded closure scenario; "
                                                  "with --resume: the scenario stored in the run directory)."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Closure runs: the run directory (default "
                                           "runs/default). Calculator scenarios: the NetCDF file to write."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
        resume: bool = typer.Option(False, "--resume", help="Continue a closure run from its last complete cycle."),
        overwrite: bool = typer.Option(False, "--overwrite", help="Replace the run already in --out."),
        no_plots: bool = typer.Option(False, "--no-plots", help="Do not draw the plan-view and progress PNGs."),
        no_check: bool = typer.Option(False, "--no-check", help="Skip the verdict check (other placement seeds "
                                      "and the next finer grid, set in the scenario's check table) for a quick look."),
        plot: Optional[Path] = typer.Option(None, help="Calculator scenarios: write the Fig 2.6-style chart to this PNG."),
    ) -> None:
        """Run the closure simulation (default: the embedded scenario), or a calculator-only scenario file."""
        from ._common import console, pick_out

        con = console()
        out = pick_out(out, output)
        if scenario is not None and not _is_closure(scenario):
            _run_calculator(scenario, plot, out, con)
            return
        out = DEFAULT_OUT if out is None else out
        from ..io import RunDirectory

        # the lock first: nothing is checked or written in a directory another process works on
        with RunDirectory(out).lock() as lock:
            if lock.stale:
                from ..io.lock import describe

                con.print(f"note: a previous process died holding the lock of {out} ({describe(lock.stale)}); "
                          "its lock was taken over", highlight=False)
            overwrite = check_run_target(scenario, out, resume, overwrite)
            run_closure_cli(scenario, out, resume, overwrite, not no_plots, con, check=not no_check)

    @app.command("model-problem")
    def model_problem_cmd(
        plot: Optional[Path] = typer.Option(None, help="Write the Fig 2.6-style closure-window chart to this PNG."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Write the closure-window Dataset to NetCDF."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
    ) -> None:
        """The report's model problem (Table 2.5, hurricane and riverine) and the typical breach's growth."""
        from ._common import console, pick_out

        run_model_problem(console(), plot=plot, output=pick_out(out, output))

    @app.command()
    def combine(
        run_dir: Path = typer.Argument(..., help="A closure run directory."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Archive NetCDF to write."),
        output: Optional[Path] = typer.Option(None, "--output", hidden=True),
    ) -> None:
        """Combine a closure run's cycles into one NetCDF archive (trajectories in group 'trajectories')."""
        from ..io import RunDirectory
        from ._common import console, pick_out

        out = pick_out(out, output)
        if out is None:
            raise typer.BadParameter("give the archive to write with --out/-o", param_hint="--out")
        rd = RunDirectory(run_dir)
        problems = rd.verify()
        if problems:
            raise typer.BadParameter("; ".join(problems))
        console().print(f"wrote {rd.combine(out)} ({len(rd.completed_cycles())} cycles)", highlight=False)


def summary_table(rows):
    """The closure summary as a rich Table; *rows* are plain text (a warning's ``[placement]`` is no markup)."""
    from rich.markup import escape
    from rich.table import Table

    summary = Table(title="closure summary", show_header=False)
    summary.add_column("quantity")
    summary.add_column("value")
    for k, v in rows:
        summary.add_row(escape(k), escape(v))
    return summary
