"""How steady is the steady open breach? The start's solve as the shipped steady test accepts it, then marched on.

    python benchmarks/dev/steady_wander.py SCENARIO [--resolution M] [--weir C] [--until T] [--initial SNAPSHOT.nc]
        [--out FILE.json]

The open breach of a closure scenario in time is solved at the start of the closure, the polder filled with the
weir coefficient *C* (m^0.5/s; e.g. a run's ``metadata.timeline_start.weir_coefficient``, as the verdict check
hands its finer grid) — one solve, no calibration — from rest or from ``--initial`` (a grid snapshot on the same
grid, e.g. an earlier output of this script's ``--snapshot``), with the scenario's solver and steady test. When
the test accepts the state, the march goes on to *T* s of simulated time, the breach discharge and the control
section's speed (:func:`breachflow.cycle.criteria.section_discharge`, :func:`~breachflow.cycle.criteria.control_speed`)
read every check interval. Printed: the accepted state, then the range and mean of both figures over the march
and over its quarters, against the accepted values (docs/verdict-check.md, *How steady the steady open breach
is*). ``--out`` keeps the records (JSON), ``--snapshot`` the accepted state (NetCDF).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path)
    ap.add_argument("--resolution", type=float, default=None, help="[hydro] resolution (m)")
    ap.add_argument("--weir", type=float, default=None, help="weir coefficient the polder is filled with (m^0.5/s)")
    ap.add_argument("--until", type=float, default=1800.0, help="simulated time to march to (s)")
    ap.add_argument("--initial", type=Path, default=None, help="grid snapshot to start from (same grid)")
    ap.add_argument("--out", type=Path, default=None, help="records (JSON)")
    ap.add_argument("--snapshot", type=Path, default=None, help="the accepted state (NetCDF)")
    a = ap.parse_args(argv)

    import xarray as xr

    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import control_speed, section_discharge
    from breachflow.scenario import parse_scenario
    from breachflow.scenario.toml import scenario_with
    from breachflow.swe import solver as S

    text = a.scenario.read_text()
    if a.resolution:
        text = scenario_with(text, {"hydro.resolution": f"{a.resolution:g} m"})
    s = closure_setup(parse_scenario(text, path=a.scenario))
    if s.timeline is None:
        raise SystemExit(f"{a.scenario}: not a closure in time ([closure] method, [polder])")
    s.timeline.calibrate_from(a.weir)
    s.timeline.begin()
    print(f"polder level at the start {s.timeline.polder_level:.4f} m", flush=True)
    original = S.SWESimulation.run_to_steady
    c0 = time.process_time()
    record: dict = {}

    def figures(sim):
        snap = sim.snapshot(derived=False)
        return (section_discharge(snap, s.breach_x, s.levee_y, s.flow_sign),
                control_speed(snap, s.breach_x, s.levee_y)[1])

    def march(sim, *args, **kw):
        hist = original(sim, *args, **kw)
        q, vc = figures(sim)
        record["accepted"] = dict(t=sim.t, steps=sim.steps, cpu=time.process_time() - c0, converged=hist.converged,
                                  q=q, control=vc, window=hist.window, cells=int(np.prod(sim.domain.shape)),
                                  check_t=list(hist.time), check_q=list(hist.section_discharge))
        print(f"accepted at t = {sim.t:.1f} s ({sim.steps} steps, {record['accepted']['cpu']:.1f} CPU s): "
              f"Q {q:.1f} m3/s, control speed {vc:.4f} m/s", flush=True)
        if a.snapshot:
            sim.snapshot().to_netcdf(a.snapshot)
        interval = hist.time[1] - hist.time[0] if len(hist.time) > 1 else 5.0
        rows = record["march"] = []
        while sim.t < a.until - 1e-9:
            sim.advance_to(min(sim.t + interval, a.until))
            rows.append((sim.t, *figures(sim), time.process_time() - c0, sim.steps))
            if a.out and len(rows) % 20 == 0:
                a.out.write_text(json.dumps(record))
        return hist

    S.SWESimulation.run_to_steady = march
    try:
        s.solver.solve(s.domain, initial=xr.open_dataset(a.initial).load() if a.initial else None)
    finally:
        S.SWESimulation.run_to_steady = original
    if a.out:
        a.out.write_text(json.dumps(record))
    acc, rows = record["accepted"], np.array(record["march"]) if record["march"] else np.zeros((0, 5))
    if len(rows):
        t, q, vc = rows[:, 0], rows[:, 1], rows[:, 2]
        edges = np.linspace(acc["t"], t[-1], 5)

        def line(sel, label):
            return (f"{label}: Q {q[sel].min():.1f}-{q[sel].max():.1f} (mean {q[sel].mean():.1f}) m3/s, "
                    f"{100 * (q[sel].min() / acc['q'] - 1):+.2f} to {100 * (q[sel].max() / acc['q'] - 1):+.2f} %; "
                    f"control {vc[sel].min():.3f}-{vc[sel].max():.3f} (mean {vc[sel].mean():.3f}) m/s, "
                    f"{100 * (vc[sel].min() / acc['control'] - 1):+.2f} to {100 * (vc[sel].max() / acc['control'] - 1):+.2f} %")

        print(line(np.ones(len(t), bool), f"march {acc['t']:.0f}-{t[-1]:.0f} s"))
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (t > lo) & (t <= hi + 1e-9)
            if sel.any():
                print(line(sel, f"  {lo:.0f}-{hi:.0f} s"))
        print(f"end: t = {t[-1]:.1f} s, Q {q[-1]:.1f} m3/s, control {vc[-1]:.4f} m/s; "
              f"{rows[-1, 3]:.1f} CPU s, {int(rows[-1, 4])} steps in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
