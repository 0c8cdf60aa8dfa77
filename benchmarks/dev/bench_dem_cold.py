"""First DEM run on an empty numba cache (compile cost) against a warm one (issue 16).

    python3 tasks.py bench dem_cold [--old <other tree's src>] [--reps 2]

A fresh process (``PYTHONPATH`` selecting the tree) imports breachflow, builds the 1000-sphere settled bed
of benchmarks/bench_dem.py from a saved state and steps it 200 times (``predicted_verlet``), first with an
empty ``NUMBA_CACHE_DIR`` (everything compiles), then again with that cache filled; printed: CPU seconds
of each process (``time.process_time``, import included).
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

RUN = r"""
import time
c0 = time.process_time()
import numpy as np
from breachflow.dem import DemSimulation, Material, Plane
d = np.load({bed!r}); L = float(d["L"])
mat = Material(density=2650, kn=1e7, ks=1e7, friction=0.5, c_cn=2e4)
sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], periodic_x=(0, L), periodic_y=(0, L),
                    dt=1e-3, sleeping=False, integrator="predicted_verlet")
sim.add_particles(d["pos"], 0.5, mat, vel=d["vel"])
sim.step(200)
print(time.process_time() - c0)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench dem_cold", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--old", help="src directory of a baseline tree")
    ap.add_argument("--reps", type=int, default=2)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_dem

    tmp = Path(tempfile.mkdtemp())
    sim, L = bench_dem.settled_bed(1000)
    np.savez(tmp / "bed.npz", pos=sim.state.pos, vel=sim.state.vel, L=L)
    trees = {"this tree": ROOT / "src"}
    if a.old:
        trees["old"] = Path(a.old).resolve()
    code = RUN.format(bed=str(tmp / "bed.npz"))
    for rep in range(a.reps):
        for name, src in trees.items():
            cache = tmp / f"cache_{rep}_{name.replace(' ', '_')}"
            env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
            cpu = [float(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                        check=True).stdout.strip().splitlines()[-1]) for _ in range(2)]
            print(f"{name:10s} rep {rep + 1}: empty cache {cpu[0]:.1f} CPU s, warm cache {cpu[1]:.2f} CPU s",
                  flush=True)
            shutil.rmtree(cache, ignore_errors=True)
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
