"""The verdict check of a closure run: other placement seeds and the next finer grid.

A closure verdict computed once, at one cell size and one random placement, can hang on either: a mass
that rolls at 8 m/s on the breach floor stays at a gap speed of 7.9 m/s and is carried away at 8.1 m/s,
and the gap speed of a coarse grid is a few per cent below that of a finer one. ``breachflow run``
therefore checks its answer (``[check]``, on by default; ``--no-check`` for a quick look):

* ``seeds`` placement seeds at the run's cell size (the run's own seed and the next ``seeds - 1``);
* with ``refine`` the next finer grid: the cell size halved (``grid = "uniform"``) or a nested grid of
  half the cell size around the breach (``grid = "nested"``, ``[hydro] refine``), on which the open
  breach is solved (its breach discharge and gap speed against the run's) and ``refine_seeds`` closures
  are run. The gap speed judged is the mean speed at the breach's control section, where the flow passes
  critical depth (:func:`breachflow.cycle.criteria.control_speed`): it converges with the discharge, where
  the speed past the control, on the levee line, keeps rising as the grid resolves the jet behind square
  breach heads (docs/verdict-check.md, *The gap speed that converges*); that one is reported, not judged.

The extra closures are the members of an ensemble (:mod:`breachflow.ensemble`, member runner
``closure``, design ``members``) in ``RUN/check/``: resumed member by member, run in parallel with
``workers > 1`` (dask), each in its own run directory; the extra seeds take the run's start state (the
solves before cycle 1, which do not depend on the seed) from ``RUN/check/start_states/``
(:mod:`breachflow.cycle.start_state`) instead of solving it again; the finer grid's weir calibrations begin
from the coefficient the run calibrated (so that the grids are compared at the same polder level when the finer
grid's discharge is within the calibration's tolerance, with one solve where from the report's coefficient it
takes several). The summary — P(closure) with its Wilson 95 %
interval, the tonnage in place over seeds × grids and per grid, the open breach's flow on both grids — is
written to ``RUN/check.nc`` and to the manifest's ``metadata.check``; the statement says "closed" only when
every run closed, the grids agree on the flow within ``tolerance`` and their tonnage ranges over the seeds
overlap, and names the disagreement otherwise ("grid-dependent: closed at 4 m, not closable at 2 m"; "closed
in every run, but unconfirmed; the tonnage depends on the grid (...)").
"""
from __future__ import annotations

import json
import math
import time as _time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..scenario.config import register_section

GRIDS = ("uniform", "nested")
#: steady windows the check marches each grid's open breach on after its steady test accepts it (``[check]
#: flow_mean_windows``): the second half is averaged (docs/verdict-check.md, *The open breach's flow as a time mean*)
FLOW_MEAN_WINDOWS = 4
#: batches of the march's averaged half (:func:`breachflow.swe.steady_mean.series_mean`)
FLOW_MEAN_BATCHES = 8
#: samples of the march per check interval of the steady test (:func:`open_breach_mean`)
FLOW_MEAN_SAMPLES = 4
#: the flow figures a marched open breach carries with their errors (:class:`CheckRun`)
FLOW_FIGURES = ("discharge", "control_speed", "gap_mean_speed", "gap_max_speed")
#: the folder of ``RUN/check/`` holding the start states the run and its extra seeds share
#: (:mod:`breachflow.cycle.start_state`; ``breachflow run`` writes the run's own there)
START_STATES = "start_states"


@register_section("check")
@dataclass
class CheckSection:
    """``[check]``: ``enabled`` (default true), ``seeds`` (placement seeds at the run's cell size, the
    run's own included; default 3), ``refine`` (also the next finer grid; default true), ``grid``
    (``uniform``: the whole domain at half the cell size; ``nested``: a nested grid of half the cell size
    around the breach), ``refine_seeds`` (closures on the finer grid, 0: only its open-breach solve;
    default 1), ``tolerance`` (relative difference of the open breach's discharge and gap speed between
    the grids above which the flow is called grid-dependent; default 0.02), ``flow_mean_windows`` (the open
    breach is solved on both grids and marched on for this many steady windows after its steady test accepts
    it; the grids' flows are compared as the time means of the march's second half with their errors
    (:func:`open_breach_mean`); default 4; 0: the states the steady test first accepts), ``workers``
    (processes for the extra closures; default 1, in this process)."""

    enabled: bool = True
    seeds: int = 3
    refine: bool = True
    grid: str = "uniform"
    refine_seeds: int = 1
    tolerance: float = 0.02
    flow_mean_windows: int = FLOW_MEAN_WINDOWS
    workers: int = 1

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"enabled", "seeds", "refine", "grid", "refine_seeds", "tolerance", "flow_mean_windows",
                               "workers"})
        out = cls(enabled=ctx.raw(table, "enabled", types=(bool,), default=True),
                  seeds=ctx.raw(table, "seeds", types=(int,), default=3),
                  refine=ctx.raw(table, "refine", types=(bool,), default=True),
                  grid=ctx.raw(table, "grid", default="uniform"),
                  refine_seeds=ctx.raw(table, "refine_seeds", types=(int,), default=1),
                  tolerance=ctx.quantity(table, "tolerance", "dimensionless", default=0.02, default_unit="",
                                         positive=True),
                  flow_mean_windows=ctx.raw(table, "flow_mean_windows", types=(int,), default=FLOW_MEAN_WINDOWS),
                  workers=ctx.raw(table, "workers", types=(int,), default=1))
        if isinstance(out.seeds, bool) or out.seeds < 1:
            raise ctx.error(f"seeds = {out.seeds!r}: needs at least 1 (the run's own)", "seeds")
        if isinstance(out.refine_seeds, bool) or not 0 <= out.refine_seeds <= out.seeds:
            raise ctx.error(f"refine_seeds = {out.refine_seeds!r}: needs 0 <= refine_seeds <= seeds = {out.seeds}",
                            "refine_seeds")
        if out.grid not in GRIDS:
            raise ctx.error(f"grid = {out.grid!r}; use one of {list(GRIDS)}", "grid")
        if isinstance(out.flow_mean_windows, bool) or out.flow_mean_windows < 0:
            raise ctx.error(f"flow_mean_windows = {out.flow_mean_windows!r}: needs a whole number >= 0 (0: no march)",
                            "flow_mean_windows")
        if isinstance(out.workers, bool) or out.workers < 1:
            raise ctx.error(f"workers = {out.workers!r}: needs at least 1", "workers")
        return out


