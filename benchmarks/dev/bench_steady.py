"""Is a warm re-solve of the closure cycle a steady state? (issue 12, part 3)

    python3 tasks.py bench steady [--scene default|typical] [--resolution 4] [--cycles 2]
                                  [--tolerances 2e-3,1e-3,5e-4,2e-4,1e-4] [--long 10] [--t-max S] [--cold-time S]

The closure cycle's re-solves are recorded as a closure run makes them (``breachflow run``'s driver:
DEM cycle, remap of the resting masses, warm-started re-solve of ``[hydro]``'s solver). Scenes: the
embedded default scenario (``default``), or the report's typical breach (``typical``: 20 masses of 2 m
dropped across the breach in one cycle, ``[hydro]`` defaults at ``--resolution``). For each recorded
re-solve, the breach discharge (``section_discharge`` across the levee centreline, m³/s) and the max
speed (criterion ``max_speed``, m/s) of

* the warm re-solve at each tolerance of ``--tolerances`` (the re-solve as the driver does it, with
  that tolerance),
* the same warm start marched ``--long`` × longer than the warm re-solve at the scenario's tolerance
  took (no steady-state test),
* a cold solve of the same obstacles and bed from the scene's initial state (flood side at the source
  level, polder dry) to steady state at 1e-4 1/s, breach discharge included (t_max 10 × t_max_initial),

with the differences to the long run and to the cold solve, the simulated time and the CPU time.
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

TYPICAL = """
[scenario]
name = "typical breach, 20 masses of 2 m"
[site]
preset = "typical_breach"
[hydro]
resolution = "%g m"
%s
[placement]
diameter = ["2 m", "2 m"]
batch = 20
positions = "line"
start = ["-28 m", "0 m"]
stop = ["28 m", "0 m"]
release_height = "1 m"
[criteria]
mode = "any"
max_cycles = %d
max_speed = "0.01 m/s"
[closure]
seed = 3
"""


class Recorder:
    """Wraps the closure run's solver and keeps every warm re-solve's arguments and result."""

    def __init__(self, solver):
        self.solver = solver
        self.calls = []

    def solve(self, domain, obstacles=None, initial=None):
        c0 = time.process_time()
        out = self.solver.solve(domain, obstacles=obstacles, initial=initial)
        if initial is not None:
            sim = self.solver.warm.last
            self.calls.append(dict(domain=domain, obstacles=obstacles, initial=initial, snapshot=out, t=sim.t,
                                   cpu=time.process_time() - c0, converged=sim.history.converged))
        return out


def measures(setup, ds):
    from breachflow.cycle.criteria import CycleContext, MaxSpeed, section_discharge

    ctx = CycleContext(cycle=0, snapshot=ds, breach_x=setup.breach_x, levee_y=setup.levee_y)
    return section_discharge(ds, setup.breach_x, setup.levee_y), MaxSpeed("0 m/s").value(ctx)


def record(text, workdir):
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun
    from breachflow.scenario.config import parse_scenario

    setup = closure_setup(parse_scenario(text))
    rec = Recorder(setup.solver)
    setup.solver = rec
    ClosureRun(setup, workdir, text).run()
    return setup, rec


def compare(setup, rec, tolerances, long_factor, t_max=None, cold_time=None):
    from breachflow.swe import SWESimulation

    warm = rec.solver.warm
    rows = []
    for k, call in enumerate(rec.calls):
        dom, obst, init = call["domain"], call["obstacles"], call["initial"]
        q_run, v_run = measures(setup, call["snapshot"])
        # the long run and the cold solve: references
        c0 = time.process_time()
        sim = SWESimulation(dom, warm.options, obstacles=obst, initial=init)
        t_long = long_factor * call["t"]
        trace = []
        for t in (5.0, 10.0, 20.0, 40.0, 80.0, 160.0, 320.0, 640.0, 1280.0, 2560.0):
            if t >= t_long:
                break
            sim.advance_to(t)
            trace.append(f"{t:g} s: {measures(setup, sim.snapshot(derived=False))[0]:.4g}")
        sim.advance_to(t_long)
        q_long, v_long = measures(setup, sim.snapshot(derived=False))
        print(f"[bench steady] re-solve {k + 1}: breach discharge (m³/s) of the long run at " + ", ".join(trace)
              + f", {sim.t:.0f} s: {q_long:.4g}", flush=True)
        cpu_long = time.process_time() - c0
        c0 = time.process_time()
        cold = SWESimulation(dom, warm.options, obstacles=obst)
        if cold_time:
            cold.advance_to(cold_time)
            hist = cold.history
            hist.converged = True
        else:
            hist = cold.run_to_steady(1e-4, 10.0 * rec.solver.cold.t_max, region=warm.region,
                                      **({"section": warm.section} if getattr(warm, "section", None) else {}))
        q_cold, v_cold = measures(setup, cold.snapshot(derived=False))
        cpu_cold = time.process_time() - c0
        ref = [(f"{long_factor:g}× longer", q_long, v_long, sim.t, True, cpu_long),
               (f"cold, {cold_time:g} s" if cold_time else "cold, 1e-4 1/s", q_cold, v_cold, cold.t, hist.converged, cpu_cold)]
        tried = [(f"as run (tol {warm.tolerance:g})", q_run, v_run, call["t"], call["converged"], call["cpu"])]
        for tol in tolerances:
            c0 = time.process_time()
            s = SWESimulation(dom, warm.options, obstacles=obst, initial=init)
            h = s.run_to_steady(tol, t_max or warm.t_max, warm.check_interval, region=warm.region,
                                **({"section": warm.section} if getattr(warm, "section", None) else {}))
            q, v = measures(setup, s.snapshot(derived=False))
            tried.append((f"tol {tol:g}", q, v, s.t, h.converged, time.process_time() - c0))
        for label, q, v, t, conv, cpu in tried + ref:
            rows.append([str(k + 1), label, f"{t:.1f}", "yes" if conv else "no", f"{cpu:.1f}", f"{q:.3f}",
                         f"{100 * (q / q_long - 1):+.2f}", f"{100 * (q / q_cold - 1):+.2f}", f"{v:.3f}",
                         f"{100 * (v / v_long - 1):+.2f}", f"{100 * (v / v_cold - 1):+.2f}"])
            print("[bench steady] " + " | ".join(rows[-1]), flush=True)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", choices=("default", "typical"), default="default")
    p.add_argument("--resolution", type=float, default=4.0, help="typical breach: cell size (m)")
    p.add_argument("--cycles", type=int, default=2, help="default scene: cycles recorded")
    p.add_argument("--tolerances", default="2e-3,1e-3,5e-4,2e-4,1e-4")
    p.add_argument("--long", type=float, default=10.0, help="the long re-solve runs this many times longer")
    p.add_argument("--run-tolerance", default="", help="typical scene: [hydro] tolerance of the closure run "
                   "(e.g. '2e-3 1/s', the default before issue 12); the long re-solve is 10x its re-solve")
    p.add_argument("--run-t-max", default="", help="typical scene: [hydro] t_max of the closure run (e.g. '60 s')")
    p.add_argument("--cold-time", type=float, default=None,
                   help="march the cold solve for this simulated time (s) instead of to 1e-4 1/s")
    p.add_argument("--t-max", type=float, default=None, help="time limit (s) of the re-solves at --tolerances "
                   "(default: the scenario's [hydro] t_max)")
    a = p.parse_args(argv)
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    from bench_swe import _table

    if a.scene == "default":
        from breachflow.cycle.main import default_scenario_text

        text = default_scenario_text()
        text = text.replace("max_cycles = 24", f"max_cycles = {a.cycles}")
        title = f"default scene, first {a.cycles} cycles"
    else:
        hydro = "".join(f'{k} = "{v}"\n' for k, v in (("tolerance", a.run_tolerance), ("t_max", a.run_t_max)) if v)
        text = TYPICAL % (a.resolution, hydro, 1)
        title = f"typical breach at {a.resolution:g} m, 20 masses of 2 m"
    tols = [float(s) for s in a.tolerances.split(",") if s]
    with tempfile.TemporaryDirectory() as tmp:
        setup, rec = record(text, tmp + "/run")
    rows = compare(setup, rec, tols, a.long, a.t_max, a.cold_time)
    _table(f"warm re-solves, {title}: breach discharge Q and max speed against a {a.long:g}× longer re-solve "
           "and a cold solve of the same obstacles",
           ["re-solve", "run", "sim time s", "steady", "CPU s", "Q m³/s", "ΔQ vs long %", "ΔQ vs cold %",
            "max speed m/s", "Δv vs long %", "Δv vs cold %"], rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
