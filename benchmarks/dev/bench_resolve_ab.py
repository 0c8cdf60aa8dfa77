"""A/B of the closure's warm re-solve between two source trees (issue 16: quiet cells kept across the
porous pile's steps, the region re-solve).

    git archive <old-commit> src | tar -x -C /tmp/old
    .venv/bin/python benchmarks/bench_resolve_ab.py --old /tmp/old/src [--runs default,typical4] [--reps 1]
                                                   [--resolve full|region]

Runs (each in a fresh process, old / new interleaved, ``PYTHONPATH`` selecting the tree, each tree its own
numba cache, compiled before the timing by a first run): ``default`` the embedded default scenario
(``breachflow run``: 12 m breach, 1 m cells, porous pile); ``typical4`` ``examples/typical_breach.toml``
(61 m breach, 4 m cells). ``--resolve`` sets ``[hydro] resolve`` of the new tree's runs (the old tree
keeps the scenario's). Printed per run and tree: cycles, masses, tonnage, final breach discharge and
seepage, and per cycle the re-solve CPU time (this process, from the manifest's ``cpu_solve``; the
mean and its standard deviation over the cycles) and the new/old ratio of the summed re-solve CPU time.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics as st
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = r"""
import json, re, sys
from breachflow.cycle.main import run_closure, default_scenario_text
scenario, out, resolve = sys.argv[1], sys.argv[2], sys.argv[3]
text = default_scenario_text() if scenario == "default" else open(scenario).read()
if resolve != "-":
    text = re.sub(r'^resolve = .*\n', '', text, flags=re.M)
    text = text.replace("[hydro]\n", f'[hydro]\nresolve = "{resolve}"\n', 1)
path = out + "/scenario.toml"
open(path, "w").write(text)
res = run_closure(path, out + "/run", overwrite=True, plots=False)
print(json.dumps({"closed": bool(res.closed)}))
"""

RUNS = {"default": "default", "typical4": str(ROOT / "examples" / "typical_breach.toml")}


def run_one(src: Path, cache: Path, scenario: str, resolve: str, work: Path) -> dict:
    work.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", CHILD, scenario, str(work), resolve], env=env, capture_output=True,
                         text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-3000:])
    man = json.loads((work / "run" / "manifest.json").read_text())
    cyc = [c["summary"] for c in man["cycles"]]
    last = cyc[-1] if cyc else {}
    return dict(cycles=len(cyc), masses=last.get("masses", 0), tonnage=last.get("tonnage", 0.0),
                q=last.get("breach_discharge", float("nan")), seep=last.get("seepage_discharge", float("nan")),
                cpu=[c.get("cpu_solve", float("nan")) for c in cyc], resolves=[c.get("hydro", "") for c in cyc],
                closed=json.loads(out.stdout.strip().splitlines()[-1])["closed"])


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True, help="src directory of the baseline tree")
    ap.add_argument("--runs", default="default,typical4")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--resolve", default="-", help="[hydro] resolve of the new tree's runs (default: the scenario's)")
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    trees = {"old": (Path(a.old).resolve(), tmp / "cache_old", "-"), "new": (ROOT / "src", tmp / "cache_new", a.resolve)}
    for name, (src, cache, _) in trees.items():  # compile into each tree's cache outside the timing
        run_one(src, cache, "default", "-", tmp / f"warm_{name}")
    for run in a.runs.split(","):
        res = {}
        for k in range(a.reps):
            for name, (src, cache, resolve) in trees.items():
                res.setdefault(name, []).append(run_one(src, cache, RUNS[run], resolve, tmp / f"{run}_{name}_{k}"))
        for name, rs in res.items():
            r = rs[0]
            cpu = [c for x in rs for c in x["cpu"]]
            sd = st.stdev(cpu) if len(cpu) > 1 else float("nan")
            region = sum("% of the domain" in w for w in r["resolves"])
            print(f"{run} {name}: closed {r['closed']}, {r['cycles']} cycles, {r['masses']} masses, "
                  f"{r['tonnage']:.1f} t, final Q {r['q']:.4g} m3/s (seepage {r['seep']:.4g}); re-solve CPU per "
                  f"cycle {st.mean(cpu):.2f} ± {sd:.2f} s (sum {sum(cpu) / len(rs):.1f} s per run; "
                  f"region re-solves {region} of {len(r['resolves'])})", flush=True)
        ratio = [sum(n["cpu"]) / sum(o["cpu"]) for o, n in zip(res["old"], res["new"])]
        print(f"{run}: summed re-solve CPU new/old {st.mean(ratio):.2f}"
              + (f" ± {st.stdev(ratio):.2f}" if len(ratio) > 1 else "") + f" (n={len(ratio)})", flush=True)


if __name__ == "__main__":
    main()