@dataclass
class CheckRun:
    """One closure of the check (or the run itself): its grid, seed and outcome."""

    label: str            #: "4 m", "2 m", "2 m nested"
    cell_size: float      #: m, the finest cell size at the breach
    seed: int
    closed: bool | None   #: None: only the open breach was solved
    verdict: str = ""
    tonnage: float = math.nan        #: placed, t
    lost_tonnage: float = math.nan   #: carried out of the breach area, t
    cycles: int = 0
    discharge: float = math.nan      #: open breach's discharge, m³/s
    gap_mean_speed: float = math.nan  #: open breach's depth-weighted mean gap speed, m/s
    gap_max_speed: float = math.nan
    #: open breach's mean speed at its control section (where the flow passes critical depth), m/s
    control_speed: float = math.nan
    cpu: float = math.nan            #: CPU s of the closure (or solve), NaN when unknown
    #: tonnage in place after the cycle before the last (t; NaN: not known). A closure is judged after each load,
    #: so a run that closed needed more than this and at most :attr:`in_place` (:attr:`needed`)
    in_place_before: float = math.nan
    own: bool = False                #: the checked run itself
    error: str = ""
    #: open breach marched on (:func:`open_breach_mean`): the simulated time (s) its flow figures are the means
    #: over, 0 for a single state; the errors of the means (same units as the figures; NaN: a single state)
    mean_interval: float = 0.0
    discharge_error: float = math.nan
    control_speed_error: float = math.nan
    gap_mean_speed_error: float = math.nan
    gap_max_speed_error: float = math.nan

    @property
    def in_place(self) -> float:
        return self.tonnage - (self.lost_tonnage if np.isfinite(self.lost_tonnage) else 0.0)

    @property
    def needed(self) -> tuple[float, float]:
        """``(low, high)`` (t): the closure needed more than the tonnage in place before its last load (*low*:
        not enough) and at most the tonnage after it (*high*); without the one before, ``low = high`` = the tonnage
        in place, which then counts as enough (:func:`tonnage_overlap`)."""
        before = self.in_place_before
        return (float(before) if np.isfinite(before) else float(self.in_place), float(self.in_place))

    @property
    def outcome(self) -> str:
        if self.error:
            return "failed"
        if self.closed is None:
            return "open breach only"
        return "closed" if self.closed else ("not closable" if "not closable" in self.verdict else "not closed")


