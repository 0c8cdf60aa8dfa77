"""A finished run's cycle flow marched on with its pile as it stood, without the steady-state test: did the
cycle's "steady" reading settle?

    python benchmarks/dev/march_cycle.py RUN CYCLE [--times 30 60 120 180]

*RUN* is a run directory with a porous pile under the closure in time (it is only read). The flow of cycle
*CYCLE* is rebuilt from its cycle file and restart record (the resting masses as the porous pile, the pile's
emergent cells as obstacles, the flood and polder levels of the cycle's operation time) and marched on with
the flow model's solver; printed at each time (s after the cycle's state): the discharge through the breach
section and the mean / peak speed in the gap section, with the CPU seconds so far.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np


def cycle_state(run: Path, flow_cycle: int, pile_cycle: int):
    """``(setup, flow, domain, obstacles)`` of a finished closure-in-time run: the flow of cycle *flow_cycle*
    (its cycle file, particle variables dropped), and the domain of cycle *pile_cycle* (its resting masses as the
    porous pile, the timeline levels of its operation time as the boundaries, its emergent cells as obstacles)."""
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.remap import porous_pile
    from breachflow.io.rundir import RunDirectory
    from breachflow.scenario import parse_scenario
    from breachflow.swe.domain import _copy_spacing

    s = closure_setup(parse_scenario((run / "scenario.toml").read_text(), path=run / "scenario.toml"))
    if s.timeline is None:
        raise SystemExit("the run is not a closure in time ([closure] method)")
    rd = RunDirectory(run)
    snap = rd.open_cycle(flow_cycle)
    snap = snap[[v for v in snap.data_vars if "particle" not in snap[v].dims and v != "scour_depth"]]
    rec = rd.load_restart(pile_cycle)
    s.timeline.restore(rd.manifest()["cycles"][pile_cycle - 1]["summary"]["timeline"])
    dom = s.domain
    pos, radius = np.asarray(rec["dem.state.pos"], float), np.asarray(rec["dem.state.radius"], float)
    resting = np.asarray(rec["resting"], bool)
    m = min(len(pos), len(radius), len(resting))
    porous = dom.with_porous(porous_pile(dom.x, dom.y, dom.bed, pos[:m], radius[:m], resting[:m], law=s.porous_law))
    d = replace(porous, boundaries=s.solver.boundaries(porous))
    _copy_spacing(porous, d)
    obstacles = np.asarray(rd.open_cycle(pile_cycle)["obstacle"].values, bool) & ~np.asarray(dom.obstacle, bool)
    return s, snap, d, obstacles


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("cycle", type=int)
    ap.add_argument("--times", type=float, nargs="+", default=[30.0, 60.0, 120.0, 180.0])
    a = ap.parse_args(argv)

    from breachflow.cycle.criteria import gap_section_speeds, section_discharge
    from breachflow.swe import SWESimulation

    s, snap, d, obstacles = cycle_state(a.run, a.cycle, a.cycle)

    def show(label, ds):
        q = section_discharge(ds, s.breach_x, s.levee_y, s.flow_sign)
        peak, mean = gap_section_speeds(ds, s.breach_x, s.levee_y)
        print(f"{label}: breach section {q:8.1f} m3/s, gap speed {mean:.3f} mean / {peak:.3f} max m/s, "
              f"{time.process_time() - c0:.0f} CPU s", flush=True)

    c0 = time.process_time()
    print(f"cycle {a.cycle}: flood {s.timeline.flood_level:.3f} m, polder {s.timeline.polder_level:.3f} m", flush=True)
    show("as written", snap)
    sim = SWESimulation(d, s.solver.inner.warm.options, obstacles=obstacles, initial=snap)
    for t in a.times:
        sim.advance_to(t)
        show(f"{t:6.0f} s on", sim.snapshot(derived=False))


if __name__ == "__main__":
    main()
