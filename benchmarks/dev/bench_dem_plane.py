"""Cost of the floor's contact loop on the settled bed: over all awake particles (the Python step's loop, and
the compiled loop's before the candidate lists) against over the floor's candidate list (issue 16,
``steploop_fluid.list_planes``), in CPU ns per particle-step.

    python3 tasks.py bench dem_plane [--scene bed|pour] [--n 1000] [--calls 2000] [--reps 5] [--old <src>]

For each mode of ``bench dem`` (``velocity_verlet`` / ``predicted_verlet`` with the step-averaged law,
``velocity_verlet`` with ``hooke_history``) the scene is stepped 20 steps, the pair list rebuilt, and
``walls.plane_forces`` is called ``--calls`` times inside one compiled loop over ``sim.idx`` ("all") and
over the candidate list ("listed"); "listed" includes the per-step guard's speed scan
(``walls.max_speed``: the compiled loop gets this bound from ``steploop.first_pass`` without a scan, so "listed" is an upper bound; ``predicted_verlet`` only: ``velocity_verlet``'s bound is the drift's maximum, and
``hooke_history`` has no force-interval reach). "list build" is ``walls.plane_candidates`` per particle, paid once per
neighbour-list rebuild. Best and median of ``--reps``, the two interleaved in alternating order; all/listed
per repeat, mean ± sd; "per contact" is (listed - empty list) / (floor contacts), the call's fixed cost
(and ``predicted_verlet``'s speed scan) taken off.

``--old <src>``: the same runs with ``plane_forces`` of another source tree (its ``dem`` package copied under
another name, as ``bench dem_kernel --old``), interleaved in the same process, and the old/new ratios of the
paired repeats (mean ± sd).
"""
from __future__ import annotations

import argparse
import statistics as st
import sys
import time
from pathlib import Path

import numpy as np


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench dem_plane", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--scene", default="bed", choices=("bed", "pour"))
    ap.add_argument("--old", help="src directory of another tree: its plane_forces timed interleaved")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem
    from bench_dem_kernel import _old_contacts, _repeat, _writable

    from breachflow.dem import integrators as _  # noqa: F401
    import importlib

    from breachflow.dem import wall_contacts as walls

    integ_mod = importlib.import_module("breachflow.dem.integrators")
    trees = {"": walls} | ({"old ": _old_contacts(a.old)} if a.old else {})  # contacts re-exports plane_forces
    sim0, L = bench_dem.settled_bed(a.n) if a.scene == "bed" else bench_dem.poured_pile(a.n)
    s0 = sim0.state
    for integ, law in (("velocity_verlet", "step_averaged"), ("predicted_verlet", "step_averaged"),
                       ("velocity_verlet", "hooke_history")):
        sim = bench_dem.make_sim(s0.pos.copy(), s0.vel.copy(), L, integ, omega=s0.omega.copy(), law=law)
        sim.step(20)
        sim.pairs.rebuild()
        s, w, it, dt = sim.state, sim.work, sim.integrator, sim.dt
        idx = sim.idx
        lo, hi = it.force_interval[0] * dt, it.force_interval[1] * dt
        pred = bool(it.predict_velocity)
        ve, we = (w["v"].copy(), w["w"].copy()) if pred else (s.vel, s.omega)
        if pred:
            integ_mod.predict_extrapolated(idx, s.vel, s.omega, sim.force, sim.torque, w["fp"].copy(), w["tp"].copy(),
                                           sim._inv_m, sim._inv_i, 0.5 * dt, it.extrapolate, sim.lmask, sim.rmask,
                                           ve, we)
        pl = sim.boundaries[0]
        cand = np.empty(idx.size, np.int64)
        margin = sim.skin
        build = (walls.plane_candidates, (idx, sim.pairs.pos_build, s.radius, pl.point, pl.normal, margin, pl.hist,
                                          pl.rhist, cand))
        nc = walls.plane_candidates(*build[1])
        cand = cand[:nc].copy()

        def args(sel):
            return (sel, pl.point, pl.normal, pl.velocity, pl.props, pl.hist, pl.rhist, s.pos, ve, we, s.radius,
                    s.mass, s.inertia, s._props, dt, sim.force, sim.torque, pl.reaction, lo, hi, s.vel, s.omega,
                    sim._law)

        runs = {}
        for tag, mod in trees.items():
            runs |= {tag + "all": [(mod.plane_forces, args(idx))], tag + "listed": [(mod.plane_forces, args(cand))],
                     tag + "empty list": [(mod.plane_forces, args(cand[:0]))]}
            if pred and law == "step_averaged":  # the guard's speed scan: in "empty list" too, so that it cancels
                runs[tag + "listed"].append((walls.max_speed, (idx, ve)))
                runs[tag + "empty list"].append((walls.max_speed, (idx, ve)))
        runs["list build"] = [build]
        ntouch = int(np.sum(s.pos[cand, 2] - pl.point[2] < s.radius[cand]))  # the floor: normal +z
        times = {k: [] for k in runs}
        for fns in runs.values():
            for fn, ar in fns:
                _repeat(1, fn, _writable(ar))  # compile
        for rep in range(a.reps):
            order = list(runs.items())
            for name, fns in (order if rep % 2 == 0 else order[::-1]):
                tot = 0.0
                for fn, ar in fns:
                    wargs = _writable(ar)
                    c = time.process_time()
                    _repeat(a.calls, fn, wargs)
                    tot += (time.process_time() - c) / a.calls
                times[name].append(tot / idx.size * 1e9)
        sd = lambda v: st.stdev(v) if len(v) > 1 else float("nan")  # noqa: E731
        print(f"{a.scene}, N = {idx.size}, {integ}, {law}: {nc} floor candidates ({100 * nc / idx.size:.1f} %), "
              f"{ntouch} in contact, margin {margin:.3g} m; CPU ns per particle, best / median of {a.reps}")
        for name, v in times.items():
            print(f"  {name:15s} {min(v):6.2f} / {st.median(v):6.2f}")
        for tag in trees:
            r = [x / y for x, y in zip(times[tag + "all"], times[tag + "listed"])]
            per = [(x - y) * idx.size / max(ntouch, 1)
                   for x, y in zip(times[tag + "listed"], times[tag + "empty list"])]
            print(f"  {tag}all/listed {st.mean(r):.2f} ± {sd(r):.2f}; {tag}ns per contact {min(per):.1f} (best), "
                  f"{st.mean(per):.1f} ± {sd(per):.1f}")
        if a.old:
            for name in ("all", "listed"):
                r = [x / y for x, y in zip(times["old " + name], times[name])]
                print(f"  old/new {name:7s} {st.mean(r):.3f} ± {sd(r):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
