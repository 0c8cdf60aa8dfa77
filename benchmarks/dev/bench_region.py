"""Work–precision of the warm re-solve: region vs full domain (issue 16).

    python3 tasks.py bench region [--scene typical_breach] [--resolution 4] [--tolerances 2e-3,5e-4,2e-4,5e-5]
                                  [--reference 2e-5] [--margin M] [--far frozen,coarse] [--factor 4]

The report's typical breach (``[site] preset``) at ``--resolution`` is solved cold to steady state, then a
pile is placed — an asymmetric mound against the west breach wall, 40 % of the breach long, 0.24 B wide
across the levee, raised to 60 % of the flood depth (the unfavourable case of the region: the change
is off-centre and large) — and re-solved warm:

* the open breach solved cold at ``--cold`` (1/s), the warm start of every re-solve;
* reference: the full domain at ``--reference`` (1/s), t_max ``--reference-t-max`` (s);
* for each tolerance of ``--tolerances``: the full-domain re-solve (``[hydro] resolve = "full"``) and the
  region re-solve (``resolve = "region"``, :mod:`breachflow.hydro.resolve_region`) with each far-field model of
  ``--far`` (:mod:`breachflow.hydro.far_field`; ``coarse`` on cells ``--factor`` times larger). Each
  region re-solve is the first of a run (a new resolver): the coarse far field pays for two coarse solves.

Printed per solve: breach discharge Q (m³/s) and its difference to the reference (%), the largest speed
within B of the breach and its difference, the largest and mean |Δ speed| against the reference over the
cells within B of the breach wet in both (m/s), the simulated time, this process's CPU time, and the
region (cells, growths). CPU times of one run on a shared machine: the ratios region / full at the same
tolerance are the figure to read.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

SCENARIO = """
[scenario]
name = "work-precision"
[site]
preset = "{scene}"
{site}
[hydro]
resolution = "{res:g} m"
tolerance = "{tol:g} 1/s"
t_max_initial = "600 s"
t_max = "{tmax:g} s"
resolve = "region"
{margin}
"""


def main(argv) -> int:
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import section_discharge
    from breachflow.scenario.config import parse_scenario

    ap = argparse.ArgumentParser(prog="bench region")
    ap.add_argument("--scene", default="typical_breach")
    ap.add_argument("--resolution", type=float, default=4.0)
    ap.add_argument("--tolerances", default="2e-3,5e-4,2e-4,5e-5")
    ap.add_argument("--reference", type=float, default=2e-5)
    ap.add_argument("--reference-t-max", type=float, default=1500.0, help="t_max (s) of the reference re-solve")
    ap.add_argument("--cold", type=float, default=2e-4, help="tolerance (1/s) of the open-breach cold solve")
    ap.add_argument("--margin", default=None, help="resolve_margin, e.g. '120 m' (default 2 B)")
    ap.add_argument("--site", default="", help="extra [site] keys, e.g. 'levee_length_each_side = \"54 m\"'"
                    " (';' separates keys)")
    ap.add_argument("--far", default="frozen", help="far-field models of the region re-solve, comma-separated")
    ap.add_argument("--factor", type=int, default=4, help="coarsening of the 'coarse' far field")
    a = ap.parse_args(argv)
    from breachflow.hydro.resolve_region import RegionResolver

    margin = f'resolve_margin = "{a.margin}"' if a.margin else ""

    def setup_at(tol, tmax=300.0):
        return closure_setup(parse_scenario(SCENARIO.format(scene=a.scene, res=a.resolution, tol=tol, tmax=tmax,
                                                            margin=margin, site="\n".join(a.site.split(";")))))

    base = setup_at(a.reference, a.reference_t_max)
    dom = base.domain
    c0 = time.process_time()
    snap = setup_at(a.cold).solver.solve(dom)  # the open breach: the common warm start of every re-solve
    print(f"{a.scene} at {a.resolution:g} m ({dom.shape[1]} x {dom.shape[0]} cells): cold solve "
          f"{time.process_time() - c0:.1f} CPU s, open-breach Q {section_discharge(snap, base.breach_x, base.levee_y):.0f} m3/s")
    x0, x1 = base.breach_x
    B = x1 - x0
    X, Y = np.meshgrid(dom.x, dom.y)
    low = float(dom.bed[np.abs(Y - base.levee_y) < dom.dy].min())
    mask = (X > x0) & (X < x0 + 0.4 * B) & (np.abs(Y - base.levee_y) < 0.12 * B)
    piled = dom.with_raised_bed(mask, low + 0.6 * (base.flood_level - low))
    near = (np.abs(X - 0.5 * (x0 + x1)) <= B) & (np.abs(Y - base.levee_y) <= B)

    def run(solver):
        c = time.process_time()
        ds = solver.solve(piled, initial=snap)
        cpu = time.process_time() - c
        info = getattr(solver, "last_info", {}) or {"mode": "full", "cells": dom.size if hasattr(dom, "size") else
                                                    int(np.prod(dom.shape)), "grown": 0}
        return dict(ds=ds, cpu=cpu, t=solver.last.t, q=section_discharge(ds, base.breach_x, base.levee_y),
                    sp=np.hypot(ds.u.values, ds.v.values), h=ds.depth.values, info=info,
                    converged=solver.last.history.converged)

    ref = run(base.solver.warm)
    print(f"reference full at {a.reference:.0e}: Q {ref['q']:.1f} m3/s, {ref['cpu']:.1f} CPU s", flush=True)
    rows = [("reference full", a.reference, ref)]
    for tol in [float(t) for t in a.tolerances.split(",") if t]:
        s = setup_at(tol)
        w = s.solver.region
        solvers = [("full", s.solver.warm)] + [
            ("region" if far == "frozen" else f"region+{far}",
             RegionResolver(s.solver.warm, margin=w.margin, edge_level=w.edge_level, far=far,
                            far_factor=a.factor if far == "coarse" else None))
            for far in a.far.split(",") if far]
        for name, solver in solvers:
            r = run(solver)
            rows.append((name, tol, r))
            extra = {k: r["info"][k] for k in ("mode", "why", "grown", "fraction", "edge_change", "far_cpu",
                                               "far_max_level_change") if k in r["info"]}
            print(f"  {name} at {tol:.0e}: Q {r['q']:.1f} m3/s, {r['cpu']:.1f} CPU s, {extra}", flush=True)
    print(f"\npile: raised bed x {x0:.1f}..{x0 + 0.4 * B:.1f} m, |y| < {0.12 * B:.1f} m; speeds within B = {B:.1f} m "
          "of the breach centre; differences against the reference")
    hdr = ("re-solve", "tol 1/s", "Q m3/s", "dQ %", "vmax m/s", "dvmax", "max|dv|", "mean|dv|", "max|dh| m",
           "sim s", "CPU s", "cells", "grown")
    print("  " + " | ".join(f"{h:>9}" for h in hdr))
    for name, tol, r in rows:
        wet = near & (r["h"] > 0.01) & (ref["h"] > 0.01)
        dv = np.abs(r["sp"] - ref["sp"])[wet]
        dh = np.abs(r["h"] - ref["h"])[wet]
        info = r["info"]
        cells = info.get("cells", int(np.prod(dom.shape)))
        print("  " + " | ".join(f"{v:>9}" for v in (
            name, f"{tol:.0e}", f"{r['q']:.1f}", f"{100 * (r['q'] - ref['q']) / ref['q']:+.2f}",
            f"{r['sp'][near].max():.3f}", f"{r['sp'][near].max() - ref['sp'][near].max():+.3f}", f"{dv.max():.3f}",
            f"{dv.mean():.4f}", f"{dh.max():.3f}", f"{r['t']:.0f}{'' if r['converged'] else '*'}", f"{r['cpu']:.1f}",
            cells, info.get("grown", 0) if info.get("mode") == "region" else "full")))
    print("  (* not converged within t_max)")
    for tol in sorted({t for _, t, _ in rows[1:]}):
        f = next(r for n, t, r in rows if n == "full" and t == tol)
        for n, t, w in rows:
            if t == tol and n != "full" and not n.startswith("reference"):
                print(f"  tol {tol:.0e}: CPU {n} / full = {w['cpu'] / max(f['cpu'], 1e-9):.2f}")
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main(sys.argv[1:]))
