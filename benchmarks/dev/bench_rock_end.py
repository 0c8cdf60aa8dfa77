"""Where the typical breach's CPU goes, and the rock stage's end with and without continuing a submerged crest's re-solve.

    python3 tasks.py bench rock_end [--resolutions 4,4+2] [--paths new,old] [--max-cycles N]
                                    [--scenario examples/typical_breach.toml] [--json FILE]

Each run is a closure of the scenario (default ``examples/typical_breach.toml``) in a child process, as
``breachflow run`` would run it, with the rock stage's end set two ways (:mod:`breachflow.cycle.rock_end`):

* ``new``: a cycle whose pile crest is below the flood in a gap column keeps its ``t_max``
  re-solve (``CONTINUE_SUBMERGED = False``): the dam cannot hold, so its flow is not solved on to steady;
* ``old`` (the default): every cycle that the criteria call closed is solved on to its steady state (up to ``steady_cap``)
  before the crest is judged (``CONTINUE_SUBMERGED = True``).

Each item of ``--resolutions`` is ``RES[+FINE]`` (cell size in m, optionally a nested fine grid at the
breach, ``[hydro] refine``). ``--max-cycles`` caps ``[criteria] max_cycles`` (say so when quoting). The
paths of one resolution run one after the other in the same command, so their CPU ratio is a same-run
ratio. Printed per run: CPU seconds in all (this child process: ``time.process_time``) and split into its
parts — the first solve (with the weir calibration's re-solves), the warm re-solves of ``t_max``, the rock
stage's end continued to steady, the seal's re-solves, the DEM, the output, and the rest (set-up, criteria,
remap) — then the verdict, cycles, tonnage, masses lost, the seal, and per cycle the breach discharge.
The error figure: the breach discharge of every cycle of ``new`` against ``old`` (the ``old`` path solves
the judging cycles to steady, the tight reference of those cycles), the cycle count and tonnage of both.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CHILD = r"""
import json, sys, time
from breachflow.cycle import rock_end, sealing
from breachflow.cycle.main import run_closure
scenario, out, result, path = sys.argv[1:5]
rock_end.CONTINUE_SUBMERGED = path == "old"
spent = {"rock_end": 0.0, "rock_end_solves": 0}
inner = rock_end.continue_to_steady
def timed(solve, snapshot, cap=rock_end.STEADY_CAP):
    if sys._getframe(1).f_globals.get("__name__") != "breachflow.cycle.driver":  # the seal's: in its own CPU
        return inner(solve, snapshot, cap)
    c0 = time.process_time()
    r = inner(solve, snapshot, cap)
    spent["rock_end"] += time.process_time() - c0
    spent["rock_end_solves"] += r[3] - 1
    return r
