"""Cost of the DEM contact loop per listed pair against a bare Hooke normal-force loop (issue 16).

    python3 tasks.py bench dem_kernel [--n 1000] [--calls 2000] [--reps 5]

On the settled bed of benchmarks/bench_dem.py (n spheres), times ``contacts.pair_forces_window`` (the
window-averaged spring–dashpot law with shear history, as the Verlet integrators call it) and a loop over
the same pair list that only adds ``k_N overlap`` along the normal (what any contact code must do at
least), in CPU ns per listed pair; best of ``--reps``, interleaved. The same kernel with
``contact_law = "hooke_history"`` (LAMMPS' point-evaluated law) is timed too.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def bare_hooke(pa, pb, pos, radius, kn, geom, periodic, force):
    """Normal spring only: the floor cost of a pair loop over the same list."""
    nc = 0
    for p in range(pa.shape[0]):
        i = pa[p]
        j = pb[p]
        dx = pos[j, 0] - pos[i, 0]
        dy = pos[j, 1] - pos[i, 1]
        if periodic[0]:
            dx -= geom[6] * math.floor(dx / geom[6] + 0.5)
        if periodic[1]:
            dy -= geom[7] * math.floor(dy / geom[7] + 0.5)
        dz = pos[j, 2] - pos[i, 2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        ov = radius[i] + radius[j] - dist
        if ov <= 0.0:
            continue
        f = -kn * ov / dist
        force[i, 0] += f * dx
        force[i, 1] += f * dy
        force[i, 2] += f * dz
        force[j, 0] -= f * dx
        force[j, 1] -= f * dy
        force[j, 2] -= f * dz
        nc += 1
    return nc


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench dem_kernel", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_dem

    from breachflow.dem import contacts

    sim, _ = bench_dem.settled_bed(a.n)
    sim.step(5)
    s = sim.state
    f, t = sim.force.copy(), sim.torque.copy()
    dt = sim.dt
    law = (sim._pa, sim._pb, sim._hist.copy(), sim._rhist.copy(), sim._touch.copy(), s.pos, s.vel, s.omega, s.vel,
           s.omega, False, s.radius, s.mass, s.inertia, s._props, s.awake, s.active, sim.geom, sim.periodic, dt,
           sim.wake_velocity, f, t, sim._wake_flag, sim._wake_ids, np.zeros(1, np.int64), -0.5 * dt, 0.5 * dt)
    bare = (sim._pa, sim._pb, s.pos, s.radius, float(s.kn[0]), sim.geom, sim.periodic, f)
    # LAMMPS' law, point values (contact_law hooke_history), on its own copy of the histories
    law_h = law[:2] + (law[2].copy(), law[3].copy(), law[4].copy()) + law[5:-2] + (0.0, 0.0, contacts.HOOKE_HISTORY)
    kernels = {"pair_forces_window": (contacts.pair_forces_window, law),
               "  hooke_history law": (contacts.pair_forces_window, law_h), "bare Hooke": (bare_hooke, bare)}
    best = {k: math.inf for k in kernels}
    for fn, args in kernels.values():
        fn(*args)
    for _ in range(a.reps):
        for name, (fn, args) in kernels.items():
            c = time.process_time()
            for _ in range(a.calls):
                fn(*args)
            best[name] = min(best[name], (time.process_time() - c) / a.calls)
    npairs, ntouch = sim._pa.size, int(bare_hooke(*bare))
    print(f"{a.n} spheres: {npairs} listed pairs, {ntouch} in contact")
    for name, sec in best.items():
        print(f"{name:20s} {sec * 1e6:8.1f} CPU us per call, {sec / npairs * 1e9:6.1f} ns per listed pair")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
