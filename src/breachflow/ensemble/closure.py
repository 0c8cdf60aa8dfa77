"""The ``closure`` ensemble member runner (issue: scenario ensembles; docs/theory.md, *Closure window*, *The closure cycle*).

Runs the member's closure simulation in its run directory (resuming a previous attempt) and its
closure window, and reduces both to scalars: cycles, masses, tonnage, simulated closure duration at
the placement rate, closure achieved, governing criterion, peak velocity, breach discharge before and
after, and the feasibility flag (closure achieved before the closure window ends).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, ClassVar

from .runners import CLOSURE_OUTPUTS, MemberScenario, ClosureWindowRunner, member_runners, window_scalars
from ..errors import InputError
from ..units import Q_

@member_runners.register("closure")
class ClosureRunner:
    """Closure simulation + closure window of one member (options: ``plots`` = false by default;
    ``start_states``: a directory where members that differ only in their placement seed share the solves
    before their first cycle, :mod:`breachflow.cycle.start_state`; a relative path is taken from the ensemble's
    output directory; ``weir_coefficient``: the coefficient (m^0.5/s) the members' weir calibrations begin from,
    the verdict check's finer grid: the run's own)."""

    sections = None
    #: the members' cycle files, whose per-cycle figures the ensemble result carries (breachflow.ensemble.cycles)
    cycle_files = "closure/cycle_*.nc"
    outputs: ClassVar[dict[str, dict]] = {**ClosureWindowRunner.outputs, **CLOSURE_OUTPUTS}
    optional_outputs: ClassVar[frozenset[str]] = ClosureWindowRunner.optional_outputs

    def __init__(self, plots: bool = False, start_states: str | None = None, weir_coefficient: float | None = None,
                 **options):
        if options:
            raise InputError(f"member runner 'closure' takes only 'plots', 'start_states' and 'weir_coefficient', got "
                             f"{sorted(options)}")
        self.plots = bool(plots)
        self.start_states = None if start_states is None else str(start_states)
        try:
            self.weir_coefficient = None if weir_coefficient is None else float(weir_coefficient)
        except (TypeError, ValueError):
            raise InputError(f"member runner 'closure': weir_coefficient must be a number (m^0.5/s), got "
                             f"{weir_coefficient!r}") from None

    def check(self, member: MemberScenario) -> list[str]:
        """Refuse a member whose closure scenario cannot work (``InputError`` from
        :func:`breachflow.cycle.sanity.check_setup`: masses lighter than water, wider than the breach,
        released outside the domain) before any member runs; return its warnings."""
        from ..scenario import parse_scenario
        from ..cycle.config import closure_setup

        # parsed afresh (not member.scenario(): its cache would travel to the worker with the task)
        scenario = parse_scenario(member.text(), path=member.path)
        setup = closure_setup(scenario)
        warnings = list(setup.warnings)
        from ..cycle.leakage import undesignable_seal

        if undesignable_seal(setup.criteria):  # the member runs, but ends with that verdict before its first cycle
            warnings.append("[criteria] polder_leakage: no seal designable for this member's rock (it ends not "
                            "closed before its first cycle)")
        missing = [s for s in ("flood", "polder", "breach") if s not in scenario]
        if missing:
            warnings.append("no closure window: the scenario has no [" + "], [".join(missing) + "] table, so "
                            "feasibility (closure before the window ends) cannot be judged and `feasible` is "
                            "false for every member")
        return warnings

    def run(self, member: MemberScenario, run_dir: Path, seed: int) -> dict[str, Any]:
        from ..scenario import closure_window
        from ..cycle.main import run_closure

        run_dir = Path(run_dir)
        table = dict(member.table)
        closure = dict(table.get("closure", {}))
        if member.replicate is not None:
            closure["seed"] = int(seed) % (2**31)  # replicates: the placement randomness varies
        else:
            closure.setdefault("seed", int(seed) % (2**31))
        table["closure"] = closure
        member.table = table
        path = member.write(run_dir / "closure_scenario.toml")
        out = run_dir / "closure"
        store = None
        if self.start_states is not None:  # a member's directory is OUT/members/<key> (breachflow.ensemble.execute)
            store = Path(os.path.normpath(run_dir.parent.parent / self.start_states))
        res = run_closure(path, out, resume=(out / "manifest.json").exists(), plots=self.plots, start_states=store,
                          weir_coefficient=self.weir_coefficient)
        scenario = member.scenario()
        results: dict[str, Any] = {}
        window = None
        if all(s in scenario for s in ("flood", "polder", "breach")):
            ds = closure_window(**scenario.window_kwargs())
            results.update(window_scalars(ds))
            window = float(ds["closure_window"])
        from ..io import RunDirectory

        m = RunDirectory(res.run_dir).manifest()
        last = m["cycles"][-1]["summary"] if m["cycles"] else {}
        results.update(
            cycles=res.cycles, masses_placed=res.masses, tonnage=Q_(res.tonnage * 1000.0, "kg"),
            closure_duration=Q_(finish_time(res), "s"), closure_achieved=res.closed,
            governing_criterion=res.governing or "none",
            peak_velocity=Q_(m["metadata"]["initial"]["max_speed"], "m/s"),
            initial_breach_discharge=Q_(m["metadata"]["initial"]["breach_discharge"], "m**3/s"),
            final_breach_discharge=Q_(last.get("breach_discharge", float("nan")), "m**3/s"),
            final_seepage_discharge=Q_(last.get("seepage_discharge", 0.0), "m**3/s"),
            feasible=bool(res.closed and window is not None and finish_time(res) <= window),
        )
        return results


def finish_time(res) -> float:
    """When the closure of *res* (:class:`~breachflow.cycle.main.ClosureResult`) is done, s since the breach: the
    end of its seal stage when the run has a plan with one (the seal is delivered after the rock,
    :mod:`breachflow.cycle.sealing`), else the operation time of its last cycle."""
    plan = getattr(res, "plan", None) or {}
    finish = plan.get("finish_s")
    return float(finish) if finish is not None else float(res.operation_time)
