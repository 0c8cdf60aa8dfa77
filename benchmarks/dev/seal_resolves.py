"""The seal stage of a finished closure run re-solved in the flow model, solve by solve: is the sealed dam's flow steady?

    python benchmarks/dev/seal_resolves.py RUN [--cap SECONDS] [--exact-tailwater]

*RUN* is a run directory whose rock dam held (``breachflow run`` with a ``polder_leakage`` seal); it is only read.
The seal stage is repeated from the run's last cycle with the re-solve forced (the seal's water-at-rest reading,
:func:`breachflow.cycle.sealing.still_water`, switched off) and continued ``t_max`` at a time up to ``--cap`` s of
simulated time; printed after each solve: the simulated time, the discharge through the breach section and the
solver's steady flag, then the seal's steps. ``--exact-tailwater`` imposes the polder level exactly (not absorbing)
on the protected edges, as before the absorbing tailwater (:func:`breachflow.cycle.timeline.with_tailwater`).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--cap", type=float, default=1440.0, help="simulated seconds of the re-solve in all")
    ap.add_argument("--exact-tailwater", action="store_true")
    a = ap.parse_args(argv)

    import breachflow.cycle.rock_end as rock_end
    import breachflow.cycle.sealing as sealing
    import breachflow.cycle.timeline as timeline
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import section_discharge
    from breachflow.io.rundir import RunDirectory
    from breachflow.scenario import parse_scenario

    if a.exact_tailwater:
        exact = timeline.with_tailwater
        timeline.with_tailwater = lambda boundaries, tail, relaxation=None: exact(boundaries, tail, None)
    sealing.separates = lambda *args, **kw: False  # force the re-solve

    s = closure_setup(parse_scenario((a.run / "scenario.toml").read_text(), path=a.run / "scenario.toml"))
    rd = RunDirectory(a.run)
    g = rd.completed_cycles()[-1]
    rec = rd.load_restart(g)
    snap = rd.open_cycle(g)
    snap = snap[[v for v in snap.data_vars if "particle" not in snap[v].dims and v != "scour_depth"]]
    if s.timeline is not None:
        s.timeline.restore(rd.manifest()["cycles"][-1]["summary"]["timeline"])
        print(f"flood {s.timeline.flood_level:.3f} m, polder {s.timeline.polder_level:.3f} m", flush=True)

    def logged(solve, snapshot, cap=None):
        total, n, c0 = rock_end.simulated_time(snapshot), 1, time.process_time()

        def show():
            q = section_discharge(snapshot, s.breach_x, s.levee_y, s.flow_sign)
            print(f"  solve {n:2d}: {total:6.0f} s simulated, breach section {q:+9.4f} m3/s, "
                  f"steady {rock_end.is_steady(snapshot)}, {time.process_time() - c0:6.1f} CPU s", flush=True)

        show()
        while total < a.cap:
            snapshot = solve(snapshot)
            total += rock_end.simulated_time(snapshot)
            n += 1
            show()
        return snapshot, rock_end.is_steady(snapshot), total, n

    rock_end.continue_to_steady = logged
    res = sealing.seal_stage(s, rec, snap)
    for step in res.steps:
        print({k: v for k, v in step.as_dict().items() if k != "tonnage_t"})
    print(res.verdict)


if __name__ == "__main__":
    main()