rock_end.continue_to_steady = timed
c0 = time.process_time()
res = run_closure(scenario, out, overwrite=True, plots=False)
json.dump(dict(spent, cpu=time.process_time() - c0, closed=res.closed, verdict=res.verdict), open(result, "w"))
"""


def one_run(scenario: Path, item: str, path: str, work: Path, max_cycles: int | None) -> dict:
    m = re.fullmatch(r"\s*([0-9.]+)(?:\+([0-9.]+))?\s*", item)
    if not m:
        raise SystemExit(f"--resolutions item {item!r}: use RES[+FINE]")
    res, fine = float(m[1]), (float(m[2]) if m[2] else None)
    label = f"{res:g} m" + (f"+{fine:g} m" if fine else "")
    text = scenario.read_text(encoding="utf-8")
    text, n = re.subn(r'^resolution = "[^"]*"', f'resolution = "{res:g} m"', text, flags=re.M)
    if n != 1:
        raise SystemExit(f"{scenario}: no single [hydro] resolution to override")
    text = re.sub(r'^refine = .*\n', "", text, flags=re.M)
    if fine:
        text = text.replace("[hydro]\n", f'[hydro]\nrefine = "{fine:g} m"\n', 1)
    if max_cycles:
        text, n = re.subn(r'^max_cycles = .*$', f"max_cycles = {int(max_cycles)}", text, flags=re.M)
        if n != 1:
            raise SystemExit(f"{scenario}: no single [criteria] max_cycles to cap")
    tag = re.sub(r"[^0-9a-z]+", "_", f"{label} {path}")
    sc, out, rfile = work / f"{tag}.toml", work / f"run_{tag}", work / f"res_{tag}.json"
    sc.write_text(text, encoding="utf-8")
    w0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", CHILD, str(sc), str(out), str(rfile), path], check=True)
    r = json.loads(rfile.read_text())
    r.update(label=label, path=path, wall=time.perf_counter() - w0)
    man = json.loads((out / "manifest.json").read_text())
    cyc = [c["summary"] for c in man["cycles"]]
    meta = man.get("metadata", {})
    seal = meta.get("seal") or {}
    r.update(cycles=len(cyc), q=[c.get("breach_discharge") for c in cyc],
             tonnage=cyc[-1].get("tonnage", 0.0) if cyc else 0.0, lost=cyc[-1].get("left_domain", 0) if cyc else 0,
             first=(meta.get("initial") or {}).get("solve_cpu_time", 0.0),
             warm=sum(c.get("cpu_solve", 0.0) for c in cyc), dem=sum(c.get("cpu_dem", 0.0) for c in cyc),
             output=sum(c.get("time_output", 0.0) for c in cyc),
             seal=sum(st.get("solve_cpu_s", 0.0) for st in seal.get("steps", [])),
             seal_t=seal.get("seal_tonnage_t"), sealed=seal.get("sealed"),
             rock_end_cycles=[(c["cycle"], c["rock_end"].get("held"), c["rock_end"].get("simulated_s"))
                              for c in cyc if c.get("rock_end")])
    r["other"] = r["cpu"] - r["first"] - r["warm"] - r["dem"] - r["output"] - r["seal"] - r["rock_end"]
    return r


PARTS = ("first", "warm", "rock_end", "seal", "dem", "output", "other")


def report(rows) -> None:
    print("\n| run | CPU s | " + " | ".join(PARTS) + " | verdict | cycles | tonnage t | lost | seal t |")
    print("|---" * (len(PARTS) + 7) + "|")
    for r in rows:
        parts = " | ".join(f"{r[p]:.1f} ({100 * r[p] / r['cpu']:.0f} %)" for p in PARTS)
        seal = f"{r['seal_t']:.0f}" if r.get("seal_t") is not None else "-"
        print(f"| {r['label']} {r['path']} | {r['cpu']:.1f} | {parts} | {'closed' if r['closed'] else 'not closed'} | "
              f"{r['cycles']} | {r['tonnage']:,.0f} | {r['lost']} | {seal} |")
    for r in rows:
        print(f"  {r['label']} {r['path']}: rock-stage end judged at (cycle, held, simulated s) {r['rock_end_cycles']}; "
              f"{r['rock_end_solves']} continued solves; verdict: {r['verdict']}")


def compare(rows) -> None:
    by = {}
    for r in rows:
        by.setdefault(r["label"], {})[r["path"]] = r
    for label, d in by.items():
        if "new" not in d or "old" not in d:
            continue
        new, old = d["new"], d["old"]
        print(f"\n{label}: CPU new / old = {new['cpu'] / old['cpu']:.3f} ({new['cpu']:.1f} / {old['cpu']:.1f} s); "
              f"rock-stage end {new['rock_end']:.1f} / {old['rock_end']:.1f} s; cycles {new['cycles']} / {old['cycles']}, "
              f"tonnage {new['tonnage']:,.0f} / {old['tonnage']:,.0f} t, closed {new['closed']} / {old['closed']}")
        print("  cycle  Q new m3/s  Q old m3/s  difference")
        for g, (qn, qo) in enumerate(zip(new["q"], old["q"]), start=1):
            print(f"  {g:5d}  {qn:10.2f}  {qo:10.2f}  {100 * (qn - qo) / qo:+8.3f} %")


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench rock_end")
    ap.add_argument("--resolutions", default="4")
    ap.add_argument("--paths", default="new,old")
    ap.add_argument("--max-cycles", type=int, default=None)
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "typical_breach.toml"))
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    paths = [p.strip() for p in a.paths.split(",") if p.strip()]
    if not paths or any(p not in ("new", "old") for p in paths):
        raise SystemExit(f"--paths {a.paths!r}: use new and/or old")
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-rock-end-") as tmp:
        for item in [i for i in a.resolutions.split(",") if i.strip()]:
            for p in paths:
                rows.append(one_run(Path(a.scenario), item, p, Path(tmp), a.max_cycles))
                report(rows[-1:])
                if a.json:
                    Path(a.json).write_text(json.dumps(rows, indent=1, default=str))
    print("\n=== all runs ===")
    report(rows)
    compare(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
