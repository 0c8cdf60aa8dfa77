"""Closure-cycle cost against the number of resting masses already in the scene, and the default run (issue 7).

    python3 tasks.py bench cycle [--sizes 10,100,1000,10000] [--no-default-run]

For each N, N masses (0.4 m, resting and asleep) lie on the flood-side floor of the default scene, as
earlier cycles would have left them: remapped into the hydrodynamic model (the flow re-solved around
them), in the pile top the remap keeps, and in the DEM that the next cycle continues. Then one full
cycle is timed: release of the cycle's batch, DEM settling in the frozen field, remap, warm-started
re-solve, criteria and the atomic cycle write. Printed per N: wall and CPU time of the cycle, the work
counts (DEM steps, particle-steps, masses the remap recomputed) and the CPU-time ratio to the smallest N
measured in the same run (flat = the cost follows the moving masses, not the pile). Then the wall and CPU
time of the README's main command, ``breachflow run`` on the embedded default scenario, in the same run.
CPU time is the steadier figure on a shared machine.
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RADIUS = 0.2
_BASE: dict = {}


def _floor_lattice(dom, n):
    """*n* points on the flat flood-side floor (y <= -12 m), spaced >= one diameter, lattice shaped like the floor."""
    x0, x1, y0, y1 = dom.x[0] + 1.0, dom.x[-1] - 1.0, dom.y[0] + 1.0, -12.0
    nx = max(2, int(np.ceil(np.sqrt(n * (x1 - x0) / (y1 - y0)))))
    ny = max(2, int(np.ceil(n / nx)))
    xs, ys = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)
    if xs[1] - xs[0] < 2 * RADIUS or ys[1] - ys[0] < 2 * RADIUS:
        raise SystemExit(f"{n} masses of {2 * RADIUS} m do not fit on the floor")
    X, Y = np.meshgrid(xs, ys)
    return np.column_stack([X.ravel(), Y.ravel()])[:n]


def one_cycle(n_resting: int, workdir: str) -> dict:
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.driver import ClosureRun
    from breachflow.cycle.main import default_scenario_text
    from breachflow.scenario.config import parse_scenario

    # the impervious pile this benchmark was built for (the default is now a porous pile)
    text = default_scenario_text().replace('remap = "porous"', 'remap = "raised_bed"')
    setup = closure_setup(parse_scenario(text))
    run = ClosureRun(setup, f"{workdir}/n{n_resting}", text, overwrite=True)
    dom = setup.domain
    pts = _floor_lattice(dom, n_resting)
    z = np.array([np.interp(py, dom.y, dom.bed[:, np.argmin(np.abs(dom.x - px))]) for px, py in pts]) + RADIUS
    pos, radius, resting = np.column_stack([pts, z]), np.full(n_resting, RADIUS), np.ones(n_resting, bool)
    # the state earlier cycles leave: the pile remapped and the flow solved around it
    if "open" not in _BASE:
        _BASE["open"] = setup.solver.solve(dom)  # the open breach, the same for every N
    base = _BASE["open"]
    from breachflow.cycle.remap import remap_top

    top = run._pile.update(pos, radius, resting)
    obstacle, bed = remap_top(top, dom.bed, base["water_surface"].values, setup.remap_mode)
    solve_domain = dom if setup.remap_mode == "no_flow" else dom.with_raised_bed(bed > dom.bed, bed)
    snapshot = setup.solver.solve(solve_domain, obstacles=obstacle, initial=base)
    sim = run.dem.make(snapshot)
    run.dem.add(sim, pos, radius, np.full(n_resting, 2650.0))
    sim.sleep(np.arange(sim.state.n))
    rec = {"dem." + key: v for key, v in sim.save_state().items()}
    rec.update(placed_cycle=np.zeros(n_resting, np.int32), resting=resting)
    run.dem.live = (0, sim)  # an uninterrupted run continues the DEM of the previous cycle
    w0, c0 = time.perf_counter(), time.process_time()
    rep, _, _ = run._cycle(1, rec, snapshot)
    return {"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0, "steps": rep.dem_steps,
            "psteps": rep.dem_particle_steps, "remapped": run._pile.last_changed, "hydro": rep.hydro}


def default_run(workdir: str) -> tuple[float, float, str]:
    """Wall and CPU time (s) of ``breachflow run --out DIR`` (the embedded default scenario), and its summary."""
    exe = Path(sys.executable).with_name("breachflow")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([str(exe), "run", "--out", f"{workdir}/default"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode:
        raise SystemExit(f"breachflow run failed:\n{res.stdout}\n{res.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rows = {}
    for ln in res.stdout.splitlines():
        cells = [c.strip() for c in ln.replace("│", "|").split("|") if c.strip()]
        if len(cells) == 2:
            rows[cells[0]] = cells[1]
    what = ", ".join(f"{k} {rows[k]}" for k in ("cycles", "masses placed", "tonnage", "closure achieved") if k in rows)
    return wall, cpu, what


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="10,100,1000,10000")
    ap.add_argument("--no-default-run", action="store_true", help="skip timing `breachflow run`")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    with tempfile.TemporaryDirectory() as tmp:
        one_cycle(sizes[0], tmp)  # compile / warm caches outside the timings
        rows = [(n, one_cycle(n, tmp)) for n in sizes]
        base = rows[0][1]["cpu"]
        print(f"{'resting masses':>15} {'cycle wall (s)':>15} {'cycle CPU (s)':>14} {'DEM steps':>10} "
              f"{'particle-steps':>15} {'remapped':>9} {'CPU ratio':>10}  hydro")
        for n, r in rows:
            print(f"{n:>15d} {r['wall']:>15.2f} {r['cpu']:>14.2f} {r['steps']:>10d} {r['psteps']:>15d} "
                  f"{r['remapped']:>9d} {r['cpu'] / base:>10.2f}  {r['hydro']}", flush=True)
        if not args.no_default_run:
            wall, cpu, closed = default_run(tmp)
            print(f"default run (`breachflow run`, embedded scenario): wall {wall:.1f} s, CPU {cpu:.1f} s; {closed}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
