"""Closure-cycle cost against the number of resting masses already in the scene (issue 7).

    python3 tasks.py bench cycle [--sizes 10,100,1000,10000]

For each N, N masses (0.4 m, resting and asleep) are laid on the flood-side floor of the default scene,
then one full cycle is timed: release of the cycle's batch, DEM settling in the frozen field, remap,
warm-started re-solve, criteria and the atomic cycle write. Printed as wall time per cycle and the ratio
to the smallest N measured in the same run (flat = the cost follows the moving masses, not the pile).
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np


def one_cycle(n_resting: int, workdir: str) -> tuple[float, int, int]:
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun
    from breachflow.cycle.main import default_scenario_text
    from breachflow.scenario.config import parse_scenario

    text = default_scenario_text()
    setup = closure_setup(parse_scenario(text))
    run = ClosureRun(setup, f"{workdir}/n{n_resting}", text, overwrite=True)
    snapshot = setup.solver.solve(setup.domain)
    sim = run._make_dem(snapshot)
    r = 0.2
    dom = setup.domain
    # a square lattice of resting masses on the flat flood-side floor, away from the breach
    k = int(np.ceil(np.sqrt(n_resting)))
    xs = np.linspace(dom.x[0] + 1.0, dom.x[-1] - 1.0, max(k, 2))
    ys = np.linspace(dom.y[0] + 1.0, -12.0, max(k, 2))
    X, Y = np.meshgrid(xs, ys)
    pts = np.column_stack([X.ravel(), Y.ravel()])[:n_resting]
    if (xs[1] - xs[0]) < 2 * r or (ys[1] - ys[0]) < 2 * r:
        raise SystemExit(f"{n_resting} masses of {2 * r} m do not fit on the floor")
    z = np.interp(pts[:, 1], dom.y, dom.bed[:, dom.x.size // 2]) + r
    run._add(sim, np.column_stack([pts, z]), np.full(n_resting, r), np.full(n_resting, 2650.0))
    sim.sleep(np.arange(sim.state.n))
    rec = {"dem." + key: v for key, v in sim.save_state().items()}
    rec.update(placed_cycle=np.zeros(n_resting, np.int32), resting=np.ones(n_resting, bool))
    t0 = time.perf_counter()
    rep, _, _ = run._cycle(1, rec, snapshot)
    return time.perf_counter() - t0, rep.dem_steps, rep.dem_particle_steps


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="10,100,1000,10000")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    with tempfile.TemporaryDirectory() as tmp:
        one_cycle(sizes[0], tmp)  # compile / warm caches outside the timings
        rows = [(n, *one_cycle(n, tmp)) for n in sizes]
    base = rows[0][1]
    print(f"{'resting masses':>15} {'cycle wall (s)':>15} {'DEM steps':>10} {'particle-steps':>15} {'ratio':>7}")
    for n, wall, steps, psteps in rows:
        print(f"{n:>15d} {wall:>15.2f} {steps:>10d} {psteps:>15d} {wall / base:>7.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