@dataclass
class CheckResult:
    """The check's runs and its reading of them."""

    runs: list[CheckRun]
    tolerance: float
    #: the verdict in words, without the bed model (:attr:`statement` adds it)
    verdict: str = ""
    robust: bool = False
    p_closure: float = math.nan
    p_interval: tuple = (math.nan, math.nan)
    tonnage_range: tuple = (math.nan, math.nan)   #: tonnage in place over the closed runs (t)
    #: per grid label, the tonnage of its closed runs (:class:`GridTonnage`)
    tonnage_by_grid: dict = field(default_factory=dict)
    #: the grids' ranges of the tonnage needed do not overlap (:func:`tonnage_overlap`): it depends on the cell size
    tonnage_grid_dependent: bool = False
    flow_difference: dict = field(default_factory=dict)  #: relative difference fine vs coarse
    #: the error of each relative difference when both grids' figures are time means (:func:`open_breach_mean`)
    flow_difference_error: dict = field(default_factory=dict)
    #: the simulated time (s) each grid's open-breach figures were averaged over (both 0: single states)
    flow_mean_intervals: tuple = (0.0, 0.0)
    wall_time: float = 0.0
    cpu_time: float = 0.0
    #: the bed model the runs used, in words (:func:`bed_model`): the verdict holds for that bed
    bed: str = ""

    @property
    def statement(self) -> str:
        """The verdict and the bed model it holds for."""
        return self.verdict + (f" — bed: {self.bed}" if self.bed else "")

    def rows(self) -> list[tuple[str, str]]:
        """Lines of the run's summary table (the bed model in its own row)."""
        out = [("verdict check", self.verdict)]
        if self.bed:
            out.append(("  bed model of the check", self.bed))
        closures = [r for r in self.runs if r.closed is not None and not r.error]
        if closures:
            lo, hi = self.p_interval
            out.append(("P(closure) over seeds × grids",
                        f"{self.p_closure:.2f} ({sum(r.closed for r in closures)} of {len(closures)}; "
                        f"95 % interval {lo:.2f}-{hi:.2f})"))
        if np.isfinite(self.tonnage_range[0]):
            out.append(("tonnage in place over the closed runs", f"{self.tonnage_range[0]:,.0f}-{self.tonnage_range[1]:,.0f} t"))
        if len(self.tonnage_by_grid) > 1:
            for g, t in self.tonnage_by_grid.items():
                out.append((f"  tonnage at {g}", t.words()))
            out.append(("  tonnage needed on the grids", "ranges do not overlap: it depends on the cell size"
                        if self.tonnage_grid_dependent else "ranges overlap"))
        for r in self.runs:
            what = r.outcome if not r.error else f"failed: {r.error}"
            extra = "" if r.closed is None else f", {r.cycles} cycles, {r.in_place:,.0f} t in place"
            who = f"{r.label}, seed {r.seed}" if r.seed >= 0 else r.label
            if r.mean_interval > 0:
                what = f"open breach, time mean over {r.mean_interval:.0f} s"
            out.append((f"  {who}{' (this run)' if r.own else ''}",
                        f"{what}{extra}; open breach {_value_error(r.discharge, r.discharge_error, 0)} m³/s, "
                        f"control speed {_value_error(r.control_speed, r.control_speed_error, 2)} m/s, "
                        f"gap speed {r.gap_mean_speed:.2f} mean / {r.gap_max_speed:.2f} max m/s"))
        judged = judged_flow(self.flow_difference)
        marched = all(t > 0 for t in self.flow_mean_intervals)
        for k, v in self.flow_difference.items():
            err = self.flow_difference_error.get(k, math.nan)
            if k not in judged:
                note = "reported, not judged: the speed past the control section does not converge"
            elif marched:
                note = (f"time means over {self.flow_mean_intervals[0]:.0f} and {self.flow_mean_intervals[1]:.0f} s; "
                        f"tolerance {100 * self.tolerance:g} % for the difference and twice its error")
            else:
                note = f"single states; tolerance {100 * self.tolerance:g} %"
            out.append((f"  grid difference of the open breach's {k}",
                        f"{100 * v:+.2f}{_pm(100 * err, '{:.2f}')} % ({note})"))
        return out

    def summary(self) -> dict:
        """JSON-able summary (the manifest's ``metadata.check``)."""
        return {"statement": self.statement, "robust": self.robust, "bed_model": self.bed, "p_closure": _f(self.p_closure),
                "p_closure_interval": [_f(v) for v in self.p_interval],
                "tonnage_in_place_range_t": [_f(v) for v in self.tonnage_range],
                "tonnage_by_grid_t": {g: {"in_place": [_f(t.low), _f(t.high)], "needed": [_f(t.needed_low), _f(t.needed_high)],
                                          "closed_runs": t.runs} for g, t in self.tonnage_by_grid.items()},
                "tonnage_grid_dependent": self.tonnage_grid_dependent,
                "flow_difference": {k: _f(v) for k, v in self.flow_difference.items()},
                "flow_difference_error": {k: _f(v) for k, v in self.flow_difference_error.items()},
                "flow_mean_interval_s": [_f(v) for v in self.flow_mean_intervals], "tolerance": self.tolerance,
                "runs": [{"label": r.label, "cell_size_m": r.cell_size, "seed": r.seed, "outcome": r.outcome,
                          "verdict": r.verdict, "tonnage_t": _f(r.tonnage), "lost_tonnage_t": _f(r.lost_tonnage),
                          "in_place_before_last_load_t": _f(r.in_place_before),
                          "cycles": r.cycles, "open_breach_discharge_m3_s": _f(r.discharge),
                          "open_gap_mean_speed_m_s": _f(r.gap_mean_speed), "open_gap_max_speed_m_s": _f(r.gap_max_speed),
                          "open_control_speed_m_s": _f(r.control_speed),
                          "open_flow_mean_interval_s": _f(r.mean_interval),
                          "open_breach_discharge_error_m3_s": _f(r.discharge_error),
                          "open_control_speed_error_m_s": _f(r.control_speed_error),
                          "cpu_s": _f(r.cpu), "own": r.own, "error": r.error} for r in self.runs],
                "wall_time_s": self.wall_time, "cpu_time_s": self.cpu_time}

    def dataset(self):
        """The check as a CF Dataset along ``run`` (``check.nc``)."""
        import xarray as xr

        rs = self.runs
        n = len(rs)

        def var(vals, units, long_name, dtype=float):
            return ("run", np.asarray(vals, dtype), {"units": units, "long_name": long_name})

        ds = xr.Dataset({
            "cell_size": var([r.cell_size for r in rs], "m", "finest cell size at the breach"),
            "seed": var([r.seed for r in rs], "1", "placement seed ([closure] seed)", np.int64),
            "grid": ("run", np.array([r.label for r in rs], object), {"long_name": "grid of the run"}),
            "outcome": ("run", np.array([r.outcome for r in rs], object), {"long_name": "outcome of the run"}),
            "verdict": ("run", np.array([r.verdict for r in rs], object), {"long_name": "why the run ended unclosed"}),
            "closure_achieved": ("run", np.array([-1 if r.closed is None else int(r.closed) for r in rs], np.int8),
                                 {"long_name": "closure achieved", "flag_values": np.array([-1, 0, 1], np.int8),
                                  "flag_meanings": "not_run no yes"}),
            "tonnage": var([r.tonnage for r in rs], "t", "tonnage placed"),
            "lost_tonnage": var([r.lost_tonnage for r in rs], "t", "tonnage carried out of the breach area"),
            "in_place_before_last_load": var([r.in_place_before for r in rs], "t",
                                             "tonnage in place after the cycle before the last"),
            "cycles": var([r.cycles for r in rs], "1", "closure cycles run", np.int64),
            "open_breach_discharge": var([r.discharge for r in rs], "m3 s-1", "breach discharge of the open breach"),
            "open_gap_mean_speed": var([r.gap_mean_speed for r in rs], "m s-1",
                                       "depth-weighted mean speed in the gap section of the open breach"),
            "open_gap_max_speed": var([r.gap_max_speed for r in rs], "m s-1", "largest speed in the gap section of the open breach"),
            "open_control_speed": var([r.control_speed for r in rs], "m s-1",
                                      "mean speed at the control section (critical depth) of the open breach"),
            "open_breach_discharge_error": var([r.discharge_error for r in rs], "m3 s-1",
                                               "error of the time-mean breach discharge of the open breach"),
            "open_control_speed_error": var([r.control_speed_error for r in rs], "m s-1",
                                            "error of the time-mean speed at the control section of the open breach"),
            "open_flow_mean_interval": var([r.mean_interval for r in rs], "s",
                                           "simulated time the open breach's figures are the means over (0: one state)"),
            "this_run": ("run", np.array([int(r.own) for r in rs], np.int8), {"long_name": "the checked run itself"}),
        }, coords={"run": ("run", np.arange(n, dtype="i4"), {"long_name": "run of the check (this_run: the checked run)",
                                                            "units": "1"})})
        ds.attrs.update(title="breachflow verdict check", statement=self.statement, robust=int(self.robust),
                        p_closure=_f(self.p_closure), p_closure_interval=f"{self.p_interval[0]:.4f} {self.p_interval[1]:.4f}",
                        tonnage_in_place_range_t=f"{self.tonnage_range[0]:.1f} {self.tonnage_range[1]:.1f}",
                        tonnage_grid_dependent=int(self.tonnage_grid_dependent),
                        tolerance=self.tolerance, Conventions="CF-1.8", bed_model=self.bed,
                        **{f"grid_difference_{k.replace(' ', '_')}": v for k, v in self.flow_difference.items()},
                        **{f"grid_difference_{k.replace(' ', '_')}_error": v for k, v in self.flow_difference_error.items()
                           if np.isfinite(v)})
        ds.attrs = {k: v for k, v in ds.attrs.items() if v is not None}  # no P(closure) without a closure run
        return ds


