"""``breachflow run``: the closure simulation of a scenario file (default: the embedded scenario).

:func:`run_closure` is the Python API; the CLI adds a progress display, the summary table and plots.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..scenario.config import parse_scenario
from .config import closure_setup
from .driver import ClosureRun, CycleReport

DEFAULT_SCENARIO = "closure_default.toml"


def default_scenario_text() -> str:
    return resources.files("breachflow.data").joinpath(DEFAULT_SCENARIO).read_text(encoding="utf-8")


@dataclass
class ClosureResult:
    """Summary of a closure run (SI)."""

    run_dir: Path
    reports: list[CycleReport]
    closed: bool
    governing: str
    cycles: int
    masses: int
    tonnage: float
    operation_time: float
    closure_window: float | None
    feasible: bool | None
    wall_time: float
    peak_speed: float
    plots: list = field(default_factory=list)
    verdict: str = ""  #: why the run ended without closure ("" when closed)
    lost_masses: int = 0  #: masses carried out of the breach area over the run
    lost_tonnage: float = 0.0  #: their tonnage (t)
    losses_flagged: bool = False  #: more than ``loss_limit`` of the placed tonnage lost
    #: the pre-simulation estimate (:func:`breachflow.scenario.stone.stone_size`) for the first cycle's
    #: peak speed and the breach cross-section, shown beside the simulated tonnage
    estimate: object = None
    #: breach discharge and its seepage part after the last cycle (m³/s)
    final_discharge: float = float("nan")
    final_seepage: float = 0.0
    #: breach discharge of the open breach, before the first mass (m³/s)
    open_breach_discharge: float = float("nan")
    #: sanity warnings: the scenario's (before the run) and the outcome's (masses lost or never at rest)
    warnings: list = field(default_factory=list)
    #: placement strategy (``[placement] positions``)
    strategy: str = ""
    #: the highest gap speeds over the closure cycles (depth-weighted mean and max in the gap section,
    #: :func:`~breachflow.cycle.criteria.gap_section_speeds`), m/s; the open breach's are in the manifest
    peak_gap_mean_speed: float = float("nan")
    peak_gap_max_speed: float = float("nan")
    #: the closure plan of a run in time (``[closure] method``; :func:`~breachflow.cycle.plan.closure_plan`)
    plan: dict | None = None

    @property
    def statement(self) -> str:
        """The outcome in one phrase: for a porous pile, "closed (overflow stopped); seepage X m³/s ... to be
        sealed with finer fill" — a rock-fill dam leaks, and the sealing must take that seepage; after a seal
        stage, the sealed dam's leakage and the polder rise it causes."""
        if not self.closed:
            return "not closed"
        seal = (self.plan or {}).get("seal") or {}
        if seal.get("sealed"):  # the rock dam's seepage was sealed: what is left is the sealed dam's leakage
            end = self.plan.get("leakage_end", {})
            rise = end.get("polder_rise_m_per_day")
            rise = f", a polder rise of {100 * rise:.2g} cm/day" if rise is not None else ""
            return (f"closed and sealed ({seal['seal_thickness_m']:.2f} m of seal, {seal['seal_tonnage_t']:,.0f} t): "
                    f"leakage {abs(end.get('breach_discharge_m3_s', float('nan'))):.2f} m³/s through the dam{rise}")
        seep = abs(self.final_seepage)
        if not seep > 0:
            return "closed"
        over = max(abs(self.final_discharge) - seep, 0.0)
        q0 = abs(self.open_breach_discharge)
        share = f" ({seep / q0:.0%} of the open breach's {q0:.1f} m³/s)" if q0 > 0 else ""
        return (f"closed (overflow stopped: {over:.2f} m³/s over the crest); seepage {seep:.2f} m³/s through the "
                f"pile{share} to be sealed with finer fill")

    def table_rows(self) -> list[tuple[str, str]]:
        hrs = lambda s: f"{s / 3600:.2f} h"
        rows = [("placement strategy", self.strategy or "-"), ("cycles", str(self.cycles)),
                ("masses placed", str(self.masses)),
                ("tonnage", f"{self.tonnage:.1f} t"), ("closure operation time", hrs(self.operation_time)),
                ("closure achieved", ("yes: " + self.statement if self.statement != "closed" else "yes")
                 if self.closed else "no"),
                ("governing criterion", self.governing or "-"),
                ("masses lost (carried out of the breach area)",
                 f"{self.lost_masses} ({self.lost_tonnage:.1f} t){' — FLAGGED' if self.losses_flagged else ''}")]
        if self.verdict:
            rows.append(("verdict", self.verdict))
        rows += [
                ("peak fluid speed (first cycle)", f"{self.peak_speed:.2f} m/s")]
        if self.closure_window is not None:
            rows.append(("closure window", hrs(self.closure_window)))
            rows.append(("closed inside the window", "yes" if self.feasible else "no"))
        rows.append(("peak gap speed over the cycles (mean / max in the gap section)",
                     f"{self.peak_gap_mean_speed:.2f} / {self.peak_gap_max_speed:.2f} m/s"))
        rows.append(("breach discharge at the end (seepage)",
                     f"{self.final_discharge:.2f} m³/s ({self.final_seepage:.2f} m³/s)"))
        if self.estimate is not None:
            e = self.estimate
            rows.append(("estimate (Izbash/Shields, before simulation)",
                         f"D {e.design_diameter:.2f} m, {e.tonnage:.1f} t (dam {e.height:.1f} m high, porosity "
                         f"{e.porosity:g}, slopes 1:{e.side_slope:g})"))
        for w in self.warnings:
            rows.append(("warning", w))
        rows.append(("wall time", f"{self.wall_time:.1f} s"))
        rows.append(("run directory", str(self.run_dir)))
        return rows


