"""In-process A/B of the compiled DEM loop's fused per-particle passes (``dem/steploop.py``: ``first_pass`` =
kick, drift, wrap, predict, zeroing, rebuild check; ``second_pass`` = gravity, damping, closing kick) of this
tree against another tree's (issue 16); and this tree's ``close_and_first_pass`` (a step's closing pass fused
with the next step's first pass, the compiled loop's pass between two steps) against the other tree's
``second_pass`` then ``first_pass`` (row "closing+first").

    python3 tasks.py shell python benchmarks/bench_dem_passes.py --old /work/main/src [--n 1000] [--calls 300] [--reps 7]

The settled bed of benchmarks/bench_dem.py (n spheres, periodic, no damping) is settled by this tree; then
for ``predicted_verlet`` and ``velocity_verlet`` each pass is called on copies of one step's arrays. The old
tree's ``first_pass`` / ``second_pass`` are compiled from its ``dem/steploop.py`` source in this process (in
this module's namespace: the helpers they call, ``wrapped``, ``min_image``, ``outside``, ``still_active``, are
this tree's), so both run under the same load; old and new alternate ``--reps`` times. Printed: ns per
particle (mean ± sd), the new/old ratio of paired repetitions (mean ± sd), and whether both trees' passes
give bit-identical arrays and results over 5 calls.
"""
from __future__ import annotations

import argparse
import ast
import statistics as st
import sys
import time
from pathlib import Path

import numpy as np


def old_passes(src: Path):
    """``first_pass``, ``second_pass`` of the tree *src*, compiled here (no cache)."""
    from breachflow.dem import steploop

    path = src / "breachflow" / "dem" / "steploop.py"
    text = path.read_text()
    ns = dict(vars(steploop))
    for node in ast.parse(text).body:
        if isinstance(node, ast.FunctionDef) and node.name in ("first_pass", "second_pass"):
            exec('@numba.njit(error_model="numpy")\n' + ast.get_source_segment(text, node), ns)
    return ns["first_pass"], ns["second_pass"]


def _copies(args):
    return tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)


def _shared_copies(*tuples):
    """Copies of the arrays of several argument tuples, an array shared by two tuples copied once."""
    memo = {}
    return [tuple(memo.setdefault(id(x), x.copy()) if isinstance(x, np.ndarray) else x for x in t)
            for t in tuples]


def _same(a1, a2, r1, r2) -> bool:
    same = all(np.array_equal(x, y) for x, y in zip(a1, a2) if isinstance(x, np.ndarray))
    if r1 is not None:
        same = same and all((np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y) for x, y in zip(r1, r2))
    return same


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench_dem_passes", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--old", required=True, help="src directory of the other tree")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--calls", type=int, default=300)
    ap.add_argument("--reps", type=int, default=7)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem

    from breachflow.dem import steploop

    fo1, fo2 = old_passes(Path(a.old))
    bed, L = bench_dem.settled_bed(a.n)
    s0 = bed.state
    print(f"settled bed, {s0.n} spheres, {a.calls} calls x {a.reps} alternating repetitions; ns per particle")
    for integ in ("predicted_verlet", "velocity_verlet"):
        sim = bench_dem.make_sim(s0.pos.copy(), s0.vel.copy(), L, integ, omega=s0.omega.copy())
        sim.step(20)
        sim.pairs.rebuild()
        s, w, it = sim.state, sim.work, sim.integrator
        dt, idx, pred = sim.dt, sim.idx, bool(it.predict_velocity)
        h = 0.5 * dt
        first = (idx, s.pos, s.vel, s.omega, sim.force, sim.torque, w["fp"], w["tp"], w["v"], w["w"], sim._inv_m,
                 sim._inv_i, sim.lmask, sim.rmask, h, dt, pred, float(it.extrapolate), sim.geom, sim.periodic,
                 sim._box, sim._use_box, s.active.copy(), s.awake.copy(), sim._tmp_ids, sim.pairs.pos_build)
        ve, we = (w["v"], w["w"]) if pred else (s.vel, s.omega)
        damp = bool(steploop.any_damping(idx, s.c_gn, s.c_gw))
        second = (idx, s.active, True, s.mass, sim.gravity.g, ve, we, s.c_gn, s.c_gw, damp, sim.force, sim.torque,
                  s.vel, s.omega, sim._inv_m, sim._inv_i, h, sim.lmask, sim.rmask)
        nf = len(first)
        if hasattr(steploop, "close_and_first_pass"):
            def sep(*args):  # args: the first pass's, then the second's
                fo2(*args[nf:])
                return fo1(*args[:nf])

            def fused(*args):
                return steploop.close_and_first_pass(*args[:nf], True, True, s.mass, sim.gravity.g, s.c_gn,
                                                     s.c_gw, damp)
        cases = [("first_pass", fo1, steploop.first_pass, first), ("second_pass", fo2, steploop.second_pass, second)]
        if hasattr(steploop, "close_and_first_pass"):
            cases.append(("closing+first", sep, fused, first + (second[0], first[22]) + second[2:]))
        for name, fo, fn, args in cases:
            a1, a2 = (_shared_copies(args[:nf], args[nf:]) for _ in range(2))
            a1, a2 = a1[0] + a1[1], a2[0] + a2[1]
            same = all(_same(a1, a2, fo(*a1), fn(*a2)) for _ in range(5))
            t_old, t_new = [], []
            w1, w2 = (_shared_copies(args[:nf], args[nf:]) for _ in range(2))
            w1, w2 = w1[0] + w1[1], w2[0] + w2[1]
            for _ in range(a.reps):
                for f, wa, out in ((fo, w1, t_old), (fn, w2, t_new)):
                    c = time.process_time()
                    for _ in range(a.calls):
                        f(*wa)
                    out.append((time.process_time() - c) / a.calls / idx.size * 1e9)
            r = [y / x for x, y in zip(t_old, t_new)]
            print(f"  {integ:17s} {name:11s} old {st.mean(t_old):6.2f} ± {st.stdev(t_old):.2f}  new "
                  f"{st.mean(t_new):6.2f} ± {st.stdev(t_new):.2f}  new/old {st.mean(r):.3f} ± {st.stdev(r):.3f}  "
                  f"{'bit-identical' if same else 'DIFFERENT'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