def write_check(ds, path) -> Path:
    """Write the check's Dataset (:meth:`CheckResult.dataset`) to *path* atomically, text as CF character
    arrays, with the provenance attributes every written file carries."""
    from ..atomic import atomic_write_netcdf
    from ..io.cf import netcdf_encoding

    return atomic_write_netcdf(ds, path, encoding=netcdf_encoding(ds))


def _f(v):
    return None if v is None or not np.isfinite(v) else float(v)


def _value_error(value: float, err: float, decimals: int) -> str:
    """*value* with *decimals* decimals, or ``value ± err`` to the error's second significant digit (at least
    *decimals*) when the error is known."""
    if not (np.isfinite(err) and err > 0 and np.isfinite(value)):
        return f"{value:,.{decimals}f}"
    d = max(decimals, 1 - int(math.floor(math.log10(err))))
    return f"{value:,.{d}f} ± {err:,.{d}f}"


def _pm(err: float, fmt: str) -> str:
    """`` ± err`` in *fmt*, or nothing for a NaN error (a single state)."""
    return "" if not np.isfinite(err) else " ± " + fmt.format(err)


# ---------------------------------------------------------------------------------------------- planning
def check_members(section: CheckSection, resolution: float, seed: int, *,
                  refine_allowed: bool = True) -> tuple[list[int], list[int], dict]:
    """The extra closures: the seeds at the run's *resolution* (m): ``seed + 1 .. seed + seeds - 1``; the
    seeds on the finer grid (with ``refine``: the first ``refine_seeds``, the run's own first) and the
    ``[hydro]`` keys of that grid (``resolution`` halved, or ``refine`` at half the cell size)."""
    coarse = [seed + k for k in range(1, section.seeds)]
    fine = [seed + k for k in range(section.refine_seeds)] if section.refine and refine_allowed else []
    half = 0.5 * resolution
    grid = {"resolution": f"{half:g} m"} if section.grid == "uniform" else {"refine": f"{half:g} m"}
    return coarse, fine, grid


def _label(res: float, refine: float | None) -> str:
    return f"{res:g} m" if not refine else f"{refine:g} m nested"