def run_closure(scenario=None, out="runs/default", *, resume: bool = False, overwrite: bool = False,
                progress=None, plots: bool = True, on_start=None, start_states=None,
                take_start: bool = True, weir_coefficient: float | None = None) -> ClosureResult:
    """Run the closure simulation of *scenario* (a TOML path, or None for the embedded default; with
    *resume* and no scenario, the ``scenario.toml`` stored in the run directory) in the run directory
    *out*; returns the :class:`ClosureResult`.

    The run directory's exclusive lock (:class:`~breachflow.io.lock.RunLock`) is taken first and held to
    the end (:class:`~breachflow.io.lock.RunLockedError` names the holder when another process has it);
    the scenario is parsed and checked in full before anything is written. *on_start(run)* is
    called with the :class:`~breachflow.cycle.driver.ClosureRun` once its directory is started or resumed, before any work.
    *start_states*: a directory of start states shared by runs that differ only in their placement seed
    (:mod:`breachflow.cycle.start_state`); with *take_start* false the run solves its start and only writes it
    there. *weir_coefficient* (m^0.5/s): the weir calibrations of the closure in time begin from it instead of the
    report's coefficient (the verdict check's finer grid: the coefficient the run calibrated; the run then
    shares no start state)."""
    from ..io import RunDirectory

    with RunDirectory(out).lock():  # held from before the first check until the plots are drawn
        return _run_closure_locked(scenario, out, resume=resume, overwrite=overwrite, progress=progress,
                                   plots=plots, on_start=on_start, start_states=start_states, take_start=take_start,
                                   weir_coefficient=weir_coefficient)


