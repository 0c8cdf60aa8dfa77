"""Ensemble execution on dask: parallel efficiency 1 vs 2 workers and per-member scheduling overhead.

    python benchmarks/run.py ensemble [--work-seconds 1.0] [--grid 3] [--noop-grid 4] [--size 192]

Members run the built-in ``synthetic`` runner: explicit 2-D diffusion sweeps (numpy, one thread) of a
random field drawn from the member's seed, calibrated in this process to ``--work-seconds`` per member:
real CPU work of equal size in every member. The ensemble is a grid^3 factorial (default 3x3x3 = 27).

Measured in the same run:
* serial baseline: every member executed in this process, one after the other (same member code, result
  files written) -- no dask;
* the whole ``breachflow.ensemble.run`` call (submit, execute, gather, Dataset, NetCDF) on a LocalCluster of
  1 and of 2 worker processes (cluster start-up timed separately, not included);
* scheduling overhead: a noop^3 ensemble of zero-work members (``steps = 0``) on both clusters, and the
  difference between the 1-worker run and the serial baseline, per member.

Parallel efficiency E = T(1 worker) / (2 T(2 workers)); target >= 85 %. The load average before and after
is printed: other processes on the machine lower E. E splits into the worker utilisation (sum of member
times / (workers x wall time): what the ensemble machinery loses to scheduling and idling) and the member
slow-down (sum of member times with 2 workers / with 1: CPU contention, memory bandwidth, other load).
Member CPU times (thread CPU clock) separate the two: wall / CPU > 1 means the member waited for a core.
The projection T1' / (2 T2') with T'_k = (sum of member CPU times) / k + (wall time outside members) is
what E would be on otherwise idle cores if members ran at their CPU speed -- a model, printed as such,
for machines shared with other work (the time outside members is kept as measured, inflated by the load).
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


def spec_text(grid: int, steps: int, size: int) -> str:
    lengths = ", ".join(f'"{10 * (i + 1)} m"' for i in range(grid))
    areas = ", ".join(f'"{400 * (i + 1)} ha"' for i in range(grid))
    amps = ", ".join(f'"{i + 1} m"' for i in range(grid))
    return f"""
