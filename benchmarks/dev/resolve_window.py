"""A finished run's cycle re-solve repeated from its written state: where does the steady test stop it, with and
without the steady window, and what does it read against a long march?

    python benchmarks/dev/resolve_window.py RUN FLOW_CYCLE PILE_CYCLE [--tolerances 2e-3 2e-4]
                                            [--window auto|SECONDS|0] [--t-max 900]

*RUN* is a run directory of a closure in time with a porous pile (only read). The flow of cycle *FLOW_CYCLE*
(its cycle file) is the warm start, the pile of cycle *PILE_CYCLE* (its restart record: the resting masses as
the porous pile, its emergent cells as obstacles, the timeline levels of its operation time) the new state to
solve: ``FLOW_CYCLE = PILE_CYCLE - 1`` repeats that cycle's re-solve. For each tolerance the scenario's warm
solver settings are used (monitoring region, breach section, check interval) with the given window; printed:
the simulated time at the stop, steady or not, the breach discharge, the mean / peak speed in the gap section,
the CPU seconds, and the breach discharge at about a dozen checks along the way.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("flow_cycle", type=int)
    ap.add_argument("pile_cycle", type=int)
    ap.add_argument("--tolerances", type=float, nargs="+", default=[2e-3])
    ap.add_argument("--window", default="auto", help="steady window: 'auto', seconds, or 0 (off)")
    ap.add_argument("--t-max", type=float, default=900.0)
    a = ap.parse_args(argv)

    from breachflow.cycle.criteria import gap_section_speeds, section_discharge
    from breachflow.swe import SWESimulation
    from march_cycle import cycle_state  # this folder

    window = a.window if a.window == "auto" else float(a.window)
    s, snap, d, obstacles = cycle_state(a.run, a.flow_cycle, a.pile_cycle)
    warm = s.solver.inner.warm

    def show(label, ds, c0):
        q = section_discharge(ds, s.breach_x, s.levee_y, s.flow_sign)
        peak, mean = gap_section_speeds(ds, s.breach_x, s.levee_y)
        print(f"{label}: breach {q:8.1f} m3/s, gap speed {mean:.3f} mean / {peak:.3f} max m/s, "
              f"{time.process_time() - c0:.1f} CPU s", flush=True)

    print(f"flow of cycle {a.flow_cycle}, pile of cycle {a.pile_cycle}; flood {s.timeline.flood_level:.3f} m, "
          f"polder {s.timeline.polder_level:.3f} m")
    show("warm start", snap, time.process_time())
    for tol in a.tolerances:
        c0 = time.process_time()
        sim = SWESimulation(d, warm.options, obstacles=obstacles, initial=snap)
        h = sim.run_to_steady(tol, a.t_max, warm.check_interval, region=warm.region, section=warm.section,
                              window=window or None)
        show(f"tolerance {tol:g} 1/s, window {h.window:.1f} s: stopped at {sim.t:.1f} s, steady {h.converged}",
             sim.snapshot(derived=False), c0)
        qs = np.asarray(h.section_discharge)
        print("   breach discharge along the way:", " ".join(f"{v:.0f}" for v in qs[::max(1, len(qs) // 12)]))


if __name__ == "__main__":
    main()
