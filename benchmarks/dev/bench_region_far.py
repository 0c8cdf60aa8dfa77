"""The region re-solve's far field, frozen vs coarse, against the full-domain re-solve (issue 16).

    python3 tasks.py bench region_far [--factor 2]

The scene of ``tests/cycle/test_region_resolve.py`` (the default breach in a larger domain, 6 m region
margin, 5e-5 1/s) at 1.7 m cells with a pile against the east wall (the breach ends fall inside cells)
and at 1.5 m with a pile against the west wall. Printed per far-field model: breach discharge of the
full and the region re-solve and their difference, the mean water-level rise on the flood side outside
the region (full and region) and the rms of their difference, the region's growths and the far field's
CPU time (:mod:`breachflow.hydro.far_field`).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench region_far")
    ap.add_argument("--factor", type=int, default=2)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "cycle"))
    from test_region_resolve import SCENE, closure_setup, parse_scenario, section_discharge

    from breachflow.hydro.resolve_region import RegionResolver

    for res, wall in [("1.7 m", "east"), ("1.5 m", "west")]:
        setup = closure_setup(parse_scenario(SCENE.replace('"1.5 m"', f'"{res}"')))
        snap = setup.solver.solve(setup.domain)
        dom = setup.domain
        X, Y = np.meshgrid(dom.x, dom.y)
        x0, x1 = setup.breach_x
        B = x1 - x0
        lo, hi = (x0, x0 + 0.4 * B) if wall == "west" else (x1 - 0.3 * B, x1)
        piled = dom.with_raised_bed((X > lo) & (X < hi) & (np.abs(Y - setup.levee_y) < 0.12 * B),
                                    dom.bed.min() + 0.6 * (setup.flood_level - dom.bed.min()))
        full = setup.solver.warm.solve(piled, initial=snap)
        q = lambda ds: section_discharge(ds, setup.breach_x, setup.levee_y)
        eta = lambda ds: ds.bed_elevation.values + ds.depth.values
        for far in ("frozen", "coarse"):
            w = RegionResolver(setup.solver.warm, margin=6.0, far=far, far_factor=a.factor if far == "coarse" else None)
            win = w.solve(piled, initial=snap)
            info = w.last_info
            j0, j1, i0, i1 = info.get("box", (0, 0, 0, 0))
            outside = np.ones(dom.shape, bool)
            outside[j0:j1, i0:i1] = False
            pool = outside & (Y < setup.levee_y) & (snap.depth.values > 0.01)
            rf, rw = (eta(full) - eta(snap))[pool], (eta(win) - eta(snap))[pool]
            print(f"{res} {wall:4s} {far:6s}: Q full {q(full):.3f} region {q(win):.3f} m3/s ({100 * (q(win) / q(full) - 1):+.2f} %); "
                  f"rise outside the region: full {rf.mean():.4f} region {rw.mean():.4f} m, rms difference "
                  f"{np.sqrt(np.mean((rw - rf) ** 2)):.4f} m; mode {info['mode']}, grown {info.get('grown')}, "
                  f"far CPU {info.get('far_cpu', 0.0):.2f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
