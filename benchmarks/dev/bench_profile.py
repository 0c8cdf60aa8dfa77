"""Cost of the vertical velocity profile in the fused fluid-force kernel (issue 14).

    python3 tasks.py bench profile [--particles 5,200] [--calls 2000] [--repeats 5]

One ``FluidForces.accumulate`` call (drag, buoyancy, convective apparent mass, gridpoint torque) on a
non-uniform grid snapshot (water 0-3 m deep over a sloping bed, a jet, a dry bank), particles spread over
the water column, for the profiles ``uniform``, ``log`` and ``power`` in the fused kernel, and ``log`` in
the step-by-step path (``compiled=False``, the only path a profile had before). Calls are interleaved
over the variants in each repeat (load drifts on a shared machine); printed per variant: median µs per
call over the repeats with the spread (min-max) as its error figure, the ratio to fused ``uniform``
(median of the per-repeat ratios, with min-max), and the largest relative force difference between the
fused and step-by-step ``log`` (the accuracy that goes with the speed).
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np



def field():
    from breachflow.field.snapshot import grid_snapshot

    x = np.arange(-10.0, 10.0 + 1e-9, 0.7)
    y = np.arange(-8.0, 8.0 + 1e-9, 0.91)
    X, Y = np.meshgrid(x, y)
    bed = 0.05 * X + 0.1 * np.sin(Y)
    surface = 2.5 + 0.02 * Y
    depth = np.where(X > 6.0, 0.0, np.maximum(surface - bed, 0.0))
    u = np.where(depth > 0, 3.0 * np.exp(-(Y / 4.0) ** 2) + 0.2 * X / 10, 0.0)
    v = np.where(depth > 0, 0.5 * np.sin(X / 3.0), 0.0)
    return grid_snapshot(x, y, bed, depth, u, v)


def state(n, rng):
    from breachflow.dem.state import Material, ParticleState

    pos = np.column_stack([rng.uniform(-9, 5, n), rng.uniform(-7, 7, n), rng.uniform(-0.3, 2.8, n)])
    return ParticleState.spheres(pos, rng.uniform(0.3, 1.0, n), Material(density=2650.0),
                                 vel=rng.normal(0, 0.5, (n, 3)))


def main(argv) -> int:
    from breachflow.fluid.forces import FluidForces

    ap = argparse.ArgumentParser(prog="bench profile")
    ap.add_argument("--particles", default="5,200")
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    snap = field()
    variants = {"fused uniform": dict(velocity_profile="uniform"), "fused log": dict(velocity_profile="log"),
                "fused power": dict(velocity_profile="power"),
                "step-by-step log": dict(velocity_profile="log", compiled=False)}
    for n in [int(s) for s in a.particles.split(",") if s]:
        rng = np.random.default_rng(n)
        st = state(n, rng)
        models = {k: FluidForces(snap, outside="air", **kw) for k, kw in variants.items()}
        f = np.zeros((n, 3))
        t = np.zeros((n, 3))
        for m in models.values():  # compile / warm up
            m.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, t)
        calls = max(1, a.calls // max(1, n // 20)) if n > 20 else a.calls
        times = {k: [] for k in models}
        for _ in range(a.repeats):
            for k, m in models.items():
                c0 = time.process_time()
                for _ in range(calls):
                    m.accumulate(st, st.pos, st.vel, st.omega, 0.0, f, t)
                times[k].append((time.process_time() - c0) / calls * 1e6)
        res = {}
        for k, m in models.items():
            ff = np.zeros((n, 3))
            m.accumulate(st, st.pos, st.vel, st.omega, 0.0, ff, np.zeros((n, 3)))
            res[k] = ff
        err = float(np.abs(res["fused log"] - res["step-by-step log"]).max() / np.abs(res["step-by-step log"]).max())
        base = np.array(times["fused uniform"])
        print(f"\n{n} particles, {calls} calls x {a.repeats} repeats (CPU µs per accumulate call):")
        for k, ts in times.items():
            ts = np.array(ts)
            r = ts / base
            print(f"  {k:18s} {np.median(ts):9.1f} µs (min-max {ts.min():.1f}-{ts.max():.1f}); "
                  f"/ fused uniform {np.median(r):.2f}x (min-max {r.min():.2f}-{r.max():.2f})")
        print(f"  largest |fused log - step-by-step log| / max |force|: {err:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