# ---------------------------------------------------------------------------------------------- running
def run_check(run_dir, scenario_text: str, scenario_path=None, *, section: CheckSection | None = None,
              console=None, fresh: bool = False) -> CheckResult:
    """Check the closure run in *run_dir* (finished) of the scenario *scenario_text*; write ``check.nc``
    and the manifest's ``metadata.check``; return the :class:`CheckResult`. *fresh*: forget the members
    of an earlier check (an overwritten run)."""
    import shutil

    from .spec import EnsembleSpec
    from ..io import RunDirectory
    from ..scenario import parse_scenario

    w0, c0 = _time.perf_counter(), _time.process_time()
    run_dir = Path(run_dir)
    sc = parse_scenario(scenario_text, path=scenario_path)
    section = section or sc.get("check") or CheckSection()
    hydro = sc.get("hydro")
    res = float(hydro.resolution) if hydro is not None else 1.0
    refine = getattr(hydro, "refine", None)
    closure = sc.get("closure")
    seed = int(getattr(closure, "seed", 0) or 0)
    rd = RunDirectory(run_dir)
    man = rd.manifest()
    own = _run_of(man, res, refine, seed, own=True)
    runs = [own]
    # a nested or external-flow run has no "next finer grid" of its own solver; only seeds are checked
    solver = getattr(hydro, "solver", "swe")
    refine_allowed = solver == "swe" and refine is None
    coarse, fine, grid = check_members(section, res, seed, refine_allowed=refine_allowed)
    out_dir = run_dir / "check"
    if fresh and out_dir.exists():  # the members of an earlier check go; start states are keyed by what they solved
        for p in out_dir.iterdir():
            if p.name != START_STATES:
                shutil.rmtree(p) if p.is_dir() else p.unlink()
    base = tomllib.loads(scenario_text)
    base.pop("check", None)
    half = 0.5 * res
    weir = _run_weir_coefficient(man)
    for name, seeds, hyd in (("seeds", coarse, {}), ("grid", fine, grid)):
        if not seeds:
            continue
        table = {k: dict(v) for k, v in base.items()}
        table["hydro"] = {**table.get("hydro", {}), **hyd}
        # the seeds share the run's start (its solves before cycle 1 do not depend on the seed); the finer
        # grid's weir calibrations begin from the run's coefficient
        if not hyd:
            options = {"start_states": f"../{START_STATES}"}
        else:
            options = {"weir_coefficient": weir} if weir is not None else {}
        spec = EnsembleSpec.from_dict({"ensemble": {"name": f"verdict check ({name})", "runner": "closure",
                                                    "members": [{"closure": {"seed": s}} for s in seeds],
                                                    **({"options": options} if options else {})}, **table},
                                      path=Path(scenario_path) if scenario_path else None)
        records = _execute(spec, out_dir / name, section.workers, console)
        for s, rec in zip(seeds, records):
            if hyd.get("refine"):
                runs.append(_member_run(rec, res, half, s))
            else:
                runs.append(_member_run(rec, half if hyd else res, None, s))
    windows = section.flow_mean_windows
    if section.refine and refine_allowed and (section.refine_seeds == 0 or windows):
        # the open breach alone: on the finer grid when no closure runs there; marched on both grids for time means
        if windows:
            runs.append(_open_breach_cached(out_dir / "grid" / "open_breach_run_grid.json", scenario_text, sc,
                                            scenario_path, res, section, weir, fine=False, windows=windows))
        runs.append(_open_breach_cached(out_dir / "grid" / f"open_breach_{section.grid}.json", scenario_text, sc,
                                        scenario_path, res, section, weir, windows=windows))
    result = judge(runs, section.tolerance, bed=bed_model(sc))
    result.wall_time, result.cpu_time = _time.perf_counter() - w0, _time.process_time() - c0
    write_check(result.dataset(), run_dir / "check.nc")
    rd.update_metadata(check=result.summary())
    return result


def _execute(spec, out_dir: Path, workers: int, console) -> list[dict]:
    """Run the members (the ensemble machinery: member directories, result records, resume); in this
    process with one worker, on a dask local cluster otherwise."""
    from .execute import RESULT_FILE, execute_member, plan, run
    from .io import read_json

    if workers > 1:
        from rich.console import Console

        ds = run(spec, out=out_dir, workers=workers, progress=False, console=console or Console(stderr=True, quiet=True))
        _, _, _, tasks = plan(spec, out_dir)
        return [read_json(Path(t.run_dir) / RESULT_FILE) or {} for t in tasks]
    _, _, _, tasks = plan(spec, out_dir)
    out = []
    for t in tasks:
        rec = read_json(Path(t.run_dir) / RESULT_FILE)
        if not (rec and rec.get("key") == t.scenario.key and rec.get("status") == "ok"):
            rec = execute_member(t)
        rec["run_dir"] = t.run_dir
        out.append(rec)
    return out


def _run_of(man: dict, res: float, refine, seed: int, *, own: bool = False, cpu: float = math.nan) -> CheckRun:
    """A :class:`CheckRun` from a closure run's manifest."""
    cycles = man.get("cycles", [])
    last = cycles[-1]["summary"] if cycles else {}
    before = cycles[-2]["summary"] if len(cycles) > 1 else {"tonnage": 0.0, "lost_tonnage": 0.0}
    in_place_before = (float(before.get("tonnage", math.nan)) - float(before.get("lost_tonnage", 0.0))
                       if cycles else math.nan)
    ini = man.get("metadata", {}).get("initial", {})
    verdict = str(man.get("final", {}).get("verdict", ""))
    return CheckRun(label=_label(res, refine), cell_size=float(refine or res), seed=seed, closed=bool(last.get("closed")),
                    verdict=verdict, tonnage=float(last.get("tonnage", 0.0)),
                    lost_tonnage=float(last.get("lost_tonnage", 0.0)), cycles=len(cycles),
                    discharge=float(ini.get("breach_discharge", math.nan)),
                    gap_mean_speed=float(ini.get("gap_mean_speed", math.nan)),
                    gap_max_speed=float(ini.get("gap_max_speed", math.nan)),
                    control_speed=float(ini.get("control_speed") if ini.get("control_speed") is not None else math.nan),
                    cpu=cpu, own=own, in_place_before=in_place_before)


