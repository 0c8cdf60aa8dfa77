"""A/B DEM throughput of two source trees on the same settled bed (issue 12: cost of the contact law's force interval).

    git archive <old-commit> src | tar -x -C /tmp/old
    .venv/bin/python benchmarks/bench_dem_ab.py --old /tmp/old/src [--n 1000] [--steps 2000] [--reps 3] [--scene bed|pour]

The bed of benchmarks/bench_dem.py (n spheres, d 1 m, kn 1e7, e 0.5, mu 0.5, periodic, dt 1e-3 s) is
settled once by this tree and saved; each timing runs in a fresh process (old / new interleaved,
``PYTHONPATH`` selecting the tree) and reports particle-steps per CPU second (``time.process_time``).
Printed: mean ± standard deviation per tree and integrator and the new/old ratio of paired runs.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics as st
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

TIMER = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, {bench!r})
import bench_dem as b
from breachflow.dem import DemSimulation, Plane
d = np.load({bed!r}); L = float(d["L"]); n = d["pos"].shape[0]
mat, _ = b.material()
sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], periodic_x=(0, L), periodic_y=(0, L),
                    dt=b.DT, sleeping=False, integrator={integ!r})
sim.add_particles(d["pos"], b.D / 2, mat, vel=d["vel"])
sim.step(20)
t = time.process_time(); sim.step({steps}); cpu = time.process_time() - t
print(json.dumps(n * {steps} / cpu))
"""


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True, help="src directory of the baseline tree")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--scene", default="bed", choices=("bed", "pour"),
                    help="settled bed or poured pile (bench_dem.py); timed from the same start state")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_dem

    tmp = Path(tempfile.mkdtemp())
    sim, L = bench_dem.settled_bed(a.n) if a.scene == "bed" else bench_dem.poured_pile(a.n)
    bed = tmp / "bed.npz"
    np.savez(bed, pos=sim.state.pos, vel=sim.state.vel, L=L)
    # a fresh numba cache per tree (a cached kernel is not rebuilt when an inlined helper changes)
    trees = {"old": (Path(a.old).resolve(), tmp / "cache_old"), "new": (ROOT / "src", tmp / "cache_new")}
    rates = {}
    for _ in range(a.reps):
        for integ in ("predicted_verlet", "velocity_verlet"):
            for name, (src, cache) in trees.items():
                code = TIMER.format(bench=str(ROOT / "benchmarks"), bed=str(bed), integ=integ, steps=a.steps)
                env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
                out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                     check=True)
                rates.setdefault((integ, name), []).append(float(out.stdout.strip().splitlines()[-1]))
    for integ in ("predicted_verlet", "velocity_verlet"):
        o, n = rates[(integ, "old")], rates[(integ, "new")]
        r = [y / x for x, y in zip(o, n)]
        sd = lambda v: st.stdev(v) if len(v) > 1 else float("nan")
        print(f"{integ:17s} old {st.mean(o) / 1e6:.2f} ± {sd(o) / 1e6:.2f}  new {st.mean(n) / 1e6:.2f} ± "
              f"{sd(n) / 1e6:.2f} M particle-steps/CPU s; new/old {st.mean(r):.3f} ± {sd(r):.3f} (n={len(r)})")


if __name__ == "__main__":
    main()
