"""Is a DEM kernel change within round-off? Mean height and kinetic energy per particle after *steps* steps
from one start (the settled bed or poured pile of bench_dem.py), two source trees, and the old tree again
from the start's positions scaled by 1 + 1e-15 (the round-off yardstick), for velocity_verlet and
predicted_verlet with the step-averaged law and velocity_verlet with hooke_history (issue 16).

    python3 tasks.py shell python benchmarks/bench_dem_roundoff.py <old src> <new src> bed|pour <n> <steps>

Each tree runs in a fresh process with its own numba cache (``PYTHONPATH`` selects the tree).
"""
import json, os, subprocess, sys, tempfile
from pathlib import Path
import numpy as np
old, new, scene, n, steps = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
bench = str(Path(__file__).resolve().parents[1])  # the folder of bench_dem
tmp = Path(tempfile.mkdtemp())
sys.path.insert(0, bench)
import bench_dem as b
sim, L = b.settled_bed(n) if scene == "bed" else b.poured_pile(n)
s = sim.state
np.savez(tmp / "s.npz", pos=s.pos, vel=s.vel, om=s.omega, L=L)
CODE = r"""
import json, sys, numpy as np
sys.path.insert(0, {bench!r})
import bench_dem as b
d = np.load({f!r}); L = float(d["L"])
pos = d["pos"] * (1.0 + {eps})
out = {{}}
for integ, law in (("velocity_verlet", "step_averaged"), ("predicted_verlet", "step_averaged"), ("velocity_verlet", "hooke_history")):
    sim = b.make_sim(pos.copy(), d["vel"].copy(), L, integ, omega=d["om"].copy(), law=law)
    sim.step({steps})
    out[integ[:2] + "/" + law[:4]] = b.summary(sim)
print(json.dumps(out))
"""
res = {}
for tag, src, eps in (("old", old, 0.0), ("new", new, 0.0), ("old+eps", old, 1e-15)):
    env = dict(os.environ, PYTHONPATH=src, NUMBA_CACHE_DIR=str(tmp / ("c_" + ("old" if src == old else "new"))))
    o = subprocess.run([sys.executable, "-c", CODE.format(bench=bench, f=str(tmp / "s.npz"), eps=eps, steps=steps)], env=env, capture_output=True, text=True, check=True)
    res[tag] = json.loads(o.stdout.strip().splitlines()[-1])
print(f"{scene} n={n} after {steps} steps: mean z (m), KE per particle (J); new-old and (old perturbed 1e-15)-old")
for k in res["old"]:
    (zo, ko), (zn, kn), (ze, ke) = res["old"][k], res["new"][k], res["old+eps"][k]
    print(f"  {k:10s} z {zo:.9f}  new-old {zn - zo:+.2e}  pert-old {ze - zo:+.2e} | KE {ko:.6e}  new/old-1 {kn / ko - 1:+.2e}  pert/old-1 {ke / ko - 1:+.2e}")