[ensemble]
name = "bench"
runner = "synthetic"
[ensemble.vary]
"breach.length" = [{lengths}]
"polder.area" = [{areas}]
"synthetic.amplitude" = [{amps}]
[synthetic]
steps = {steps}
size = {size}
"""


def calibrate(size: int, target: float) -> tuple[int, float]:
    from breachflow.ensemble.runners import diffuse

    u = np.random.default_rng(0).random((size, size))
    diffuse(u, 20)
    probe = 50
    while True:
        t = time.perf_counter()
        diffuse(u, probe)
        dt = time.perf_counter() - t
        if dt > 0.2:
            break
        probe *= 2
    per_step = dt / probe
    return max(1, int(round(target / per_step))), per_step


def serial(spec, out: Path) -> float:
    from breachflow.ensemble import execute_member, plan

    _, _, _, tasks = plan(spec, out=out)
    t = time.perf_counter()
    records = [execute_member(task) for task in tasks]
    dt = time.perf_counter() - t
    assert all(r["status"] == "ok" for r in records), [r.get("error_message") for r in records if r["status"] != "ok"]
    return dt, sum(r["elapsed"] for r in records), sum(r["cpu_time"] for r in records)


def on_cluster(n_workers: int, runs: list[tuple[str, str]], scratch: Path, *, malloc_trim: bool = False
               ) -> tuple[float, dict[str, float]]:
    from distributed import Client

    from breachflow.ensemble import parse_spec, run
    from breachflow.ensemble.execute import _quiet_distributed, local_cluster

    t = time.perf_counter()
    cluster = local_cluster(n_workers, malloc_trim=malloc_trim)
    client = Client(cluster)
    client.run(lambda: __import__("breachflow.ensemble.runners"))
    startup = time.perf_counter() - t
    times = {}
    try:
        for label, text in runs:
            out = scratch / f"{label}-{n_workers}-{malloc_trim}"
            t = time.perf_counter()
            ds = run(parse_spec(text), client=client, out=out, progress=False, resume=False,
                     console=_null_console())
            times[label] = time.perf_counter() - t
            times[label + "_member_sum"] = float(ds["member_elapsed_time"].sum())
            times[label + "_cpu_sum"] = float(ds["member_cpu_time"].sum())
            assert int(ds.attrs["ensemble_failed"]) == 0
    finally:
        with _quiet_distributed():
            client.close()
            cluster.close()
    return startup, times


def _null_console():
    from rich.console import Console

    return Console(file=open(os.devnull, "w"))


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench ensemble", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work-seconds", type=float, default=1.0, help="CPU work per member (s)")
    ap.add_argument("--grid", type=int, default=3, help="values per parameter (grid^3 members)")
    ap.add_argument("--noop-grid", type=int, default=4, help="values per parameter of the zero-work ensemble")
    ap.add_argument("--size", type=int, default=192, help="diffusion grid side of the synthetic workload")
    ap.add_argument("--dask-default-env", action="store_true",
                    help="also time 1 worker with dask's default MALLOC_TRIM_THRESHOLD_=65536 (breachflow unsets it)")
    args = ap.parse_args(argv)

    from rich.console import Console
    from rich.table import Table

    from breachflow.ensemble import parse_spec

    console = Console(width=130)
    load0 = os.getloadavg()
    steps, per_step = calibrate(args.size, args.work_seconds)
    n = args.grid ** 3
    n_noop = args.noop_grid ** 3
    work = spec_text(args.grid, steps, args.size)
    noop = spec_text(args.noop_grid, 0, 8)
    console.print(f"cores {os.cpu_count()}, load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}; "
                  f"member workload: {steps} diffusion steps on {args.size}^2 ({steps * per_step:.2f} s calibrated); "
                  f"{n} members, {n_noop} zero-work members")
    scratch = Path(tempfile.mkdtemp(prefix="bench-ensemble-"))
    try:
        t_serial, sum_serial, cpu_serial = serial(parse_spec(work), scratch / "serial")
        t_serial_noop, _, _ = serial(parse_spec(noop), scratch / "serial-noop")
        start1, t1 = on_cluster(1, [("work", work), ("noop", noop)], scratch)
        start2, t2 = on_cluster(2, [("work", work), ("noop", noop)], scratch)
        _, t1_trim = on_cluster(1, [("work", work)], scratch, malloc_trim=True) if args.dask_default_env else (0, {})
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    load1 = os.getloadavg()

    eff = t1["work"] / (2 * t2["work"])
    table = Table(title=f"ensemble of {n} members x ~{args.work_seconds:g} s CPU (synthetic runner)", title_justify="left")
    for col in ("measurement", "time (s)", "per member (s)", "ratio"):
        table.add_column(col, justify="left" if col == "measurement" else "right")
    table.add_row("serial in-process (baseline)", f"{t_serial:.2f}", f"{t_serial / n:.3f}", "1.00")
    table.add_row("dask, 1 worker", f"{t1['work']:.2f}", f"{t1['work'] / n:.3f}", f"{t_serial / t1['work']:.2f} speed-up")
    table.add_row("dask, 2 workers", f"{t2['work']:.2f}", f"{t2['work'] / n:.3f}", f"{t_serial / t2['work']:.2f} speed-up")
    table.add_row("[bold]parallel efficiency T1 / (2 T2)[/]", "", "", f"[bold]{100 * eff:.1f} %[/] (target 85 %)")
    table.add_row("efficiency vs serial T_serial / (2 T2)", "", "", f"{100 * t_serial / (2 * t2['work']):.1f} %")
    table.add_row("overhead per member, (T1 - T_serial) / n", "", f"{(t1['work'] - t_serial) / n:.4f}", "")
    table.add_row("member compute time, sum: serial / 1 w / 2 w",
                  f"{sum_serial:.2f} / {t1['work_member_sum']:.2f} / {t2['work_member_sum']:.2f}",
                  "", f"{t2['work_member_sum'] / sum_serial:.2f}x serial (contention)")
    table.add_row("member CPU time, sum: serial / 1 w / 2 w",
                  f"{cpu_serial:.2f} / {t1['work_cpu_sum']:.2f} / {t2['work_cpu_sum']:.2f}", "",
                  f"wall/CPU {t2['work_member_sum'] / t2['work_cpu_sum']:.2f} with 2 w (>1: waiting for a core)")
    table.add_row("worker utilisation, sum member time / (workers T): 1 w / 2 w",
                  f"{100 * t1['work_member_sum'] / t1['work']:.1f} % / {100 * t2['work_member_sum'] / (2 * t2['work']):.1f} %",
                  "", "idle + scheduling loss")
    # idle-core projection: members at their CPU time, the measured time outside members kept as it was
    proj1 = t1["work_cpu_sum"] + (t1["work"] - t1["work_member_sum"])
    proj2 = t2["work_cpu_sum"] / 2 + (t2["work"] - t2["work_member_sum"] / 2)
    table.add_row("projection for idle cores T1' / (2 T2'), T' = CPU/w + non-member time", f"{proj1:.2f} / {proj2:.2f}",
                  "", f"{100 * proj1 / (2 * proj2):.1f} % (model, not a measurement)")
    table.add_row(f"zero-work serial ({n_noop} members)", f"{t_serial_noop:.2f}", f"{t_serial_noop / n_noop:.4f}", "")
    table.add_row(f"zero-work dask, 1 worker ({n_noop})", f"{t1['noop']:.2f}", f"{t1['noop'] / n_noop:.4f}",
                  f"{t1['noop'] / t_serial_noop:.1f}x serial")
    table.add_row(f"zero-work dask, 2 workers ({n_noop})", f"{t2['noop']:.2f}", f"{t2['noop'] / n_noop:.4f}",
                  f"{t2['noop'] / t_serial_noop:.1f}x serial")
    table.add_row("scheduling overhead per member (1 worker)", "", f"{(t1['noop'] - t_serial_noop) / n_noop:.4f}", "")
    if t1_trim:
        table.add_row("dask, 1 worker, dask's MALLOC_TRIM_THRESHOLD_=65536", f"{t1_trim['work']:.2f}",
                      f"{t1_trim['work'] / n:.3f}", f"{t1_trim['work'] / t1['work']:.2f}x breachflow's cluster")
    table.add_row("cluster start-up 1 / 2 workers (not in the above)", f"{start1:.2f} / {start2:.2f}", "", "")
    console.print(table)
    console.print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, "
                  f"after {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} (2 cores: load > ~0.5 from other processes "
                  "lowers the 2-worker efficiency)")
    return 0
