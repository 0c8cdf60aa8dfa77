"""Breach atlas of a district-scale levee on dask: wall and CPU time, scheduling efficiency.

Breach-atlas screening at district scale: a levee of ``--length`` metres (default 20 km) at ``--spacing``
(default 200 m: 100 locations) through the screening tier on a local dask cluster; with ``--detailed``, the
scheduling efficiency of the detailed tier (closure simulations) on 1 and 2 workers.

    python3 tasks.py bench atlas [--length 20000] [--spacing "200 m"] [--workers 2] [--flow swe] [--reps 1]
    python3 tasks.py bench atlas --detailed [--length 3000] [--worst 2] [--replicates 4] [--scenario closure.toml]

Prints the wall time of the whole atlas (terrain made beforehand, not timed), the CPU time of the locations
(the workers' ``solve_cpu_s``), the scheduling efficiency ``sum(location CPU) / (workers x wall)`` and the
spread of the open-breach discharge as its error figure: the same locations at half the cell size
(``--check-resolution``, on a sample of ``--check`` locations) against the atlas resolution.

``--detailed``: the district of ``--length`` metres (default 3 km) is screened first (not timed); then its
detailed tier -- ``--worst`` locations x ``--replicates`` closure simulations with the closure template
``--scenario`` (default: the example district's ``examples/district/closure.toml``) -- runs on a local
cluster of 1 worker and of 2 workers (``--max-cycles``, default 4, and ``--cell``, default 8 m, replace
the template's cycle limit and cell size so that the command takes minutes), each started and warmed up (``breachflow.warmup`` in every worker, so
that no member loads the numba kernels) before the clock starts. Printed for each:

* the wall time of the tier (``breachflow.atlas.detailed.run_detailed``: member checks, submission, the
  members, the ensemble's Dataset and NetCDF);
* the CPU time of the members, each measured inside its task with ``time.process_time`` (the worker process)
  and ``time.thread_time`` (the member's thread alone);
* scheduling efficiency = sum of member CPU / (workers x wall of the tier);
* against the 1-worker run of the same command: speed-up wall(1) / wall(2) and its efficiency speed-up / 2;
* where the wall time goes: before the first member starts (the members' checks, submission), while
  members run, after the last one ends (results, Dataset, NetCDF); the occupancy sum(member wall) /
  (workers x wall) -- the scheduling efficiency with a member's waits for a core counted as its own time,
  which a loaded machine does not lower -- and the fraction of a core the members got;
* the bound the members themselves set: the longest-first schedule of the measured member CPU times on 2
  workers (no scheduling overhead at all), and the efficiency it would give;
* the load average before and after each run: on a machine shared with other work, a worker waiting for a
  core lowers both efficiencies, so compare figures measured at a load below the core count;
* whether the detailed figures of the two runs are identical (they must be).
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

def main(argv):
    if "--detailed" in argv:
        return detailed_main([a for a in argv if a != "--detailed"])
    ap = argparse.ArgumentParser(prog="bench atlas")
    ap.add_argument("--length", type=float, default=20000.0)
    ap.add_argument("--spacing", default="200 m")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--flow", default="swe")
    ap.add_argument("--resolution", default="8 m")
    ap.add_argument("--check", type=int, default=5, help="locations re-screened at half the cell size")
    ap.add_argument("--reps", type=int, default=1)
    a = ap.parse_args(argv)

    from breachflow.atlas import run_atlas
    from breachflow.atlas.config import parse_district

    spec = importlib.util.spec_from_file_location("make_district", ROOT / "examples" / "district" / "make_district.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_district"] = mod
    spec.loader.exec_module(mod)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        mod.write(tmp, length=a.length)
        path = tmp / "district.toml"
        path.write_text(mod.district_toml(tmp / "terrain.tif", tmp / "levee.geojson", spacing=a.spacing, flow=a.flow,
                                          resolution=a.resolution, name="benchmark district"))
        walls, effs = [], []
        for rep in range(a.reps):
            t0 = time.perf_counter()
            ds = run_atlas(path, tmp / f"out{rep}", workers=a.workers, progress=False)
            wall = time.perf_counter() - t0
            cpu = float(ds.solve_cpu_s.sum())
            walls.append(wall)
            effs.append(cpu / (a.workers * wall))
            print(f"rep {rep}: {ds.sizes['location']} locations along {a.length / 1000:g} km, wall {wall:.1f} s, "
                  f"location CPU {cpu:.1f} s, efficiency {effs[-1]:.2f}", flush=True)
        sd = lambda v: statistics.stdev(v) if len(v) > 1 else 0.0  # noqa: E731
        print(f"wall {statistics.mean(walls):.1f} ± {sd(walls):.1f} s; scheduling efficiency "
              f"{statistics.mean(effs):.2f} ± {sd(effs):.2f} on {a.workers} workers")
        if a.check and a.flow == "swe":
            from breachflow.atlas.execute import plan
            from breachflow.atlas.locations import load_inputs as _inputs
            from breachflow.atlas.screening import screen

            import dataclasses

            district, locs = plan(path)
            fine = dataclasses.replace(district, resolution=district.resolution / 2)
            terrain, levee = _inputs(str(district.terrain), str(district.levee), None, None)
            step = max(1, len(locs) // a.check)
            rel = []
            for loc in locs[::step][:a.check]:
                q0 = float(ds.open_discharge_m3s.values[loc.index])
                q1 = screen(loc, fine, terrain=terrain, levee=levee)["open_discharge_m3s"]
                rel.append((q0 - q1) / q1)
            print(f"open-breach discharge at {district.resolution:g} m against {fine.resolution:g} m cells "
                  f"({len(rel)} locations): {100 * statistics.mean(rel):+.1f} % mean, "
                  f"{100 * min(rel):+.1f} to {100 * max(rel):+.1f} %")
    return 0


# ------------------------------------------------------------------------------------------ detailed tier
def _warm_worker() -> float:
    """Load (or compile) every numba kernel of a closure run in this worker; its CPU time (s)."""
    from breachflow.warmup import warm_up

    return warm_up()


def _cluster(n: int):
    from distributed import Client

    from breachflow.ensemble.execute import local_cluster

    cluster = local_cluster(n)
    client = Client(cluster)
    workers = sorted(client.scheduler_info()["workers"])
    client.gather([client.submit(_warm_worker, workers=[w], allow_other_workers=False, pure=False, key=f"warm-{w}")
                   for w in workers])
    return cluster, client


def _load() -> str:
    import os

    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def lpt_makespan(times: list[float], workers: int) -> float:
    """Makespan of the longest-processing-time-first schedule of *times* on *workers* identical workers."""
    loads = [0.0] * workers
    for t in sorted(times, reverse=True):
        k = loads.index(min(loads))
        loads[k] += t
    return max(loads)


def detailed_main(argv):
    import json
    import shutil

    ap = argparse.ArgumentParser(prog="bench atlas --detailed")
    ap.add_argument("--length", type=float, default=3000.0)
    ap.add_argument("--spacing", default="200 m")
    ap.add_argument("--flow", default="swe")
    ap.add_argument("--resolution", default="8 m")
    ap.add_argument("--worst", type=int, default=2)
    ap.add_argument("--replicates", type=int, default=4)
    ap.add_argument("--scenario", default=str(ROOT / "examples" / "district" / "closure.toml"),
                    help="closure template of the detailed tier")
    ap.add_argument("--max-cycles", type=int, default=4,
                    help="the template's [criteria] max_cycles replaced by this (0: as the template says)")
    ap.add_argument("--cell", default="8 m",
                    help="the template's [hydro] resolution replaced by this (\"\": as the template says)")
    ap.add_argument("--workers", default="1,2", help="cluster sizes to run, in this order")
    a = ap.parse_args(argv)

    from distributed import Client  # noqa: F401  (fail early without distributed)

    from breachflow.atlas import run_atlas
    from breachflow.atlas.detailed import run_detailed
    from breachflow.atlas.execute import plan
    from breachflow.ensemble.execute import _quiet_distributed

    spec = importlib.util.spec_from_file_location("make_district", ROOT / "examples" / "district" / "make_district.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_district"] = mod
    spec.loader.exec_module(mod)
    sizes = [int(n) for n in a.workers.split(",")]
    tmp = Path(tempfile.mkdtemp(prefix="bench-atlas-detailed-"))
    runs = {}
    try:
        mod.write(tmp, length=a.length)
        template = Path(a.scenario).resolve()
        edits = ([(r"(?m)^max_cycles\s*=\s*\d+", f"max_cycles = {a.max_cycles}")] if a.max_cycles else []) + (
            [(r'(?m)^resolution\s*=\s*"[^"]*"', f'resolution = "{a.cell}"')] if a.cell else [])
        if edits:
            import re

            text = template.read_text()
            for pattern, new in edits:
                text, k = re.subn(pattern, new, text)
                if k != 1:
                    raise SystemExit(f"{template}: {pattern!r} matched {k} times (one expected)")
            template = tmp / "closure.toml"
            template.write_text(text)
        path = tmp / "district.toml"
        path.write_text(mod.district_toml(tmp / "terrain.tif", tmp / "levee.geojson", spacing=a.spacing, flow=a.flow,
                                          resolution=a.resolution, name="benchmark district")
                        + f'\n[detailed]\nworst = {a.worst}\nreplicates = {a.replicates}\n'
                          f'scenario = "{template}"\n')
        from breachflow.warmup import warm_up

        print(f"load average {_load()}; numba kernels into the cache (this process, not timed): "
              f"{warm_up():.1f} CPU s", flush=True)
        t0 = time.perf_counter()
        ds = run_atlas(path, tmp / "screening", workers=2, progress=False, detailed=False, write=False)
        district, locations = plan(path)
        print(f"screening: {ds.sizes['location']} locations along {a.length / 1000:g} km in "
              f"{time.perf_counter() - t0:.1f} s wall (not timed below); detailed tier: {a.worst} locations x "
              f"{a.replicates} replicates, template {a.scenario}"
              + (f" with max_cycles = {a.max_cycles}" if a.max_cycles else "")
              + (f", [hydro] resolution = {a.cell}" if a.cell else ""), flush=True)
        for n in sizes:
            cluster, client = _cluster(n)
            try:
                load0 = _load()
                t0, e0 = time.perf_counter(), time.time()
                out = run_detailed(district, ds, locations, tmp / f"workers{n}", client=client, progress=False)
                wall, e1 = time.perf_counter() - t0, time.time()
                load1 = _load()
            finally:
                with _quiet_distributed():
                    client.close()
                    cluster.close()
            recs = [json.loads(p.read_text()) for p in sorted((tmp / f"workers{n}" / "detailed" / "members")
                                                               .glob("*/result.json"))]
            pcpu = [float(r["process_cpu_time"]) for r in recs]
            tcpu = [float(r["cpu_time"]) for r in recs]
            elapsed = [float(r["elapsed"]) for r in recs]
            first = min(float(r["started"]) for r in recs)
            last = max(float(r["started"]) + float(r["elapsed"]) for r in recs)
            runs[n] = dict(ds=out, wall=wall, pcpu=pcpu, tcpu=tcpu, elapsed=elapsed, load0=load0, load1=load1,
                           failed=sum(r["status"] != "ok" for r in recs))
            print(f"{n} worker(s): {len(recs)} members ({runs[n]['failed']} failed), wall of the tier {wall:.1f} s, "
                  f"member CPU {sum(pcpu):.1f} s (process_time; thread_time {sum(tcpu):.1f} s), member wall "
                  f"{sum(elapsed):.1f} s, members {min(pcpu):.1f}-{max(pcpu):.1f} s CPU; scheduling efficiency "
                  f"CPU / ({n} x wall) = {sum(pcpu) / (n * wall):.3f} (thread_time: {sum(tcpu) / (n * wall):.3f}); "
                  f"load average before {load0}, after {load1}", flush=True)
            print(f"    where the wall goes: {first - e0:.1f} s before the first member starts (member checks, "
                  f"submission), {last - first:.1f} s from the first member's start to the last one's end, "
                  f"{e1 - last:.1f} s after it (results, Dataset, NetCDF); occupancy sum(member wall) / "
                  f"({n} x wall) = {sum(elapsed) / (n * wall):.3f}; the members got {sum(pcpu) / sum(elapsed):.2f} "
                  f"of a core each on average (< 1: they waited for one)", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if 2 in runs:
        r2 = runs[2]
        bound = lpt_makespan(r2["pcpu"], 2)
        print(f"2 workers: longest-first schedule of the measured member CPU times: {bound:.1f} s, i.e. an "
              f"efficiency of at most {sum(r2['pcpu']) / (2 * bound):.3f} with no scheduling overhead at all")
    if 1 in runs and 2 in runs:
        s12 = runs[1]["wall"] / runs[2]["wall"]
        print(f"speed-up 1 -> 2 workers: {runs[1]['wall']:.1f} s / {runs[2]['wall']:.1f} s = {s12:.3f}; "
              f"efficiency speed-up / 2 = {s12 / 2:.3f}; member CPU 2 workers / 1 worker "
              f"{sum(runs[2]['pcpu']) / sum(runs[1]['pcpu']):.3f} (> 1: the members themselves ran slower)")
        names = [v for v in runs[1]["ds"].data_vars if v.startswith(("p_closure", "tonnage_detailed",
                                                                        "duration_detailed"))]
        same = all(runs[1]["ds"][v].equals(runs[2]["ds"][v]) for v in names)
        print(f"detailed figures identical on 1 and 2 workers ({', '.join(names)}): {same}")
    return 0
