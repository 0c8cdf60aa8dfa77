"""Seed sweep of the nested closure from a user's regional-model files (issue 16): the scene of
``tests/site/test_nested.py::test_nested_closure_from_the_users_adh_and_hecras_files`` (the scaled breach's
steady state on an unaligned 1 m mesh, written as HEC-RAS 6 plan HDF or ADH files; ``solver = "nested"``) run
to closure at several placement seeds; per seed: closed?, cycles, masses, tonnage, lost, CPU s and the breach
discharge of every cycle, then the totals.

    python3 tasks.py bench nested_seeds --seeds 1-12 [--rule mean_speed|speed] [--fmt hecras_hdf|adh] [--out DIR]

``--rule`` sets ``[dem] rest_rule`` (which masses are the pile at the DEM's cap, :mod:`breachflow.cycle.rest`);
without it the scenario's default.
"""
from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _seeds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench nested_seeds", description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1-12", help="e.g. 1-12 or 1,3,5")
    ap.add_argument("--rule", default=None, help="[dem] rest_rule (default: the scenario default)")
    ap.add_argument("--fmt", default="hecras_hdf", choices=["hecras_hdf", "adh"])
    ap.add_argument("--out", default=None, help="directory for the files and runs (default: a temporary one)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))  # the test scene's helpers (tests/site)
    from breachflow.cycle.config import demo_breach
    from breachflow.cycle.main import run_closure
    from tests.site import test_nested as tn
    from tests.site.meshing import unaligned_mesh

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench-nested-seeds-"))
    out.mkdir(parents=True, exist_ok=True)
    scene = replace(demo_breach(), levee_length_each_side=36.0, flood_side_extent=36.0, protected_side_extent=36.0)
    grid = tn._steady(scene, 1.0)
    mesh = unaligned_mesh(grid, 1.0, angle_deg=23.0, seed=4)
    files = [p for p in tn.export_files(mesh, out, args.fmt) if p.suffix != ".prj"]
    text = tn.NESTED_SCENARIO.format(files=", ".join(f'"{p.name}"' for p in files))
    for key in ("levee_length_each_side", "flood_side_extent", "protected_side_extent"):
        text = re.sub(rf'{key} = "\d+ m"', f'{key} = "36 m"', text)
    if args.rule:
        text = text.replace("[dem]\n", f'[dem]\nrest_rule = "{args.rule}"\n')
    rows = []
    for seed in _seeds(args.seeds):
        scen = out / f"nested_{seed}.toml"
        scen.write_text(text.replace("seed = 1", f"seed = {seed}"))
        c0 = time.process_time()
        res = run_closure(scen, out / f"run_{seed}", plots=False, overwrite=True)
        rows.append((seed, res.closed, res.cycles, res.masses, res.tonnage, res.lost_masses))
        print(f"{args.fmt} rule {args.rule or 'default'} seed {seed}: closed {res.closed}, {res.cycles} cycles, "
              f"{res.masses} masses, {res.tonnage:.1f} t, lost {res.lost_masses}, CPU {time.process_time() - c0:.1f} s; "
              f"Q {[round(r.breach_discharge, 2) for r in res.reports]}", flush=True)
    n = len(rows)
    print(f"closed {sum(r[1] for r in rows)} / {n}; cycles mean {sum(r[2] for r in rows) / n:.2f} "
          f"({min(r[2] for r in rows)}-{max(r[2] for r in rows)}); tonnage mean {sum(r[4] for r in rows) / n:.1f} t "
          f"({min(r[4] for r in rows):.1f}-{max(r[4] for r in rows):.1f}); lost {sum(r[5] for r in rows)} masses; runs in {out}")
    return 0