def _member_run(rec: dict, res: float, refine, seed: int) -> CheckRun:
    if rec.get("status") != "ok":
        return CheckRun(label=_label(res, refine), cell_size=float(refine or res), seed=seed, closed=None,
                        error=f"{rec.get('error_type', '?')}: {rec.get('error_message', 'not run')}")
    man = json.loads((Path(rec["run_dir"]) / "closure" / "manifest.json").read_text())
    return _run_of(man, res, refine, seed, cpu=float(rec.get("cpu_time", math.nan)))


def _run_weir_coefficient(man: dict) -> float | None:
    """The weir coefficient the run calibrated at its start (the manifest's ``metadata.timeline_start``), or
    None (no closure in time)."""
    value = (man.get("metadata", {}).get("timeline_start") or {}).get("weir_coefficient")
    return None if value is None else float(value)


def _open_breach_cached(path: Path, text: str, sc, scenario_path, res: float, section: CheckSection,
                        weir: float | None = None, *, fine: bool = True, windows: int = 0) -> CheckRun:
    """:func:`_open_breach_on`, kept in *path* (JSON) for the same scenario text, weir coefficient, grid and
    march: a resumed check does not solve it again."""
    import dataclasses
    import hashlib

    from .io import read_json, write_record

    key = text + ("" if weir is None else f"\nweir_coefficient = {weir!r}")
    if windows or not fine:
        key += f"\nfine = {fine}\nflow_mean_windows = {windows}\nbatches = {FLOW_MEAN_BATCHES}"
    key = hashlib.sha256(key.encode()).hexdigest()
    rec = read_json(path)
    if rec and rec.get("scenario_sha256") == key:
        return CheckRun(**{k: math.nan if v is None and k != "closed" else v for k, v in rec["run"].items()})
    run = _open_breach_on(sc, scenario_path, res, section, weir, fine=fine, windows=windows)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_record(path, {"scenario_sha256": key, "run": {k: _f(v) if isinstance(v, float) else v
                                                             for k, v in dataclasses.asdict(run).items()}})
    return run


def _open_breach_on(sc, scenario_path, res: float, section: CheckSection, weir: float | None = None, *,
                    fine: bool = True, windows: int = 0) -> CheckRun:
    """The open breach solved on the finer grid (*fine*; else on the run's grid of cell size *res*), no closure:
    its discharge and gap speeds; the weir calibration begins from *weir* (the run's coefficient), as the finer
    grid's closures do. *windows* > 0: marched on from the accepted state and read as time means with their
    errors (:func:`open_breach_mean`)."""
    from ..cycle.config import closure_setup

    hydro = sc["hydro"]
    old = (hydro.resolution, hydro.refine)
    cell = 0.5 * res if fine else res
    try:
        if fine and section.grid == "uniform":
            hydro.resolution = cell
        elif fine:
            hydro.refine = cell
        c0 = _time.process_time()
        setup = closure_setup(sc)
        tl = setup.timeline
        if tl is not None:  # the closure in time: the open breach at the start, as the run on the coarser grid
            tl.calibrate_from(weir)
            tl.begin()
        snap = setup.solver.solve(setup.domain)
        if tl is not None:
            snap = tl.calibrate(snap, lambda prev: setup.solver.solve(setup.domain, initial=prev),
                                lambda s: _flow_figures(s, setup)["discharge"])
        figures = {k: (v, math.nan) for k, v in _flow_figures(snap, setup).items()}
        interval = 0.0
        sim = getattr(setup.solver, "last", None)
        if windows and sim is not None and hasattr(sim, "advance_to"):  # an embedded model to march on
            figures, interval = open_breach_mean(sim, setup, windows)
        cpu = _time.process_time() - c0
    finally:
        hydro.resolution, hydro.refine = old
    nested = fine and section.grid == "nested"
    return CheckRun(label=_label(res if nested else cell, cell if nested else None), cell_size=cell, seed=-1,
                    closed=None, cpu=cpu, mean_interval=interval,
                    **{k: float(v[0]) for k, v in figures.items()},
                    **{f"{k}_error": float(v[1]) for k, v in figures.items()})


def _flow_figures(snap, setup) -> dict:
    """The open breach's flow figures of a state (:data:`FLOW_FIGURES`): breach discharge (m³/s), control
    section speed, gap section mean and largest speed (m/s)."""
    from ..cycle.criteria import control_speed, gap_section_speeds, section_discharge

    gmax, gmean = gap_section_speeds(snap, setup.breach_x, setup.levee_y)
    return {"discharge": float(section_discharge(snap, setup.breach_x, setup.levee_y, setup.flow_sign)),
            "control_speed": float(control_speed(snap, setup.breach_x, setup.levee_y)[1]),
            "gap_mean_speed": float(gmean), "gap_max_speed": float(gmax)}


