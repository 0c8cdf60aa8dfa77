"""A/B cost of the DEM's terrain contacts on breach terrain, two source trees (old / new interleaved).

    git archive <old-commit> src | tar -x -C /tmp/old
    .venv/bin/python benchmarks/dev/bench_terrain_ab.py --old /tmp/old/src [--cell 2] [--steps 3000] [--reps 3]

The scene: a breach 60 m wide between walls 7.5 m high on a terrain grid of ``--cell`` m (the wall rises over
one cell), 400 rock spheres (r 1.035 m, kn 2e8 N/m, e 0.3, friction 0.6, rolling friction 0.3) released in a
lattice over the floor and settled for 6 s by each tree, then ``--steps`` steps timed (``time.process_time``)
in a fresh process per tree and repetition (``PYTHONPATH`` selecting the tree, a numba cache per tree).
Printed per tree: ns per sphere-step mean ± standard deviation, the new/old ratio of paired runs, and the
settled pile each tree gives (median centre height, fastest sphere): the error figure of the comparison.
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

ROOT = Path(__file__).resolve().parents[2]

TIMER = r"""
import json, math, time
import numpy as np
from breachflow.dem import DemSimulation, HeightField, Material, sphere_mass
R, KN, cell = 1.035, 2e8, {cell}
M = float(sphere_mass(R, 2650.0))
zeta = -math.log(0.3) / math.sqrt(math.pi ** 2 + math.log(0.3) ** 2)
mat = Material(kn=KN, friction=0.6, rolling_friction=0.3, c_cn=2 * zeta * math.sqrt(KN * M),
               c_cs=2 * zeta * math.sqrt(KN * M / 3.5))
x = np.arange(-48.0, 48.01, cell)
y = np.arange(-24.0, 24.01, cell)
z = np.where(np.abs(x[None, :]) < 30.0, 30.5, 38.0) * np.ones((y.size, 1))
sim = DemSimulation(boundaries=[HeightField(x, y, z, mat)], sleeping=False)
gx, gy, gz = np.arange(-26.4, 26.5, 2.2), np.arange(-7.7, 7.8, 2.2), np.arange(0, 4) * 2.2
lattice = np.array(np.meshgrid(gx, gy, gz)).reshape(3, -1).T[:400]
lattice[:, 2] += 30.5 + R + 0.3
sim.add_particles(lattice, R, mat)
sim.run(6.0)
t = time.process_time(); sim.step({steps}); cpu = time.process_time() - t
v = np.linalg.norm(sim.state.vel, axis=1)
print(json.dumps([cpu / {steps} / sim.state.n * 1e9, float(np.median(sim.state.pos[:, 2])), float(v.max())]))
"""


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True, help="src directory of the baseline tree")
    ap.add_argument("--cell", type=float, default=2.0)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    trees = {"old": (Path(a.old).resolve(), tmp / "cache_old"), "new": (ROOT / "src", tmp / "cache_new")}
    runs = {}
    for _ in range(a.reps):
        for name, (src, cache) in trees.items():
            env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
            out = subprocess.run([sys.executable, "-c", TIMER.format(cell=a.cell, steps=a.steps)], env=env,
                                 capture_output=True, text=True, check=True)
            runs.setdefault(name, []).append(json.loads(out.stdout.strip().splitlines()[-1]))
    sd = lambda v: st.stdev(v) if len(v) > 1 else float("nan")  # noqa: E731
    for name, rs in runs.items():
        ns = [r[0] for r in rs]
        print(f"{name}: {st.mean(ns):.0f} ± {sd(ns):.0f} ns per sphere-step; settled pile: median centre "
              f"{rs[-1][1]:.4f} m, fastest {rs[-1][2]:.2g} m/s")
    ratio = [n[0] / o[0] for o, n in zip(runs["old"], runs["new"])]
    print(f"new/old {st.mean(ratio):.3f} ± {sd(ratio):.3f} (n={len(ratio)}, {a.cell:g} m cells, {a.steps} steps)")


if __name__ == "__main__":
    main()
