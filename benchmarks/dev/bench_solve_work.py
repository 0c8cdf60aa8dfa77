"""Every steady solve of a typical-breach closure run: cells, steps, simulated time, checks, cell-stages.

    python3 tasks.py bench solve_work [--resolution 4] [--max-cycles 30] [--set hydro.cold_start=coarse ...]

``examples/typical_breach.toml`` at ``--resolution`` m runs (in this process) with
``SWESimulation.run_to_steady`` wrapped: per steady solve (the cold one first, the coarse level of a
``cold_start = "coarse"`` included, then the warm re-solves) one line with the domain's cells, the time
steps, the simulated time (s), the steady-state checks, whether it converged, the cell-stages that did
the flux work (``stats[3]`` of the solver: a measure of the work that does not depend on the machine's
load), the CPU time (s) and the breach discharge at the last check (m³/s). ``--set SECTION.KEY=VALUE``
(TOML value) changes the scenario. At the end: the sums for the cold and the warm solves.
"""
from __future__ import annotations

import argparse
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench solve_work")
    ap.add_argument("--resolution", type=float, default=4.0)
    ap.add_argument("--max-cycles", type=int, default=30)
    ap.add_argument("--set", action="append", default=[], help="SECTION.KEY=VALUE (TOML value)")
    a = ap.parse_args(argv)
    from breachflow.cycle.main import run_closure
    from breachflow.swe import solver as S
    from breachflow.scenario.toml import scenario_with

    changes = {"hydro.resolution": f"{a.resolution:g} m", "criteria.max_cycles": a.max_cycles}
    for item in a.set:
        key, value = item.split("=", 1)
        changes[key] = tomllib.loads(f"v = {value}")["v"]
    text = scenario_with((ROOT / "examples" / "typical_breach.toml").read_text(), changes)
    log = []
    original = S.SWESimulation.run_to_steady

    def traced(self, *args, **kw):
        c0, s0, w0 = time.process_time(), self.steps, self.stats[3]
        t0 = self.t
        hist = original(self, *args, **kw)
        rec = dict(cells=int(np.prod(self.domain.shape)), steps=self.steps - s0, time=self.t - t0,
                   checks=len(hist.time), converged=hist.converged, cell_stages=float(self.stats[3] - w0),
                   cpu=time.process_time() - c0,
                   q=hist.section_discharge[-1] if hist.section_discharge else float("nan"))
        log.append(rec)
        print(f"solve {len(log):2d}: {rec['cells']:7d} cells, {rec['steps']:5d} steps, {rec['time']:6.1f} s simulated, "
              f"{rec['checks']:2d} checks{'' if rec['converged'] else ' (t_max)'}, {rec['cell_stages'] / 1e6:7.1f} M "
              f"cell-stages, CPU {rec['cpu']:6.1f} s, Q {rec['q']:8.1f} m3/s", flush=True)
        return hist

    S.SWESimulation.run_to_steady = traced
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scenario.toml"
        path.write_text(text)
        c0 = time.process_time()
        res = run_closure(path, Path(tmp) / "run", plots=False)
        cpu = time.process_time() - c0
    n_cold = 2 if "coarse" in str(changes.get("hydro.cold_start", "")) else 1
    cold, warm = log[:n_cold], log[n_cold:]
    for name, part in (("cold", cold), ("warm", warm)):
        print(f"{name}: {len(part)} solves, {sum(r['steps'] for r in part)} steps, "
              f"{sum(r['cell_stages'] for r in part) / 1e6:.1f} M cell-stages, CPU {sum(r['cpu'] for r in part):.1f} s")
    print(f"run: {'closed' if res.closed else res.verdict or 'not closed'} after {res.cycles} cycles, "
          f"{res.tonnage:,.0f} t; CPU {cpu:.1f} s")
    return 0