def open_breach_mean(sim, setup, windows: int, batches: int = FLOW_MEAN_BATCHES) -> tuple[dict, float]:
    """March the accepted open breach *sim* (:class:`~breachflow.swe.solver.SWESimulation`) on for *windows*
    steady windows (its ``history.window``, else one long-wave crossing of the domain) and read the flow
    figures of *setup* (``_flow_figures``: :data:`FLOW_FIGURES`) :data:`FLOW_MEAN_SAMPLES` times per check interval of its steady
    test; the first half of the march is left out
    as the transient a steady test may accept too early (Law & Kelton's rule of the discarded warm-up), the second
    half gives each figure's time mean and its error (:func:`~breachflow.swe.steady_mean.series_mean`: batch
    means and the drift between the halves). Returns ``({figure: (mean, error)}, averaged interval in s)``.
    docs/verdict-check.md, *The open breach's flow as a time mean*."""
    from ..swe.steady_mean import series_mean

    hist = sim.history
    window = float(hist.window) if hist.window > 0 else float(sim.crossing_time())
    times = hist.time
    interval = (float(times[-1] - times[-2]) if len(times) > 1 else window / 20.0) / FLOW_MEAN_SAMPLES
    t0 = sim.t
    t_end = t0 + windows * window
    samples: list[tuple[float, dict]] = []
    while sim.t < t_end - 1e-9:
        sim.advance_to(min(sim.t + interval, t_end))
        samples.append((sim.t, _flow_figures(sim.snapshot(derived=False), setup)))
    half = t0 + 0.5 * (t_end - t0)
    kept = [f for t, f in samples if t > half + 1e-9]
    out = {k: series_mean([f[k] for f in kept], batches) for k in FLOW_FIGURES}
    return out, float(t_end - half)


# ---------------------------------------------------------------------------------------------- judging
def bed_model(sc) -> str:
    """The bed model of the parsed scenario *sc* in words: grain size, bottom protection, erodible or not."""
    sec = sc.get("bed") if hasattr(sc, "get") else None
    if sec is None:
        return "smooth bed (no [bed] section: no grain roughness, no near-bed forces, not erodible)"
    return sec.settings.describe()


def judged_flow(flow_difference: dict) -> set:
    """The grid differences the verdict judges: the breach discharge and the control section's speed (it
    converges with the discharge), else the levee line's mean speed (runs recorded without a control
    section); the speeds past the control are reported, not judged (docs/verdict-check.md)."""
    return {"breach discharge", "control speed" if "control speed" in flow_difference else "gap mean speed"}


def judge(runs: list[CheckRun], tolerance: float, *, bed: str = "") -> CheckResult:
    """Read the runs: P(closure), tonnage range, grid differences of the open breach, the statement (which
    ends with the bed model *bed* the runs used, when given)."""
    from .dataset import wilson_interval

    out = CheckResult(runs=runs, tolerance=tolerance, bed=bed)
    done = [r for r in runs if r.closed is not None and not r.error]
    n, k = len(done), sum(bool(r.closed) for r in done)
    if n:
        out.p_closure = k / n
        lo, hi = wilson_interval(k, n)
        out.p_interval = (float(lo), float(hi))
    for r in done:
        if r.closed:
            out.tonnage_by_grid.setdefault(r.label, GridTonnage()).add(r)
    if out.tonnage_by_grid:
        out.tonnage_range = (min(t.low for t in out.tonnage_by_grid.values()),
                             max(t.high for t in out.tonnage_by_grid.values()))
    out.tonnage_grid_dependent = not tonnage_overlap(out.tonnage_by_grid)
    coarse, f = flow_pair(runs)
    if f is not None:
        for name, key in (("breach discharge", "discharge"), ("control speed", "control_speed"),
                          ("gap mean speed", "gap_mean_speed"), ("gap max speed", "gap_max_speed")):
            a, b = getattr(coarse, key), getattr(f, key)
            if np.isfinite(a) and np.isfinite(b) and a != 0:
                out.flow_difference[name], out.flow_difference_error[name] = relative_difference(
                    a, getattr(coarse, f"{key}_error"), b, getattr(f, f"{key}_error"))
        out.flow_mean_intervals = (coarse.mean_interval, f.mean_interval)
    by_grid: dict[str, list[CheckRun]] = {}
    for r in done:
        by_grid.setdefault(r.label, []).append(r)
    words = {g: _grid_words(rs) for g, rs in by_grid.items()}
    failed = [r for r in runs if r.error]
    judged = judged_flow(out.flow_difference)
    errors = {k: out.flow_difference_error.get(k, math.nan) for k in out.flow_difference}
    # time means are judged with their errors: the difference and twice its error within the tolerance
    flow_off = {k: v for k, v in out.flow_difference.items()
                if k in judged and abs(v) + (2.0 * errors[k] if np.isfinite(errors[k]) else 0.0) > tolerance}
    grid_note = ""
    if flow_off:
        means = " as time means" if any(np.isfinite(errors[k]) for k in flow_off) else ""
        grid_note = "; open-breach flow not grid-converged (" + ", ".join(
            f"{k} {100 * v:+.1f}{_pm(100 * errors[k], '{:.1f}')} %" for k, v in flow_off.items()) + \
            f" on the finer grid{means}, tolerance {100 * tolerance:g} %)"
    if failed:
        grid_note += f"; {len(failed)} check run(s) failed"
    tonnage_note = ""
    if out.tonnage_grid_dependent:
        tonnage_note = ("; the tonnage depends on the grid (needed: " + ", ".join(
            f"{t.needed_words()} at {g}" for g, t in out.tonnage_by_grid.items()) + "; the ranges do not overlap)")
    if len({w for w in words.values()}) > 1 and any(all(r.closed for r in rs) for rs in by_grid.values()) \
            and any(not any(r.closed for r in rs) for rs in by_grid.values()):
        out.verdict = "grid-dependent: " + ", ".join(f"{w} at {g}" for g, w in words.items()) + grid_note
    elif 0 < k < n:
        out.verdict = (f"seed-dependent: closed in {k} of {n} runs (P(closure) = {k / n:.2f}; "
                         + ", ".join(f"{w} at {g}" for g, w in words.items()) + ")" + grid_note)
    elif n and k == n:
        if flow_off or failed or tonnage_note:
            out.verdict = "closed in every run, but unconfirmed" + grid_note + tonnage_note
        else:
            grids = ", ".join(by_grid)
            out.verdict = f"closed in all {n} runs ({grids}; {len({r.seed for r in done})} seeds)" + grid_note
            out.robust = True
    elif n:
        out.verdict = f"not closed in any of {n} runs ({', '.join(f'{w} at {g}' for g, w in words.items())})" + grid_note
        out.robust = not flow_off and not failed
    else:
        out.verdict = "no check run completed" + grid_note
    return out


