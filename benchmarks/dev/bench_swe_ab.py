"""A/B shallow-water throughput of two source trees (issue 16: the fused, quiet-skipping kernels).

    git archive <old-commit> src | tar -x -C /tmp/old
    .venv/bin/python benchmarks/bench_swe_ab.py --old /tmp/old/src [--reps 3] [--cases stoker,wet,dry]

Cases (second order, one numba thread unless ``--threads``): ``stoker`` the Stoker dam break of
``bench_swe.py`` (100 m × 5 m, 0.125 m square cells = 32,000 cells, to t = 5 s; also its L1 error);
``wet`` the throughput domain of ``bench_swe.py`` (316 × 316 cells, a dam break in a wet basin, 40
steps: the wave covers a small part, the rest is at rest); ``busy`` the same grid with every cell
moving (h 1 ± 0.2 m, u 0.5, v 0.2 m/s; no cell is quiet: the cost of the fused kernels alone); ``dry`` a mostly dry polder (400 × 400 cells of 1 m, a 40 m wide basin 2 m deep at the west
edge flowing onto a dry bed, 60 s). Each timing runs in a fresh process (old / new interleaved,
``PYTHONPATH`` selecting the tree, each tree its own numba cache) and reports cell-steps per CPU second
(``time.process_time``; a second-order step is two stages). Printed: mean ± standard deviation per
tree and the new/old ratio of paired runs, and whether both trees give bitwise the same depths.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics as st
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

TIMER = r"""
import dataclasses, hashlib, json, math, sys, time
import numpy as np
sys.path.insert(0, {bench!r})
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import uniform_grid
case, threads = {case!r}, {threads}
kw = dict(order=2, threads=threads)
if {skip!r} is not None and "skip_quiet" in {{f.name for f in dataclasses.fields(SWEOptions)}}:
    kw["skip_quiet"] = {skip!r}
if {tol!r} is not None and "quiet_tolerance" in {{f.name for f in dataclasses.fields(SWEOptions)}}:
    kw["quiet_tolerance"] = {tol!r}
if case == "stoker":
    dom = uniform_grid(0, 100, 0, 5, 0.125, initial_surface=lambda X, Y: np.where(X < 50.0, 1.0, 0.1))
    t_end, max_steps = 5.0, 10**9
elif case == "wet":
    n = 316
    dom = uniform_grid(0, n, 0, n, 1.0, manning=0.02,
                       initial_surface=lambda X, Y: np.where(X + 0.3 * Y < 0.6 * n, 2.0, 1.0),
                       bed=lambda X, Y: 0.1 * np.sin(X / 7.0) * np.cos(Y / 5.0))
    t_end, max_steps = 1e9, 40
elif case == "busy":
    n = 316
    dom = uniform_grid(0, n, 0, n, 1.0, manning=0.02, bed=lambda X, Y: 0.1 * np.sin(X / 7.0) * np.cos(Y / 5.0))
    X, Y = np.meshgrid(dom.x, dom.y)
    h0 = 1.0 + 0.2 * np.sin(X / 11.0) * np.cos(Y / 13.0)
    initial = (h0, 0.5 * h0, 0.2 * h0)
    t_end, max_steps = 1e9, 40
else:
    dom = uniform_grid(0, 400, 0, 400, 1.0, manning=0.03, bed=lambda X, Y: 0.02 * np.sin(X / 9.0) * np.cos(Y / 7.0),
                       initial_surface=lambda X, Y: np.where(X < 40.0, 2.0, -1.0))
    t_end, max_steps = 60.0, 10**9
initial = initial if case == "busy" else None
SWESimulation(dom, SWEOptions(**kw), initial=initial).advance_to(1e9, max_steps=2)  # compile outside the timing
sim = SWESimulation(dom, SWEOptions(**kw), initial=initial)
c0 = time.process_time(); w0 = time.perf_counter()
sim.advance_to(t_end, max_steps=max_steps)
cpu = time.process_time() - c0; wall = time.perf_counter() - w0
out = dict(rate=dom.bed.size * sim.steps / cpu, wall_rate=dom.bed.size * sim.steps / wall, steps=sim.steps,
           digest=hashlib.sha1(np.ascontiguousarray(sim.depth).tobytes()).hexdigest())
if case == "stoker":
    sys.path.insert(0, {bench!r})
    from bench_swe import stoker_exact
    out["l1"] = float(np.abs(sim.depth - stoker_exact(dom.x)[None, :]).sum() * dom.dx * dom.dy / 500.0)
print(json.dumps(out))
"""


def run_one(src: Path, cache: Path, case: str, threads: int, skip=None, tol=None) -> dict:
    code = TIMER.format(bench=str(ROOT / "benchmarks"), case=case, threads=threads, skip=skip, tol=tol)
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-3000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True, help="src directory of the baseline tree")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--cases", default="stoker,wet,busy,dry")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--no-skip", action="store_true",
                    help="also time the new tree without quiet-cell skipping and with exact skipping (tolerance 0)")
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    new_cache = tmp / ("cache_new_" + hashlib.sha1(str(ROOT).encode()).hexdigest()[:8])
    trees = {"old": (Path(a.old).resolve(), tmp / "cache_old", None, None),
             "new": (ROOT / "src", new_cache, None, None)}
    if a.no_skip:
        trees["new, exact skip"] = (ROOT / "src", new_cache, True, 0.0)
        trees["new, no skip"] = (ROOT / "src", new_cache, False, None)
    res: dict = {}
    for _ in range(a.reps):
        for case in a.cases.split(","):
            for name, (src, cache, skip, tol) in trees.items():
                res.setdefault((case, name), []).append(run_one(src, cache, case, a.threads, skip, tol))
    sd = lambda v: st.stdev(v) if len(v) > 1 else float("nan")  # noqa: E731
    for case in a.cases.split(","):
        old = [r["rate"] for r in res[(case, "old")]]
        line = [f"{case:6s} ({a.threads} thread(s)) old {st.mean(old) / 1e6:.2f} ± {sd(old) / 1e6:.2f}"]
        for name in list(trees)[1:]:
            new = [r["rate"] for r in res[(case, name)]]
            r = [y / x for x, y in zip(old, new)]
            same = res[(case, name)][0]["digest"] == res[(case, "old")][0]["digest"]
            line.append(f"{name} {st.mean(new) / 1e6:.2f} ± {sd(new) / 1e6:.2f} M cell-steps/CPU s, "
                        f"{name}/old {st.mean(r):.2f} ± {sd(r):.2f} (n={len(r)}), same depths: {same}")
        if "l1" in res[(case, "old")][0]:
            line.append("L1 " + ", ".join(f"{k} {res[(case, k)][0]['l1']:.6e} m" for k in trees))
        line.append(f"steps {res[(case, 'old')][0]['steps']}")
        print("; ".join(line), flush=True)


if __name__ == "__main__":
    main()
