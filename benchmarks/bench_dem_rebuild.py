"""CPU cost of one neighbour-list rebuild of the poured pile (issue 16), for this tree or another one.

    .venv/bin/python benchmarks/bench_dem_rebuild.py [--n 1000,10000] [--reps 200]
    PYTHONPATH=<other tree's src> .venv/bin/python benchmarks/bench_dem_rebuild.py   # e.g. main before the
                                                                                    # compiled rebuild

Builds ``bench_dem.poured_pile(n)`` (the scene of ``tasks.py bench dem``) and times ``DemSimulation._rebuild``
(the driver's rebuild: on older trees hash grid + search + numpy sort / searchsorted of the keys; here
``neighbours.relist``, ``neighbours.rebuild`` without sleepers, the function the compiled loop calls) and, where it exists, the pair search alone
(``neighbours.search_awake``), in ms per rebuild (``time.process_time``, mean ± sd of 5 blocks).
"""
from __future__ import annotations

import argparse
import statistics as st
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def blocks(fn, reps, nblocks=5):
    fn()
    out = []
    for _ in range(nblocks):
        t = time.process_time()
        for _ in range(reps):
            fn()
        out.append(1e3 * (time.process_time() - t) / reps)
    return f"{st.mean(out):.3f} ± {st.stdev(out):.3f} ms"


def main(argv=None):
    import bench_dem
    from breachflow.dem import neighbours

    ap = argparse.ArgumentParser()
    ap.add_argument("--n", default="1000,10000")
    ap.add_argument("--reps", type=int, default=200)
    a = ap.parse_args(argv)
    for n in (int(x) for x in a.n.split(",")):
        sim, _ = bench_dem.poured_pile(n)
        s = sim.state
        sim._rebuild()
        reps = max(5, a.reps * 1000 // n)
        line = f"poured pile N={n}: {sim._pa.size} pairs; rebuild {blocks(sim._rebuild, reps)}"
        if hasattr(neighbours, "search_awake"):
            ca, cb = np.empty(2 * sim._pa.size, np.int64), np.empty(2 * sim._pa.size, np.int64)
            args = (sim.idx, s.pos, s.radius, 0.5 * sim.skin, sim.geom, sim.periodic, sim.ncell, ca, cb)
            line += f", of it the search {blocks(lambda: neighbours.search_awake(*args), reps)}"
        print(line)


if __name__ == "__main__":
    main()