def relative_difference(a: float, a_error: float, b: float, b_error: float) -> tuple[float, float]:
    """``(d, u)``: the relative difference ``d = (b - a) / |a|`` of *b* from *a* and its error from both values'
    errors (first order, independent: ``u = sqrt((e_b / a)² + (b e_a / a²)²)``; NaN when either is NaN)."""
    return (b - a) / abs(a), math.hypot(b_error / abs(a), abs(b) * a_error / (a * a))


def flow_pair(runs: list[CheckRun]) -> tuple[CheckRun, CheckRun | None]:
    """The two open breaches whose flow the check compares: the marched ones (:func:`open_breach_mean`) of the
    run's grid and the finer grid when both are there; else the run itself (``runs[0]``, its first solve) and
    the first finer run with a flow (``None`` when there is none)."""
    size = runs[0].cell_size
    ok = [r for r in runs if not r.error and np.isfinite(r.discharge)]
    marched = [r for r in ok if r.closed is None and r.mean_interval > 0]
    here = [r for r in marched if r.cell_size == size]
    finer = [r for r in marched if r.cell_size < size]
    if here and finer:
        return here[0], finer[0]
    fine = [r for r in ok if r.cell_size < size and r.mean_interval == 0]
    return runs[0], (fine[0] if fine else None)


@dataclass
class GridTonnage:
    """The tonnage of one grid's closed runs (t): ``low``-``high`` in place at their end, and ``needed_low``-
    ``needed_high`` the range of the tonnage they needed (:attr:`CheckRun.needed`: from the lowest tonnage before
    a last load to the highest after it)."""

    low: float = math.inf
    high: float = -math.inf
    needed_low: float = math.inf
    needed_high: float = -math.inf
    runs: int = 0
    #: *needed_low* was not enough (a tonnage before a closing load), else it is a run's own end value
    low_excluded: bool = False

    def add(self, run: CheckRun) -> None:
        a, b = run.needed
        self.low, self.high = min(self.low, float(run.in_place)), max(self.high, float(run.in_place))
        if a < self.needed_low:
            self.low_excluded = a < b
        elif a == self.needed_low:  # excluded only if no run counts it as enough
            self.low_excluded = self.low_excluded and a < b
        self.needed_low, self.needed_high = min(self.needed_low, a), max(self.needed_high, b)
        self.runs += 1

    def needed_words(self) -> str:
        """``"over 296 up to 412 t"`` (a lower end that was not enough), or ``"412 t"`` / ``"400-412 t"``."""
        if self.low_excluded:
            return f"over {self.needed_low:,.0f} up to {self.needed_high:,.0f} t"
        if self.needed_low == self.needed_high:
            return f"{self.needed_high:,.0f} t"
        return f"{self.needed_low:,.0f}-{self.needed_high:,.0f} t"

    def words(self) -> str:
        in_place = f"{self.low:,.0f} t" if self.low == self.high else f"{self.low:,.0f}-{self.high:,.0f} t"
        return f"{in_place} in place ({self.runs} seed{'s' if self.runs != 1 else ''}); needed {self.needed_words()}"


def tonnage_overlap(by_grid: dict) -> bool:
    """Whether the grids' ranges of the tonnage needed (``{label: GridTonnage}``) share a value (one grid or
    none: True).

    A closure is judged after each load, so a run that closed after its k-th load needed more than the tonnage in
    place after load k-1 and at most that after load k; the grid's range runs from the lowest of its runs' lower
    ends (excluded: not enough) to the highest upper end. The ranges share a value when the largest lower end is
    below the smallest upper end; at equality only when that lower end is a run's own end value (a run recorded
    without the tonnage before its last load). The same units placed by the same seed that close one grid at
    tonnage T and leave the other open at T therefore do not overlap. The tonnage is what an engineer orders: when the finer grid needs a tonnage
    the coarse grid's seeds do not reach (or the other way round), the check says so (docs/verdict-check.md,
    *The tonnage on both grids*)."""
    if len(by_grid) < 2:
        return True
    low = max(t.needed_low for t in by_grid.values())
    high = min(t.needed_high for t in by_grid.values())
    return low < high or (low == high and not any(t.low_excluded for t in by_grid.values() if t.needed_low == low))


def _grid_words(rs: list[CheckRun]) -> str:
    k = sum(bool(r.closed) for r in rs)
    if k == len(rs):
        return "closed" if len(rs) == 1 else f"closed ({k} of {k} seeds)"
    if k == 0:
        outs = {r.outcome for r in rs}
        word = "not closable" if outs == {"not closable"} else "not closed"
        return word if len(rs) == 1 else f"{word} (0 of {len(rs)} seeds)"
    return f"closed in {k} of {len(rs)} seeds"