def _run_closure_locked(scenario, out, *, resume, overwrite, progress, plots, on_start, start_states,
                        take_start, weir_coefficient) -> ClosureResult:
    from ..io import RunDirectory

    t0 = _time.perf_counter()
    source = None
    if scenario is None and resume and RunDirectory(out).exists():
        rd = RunDirectory(out)
        text = rd.scenario_text()
        meta = rd.manifest().get("metadata", {})
        orig = Path(meta["scenario_path"]) if meta.get("scenario_path") else None
        # relative paths in the scenario resolve against where the scenario file was (if still there)
        anchor = orig if orig is not None and orig.is_file() else rd.path / "scenario.toml"
        sc = parse_scenario(text, path=anchor)
        source = meta.get("scenario_path")
    elif scenario is None:
        text = default_scenario_text()
        sc = parse_scenario(text)
    else:
        path = Path(scenario)
        text = _read_text(path)  # read once: the text parsed is the text stored in the run directory
        sc = parse_scenario(text, path=path)  # errors name the file and line
        source = str(path.resolve())
    setup = closure_setup(sc)
    run = ClosureRun(setup, out, text, resume=resume, overwrite=overwrite, progress=progress,
                     metadata={"scenario_path": source}, start_states=start_states, take_start=take_start,
                     weir_coefficient=weir_coefficient)
    if on_start is not None:
        on_start(run)
    run.run()
    man = run.rundir.manifest()
    cycles = man["cycles"]
    last = cycles[-1]["summary"] if cycles else {}
    closed = bool(man.get("final", {}).get("closed", last.get("closed")))  # with a seal: the sealed verdict
    window = None
    feasible = None
    if all(k in sc for k in ("flood", "polder", "breach")) and sc["polder"].inundation_depth is not None:
        from ..scenario import closure_window

        w = closure_window(**sc.window_kwargs())
        window = float(w["closure_window"])
        feasible = closed and last.get("operation_time", np.inf) <= window
    res = ClosureResult(run_dir=Path(out), reports=run.reports, closed=closed,
                        governing=last.get("governing", ""), cycles=len(cycles), masses=int(last.get("masses", 0)),
                        tonnage=float(last.get("tonnage", 0.0)), operation_time=float(last.get("operation_time", 0.0)),
                        closure_window=window, feasible=feasible, wall_time=_time.perf_counter() - t0,
                        peak_speed=float(cycles[0]["summary"]["max_speed"]) if cycles else float("nan"),
                        verdict=str(man.get("final", {}).get("verdict", "")),
                        lost_masses=int(last.get("left_domain", 0)), lost_tonnage=float(last.get("lost_tonnage", 0.0)),
                        losses_flagged=bool(last.get("losses_flagged", False)),
                        final_discharge=float(last.get("breach_discharge", float("nan"))),
                        final_seepage=float(last.get("seepage_discharge", 0.0)),
                        open_breach_discharge=float(man.get("metadata", {}).get("initial", {}).get(
                            "breach_discharge", float("nan"))),
                        estimate=_estimate(setup, man), strategy=setup.placement.positions,
                        peak_gap_mean_speed=peak_gap_speed(man, "gap_mean_speed"),
                        peak_gap_max_speed=peak_gap_speed(man, "gap_max_speed"))
    from .sanity import outcome_warnings

    res.warnings = list(setup.warnings) + outcome_warnings(
        int(last.get("left_domain", 0)), int(last.get("not_at_rest", 0)), res.masses,
        float(np.mean(setup.placement.diameter)),
        res.estimate.d_izbash_exposed if res.estimate is not None else None)
    if setup.timeline is not None:  # the closure in time: its plan (closure_plan.json, closure_plan.png)
        from .plan import write_closure_plan

        res.plan = write_closure_plan(run.rundir, setup, sc, plot=plots)
        if res.plan is not None:  # judged against the simulated polder and flood, not the linear model
            res.feasible = bool(res.plan["window"]["fits"])
        if res.plan is not None and res.plan.get("plot"):
            res.plots.append(Path(res.plan["plot"]))
    if plots and cycles:
        from .plots import plot_closure_progress, plot_plan_view

        res.plots = [plot_plan_view(run.rundir, Path(out) / "plan_view.png"),
                     plot_closure_progress(run.rundir, Path(out) / "closure_progress.png")] + res.plots
    return res


def _read_text(path: Path) -> str:
    from ..errors import InputError

    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read scenario ({exc.strerror})") from None


def peak_gap_speed(manifest, key: str = "gap_mean_speed", *, open_breach: bool = False) -> float:
    """The highest *key* (``gap_mean_speed`` | ``gap_max_speed``, m/s) of a run over its closure cycles
    (after each cycle's re-solve; with *open_breach* the initial solve too); NaN when there is none."""
    vals = [manifest.get("metadata", {}).get("initial", {}).get(key)] if open_breach else []
    vals += [c["summary"].get(key) for c in manifest.get("cycles", [])]
    vals = [float(v) for v in vals if v is not None]
    return max(vals) if vals else float("nan")


def _estimate(setup, manifest):
    """The stone-size estimate for the run's breach: the initial solve's peak speed, the water depth
    and length of the breach, rock of the placement's mean density, the pile's porosity and side slopes
    (``[placement] porosity`` and ``side_slope``, :attr:`~breachflow.cycle.placement.PlacementPlan.pile_porosity`)."""
    from ..errors import BreachflowError
    from ..scenario.stone import stone_size

    try:
        u = float(manifest["metadata"]["initial"]["max_speed"])
        depth = float(setup.flood_level - setup.bottom)
        length = float(setup.breach_x[1] - setup.breach_x[0])
        rho = float(np.mean(np.atleast_1d(setup.placement.density)))
        if not (u > 0 and depth > 0 and length > 0):
            return None
        return stone_size(u, depth, length, density=rho, porosity=setup.placement.pile_porosity,
                          side_slope=setup.placement.dam_side_slope)
    except (KeyError, BreachflowError):
        return None
