"""Ensembles on dask: parallel efficiency on 1 and 2 workers and the scheduling CPU per member.

Ensemble execution on dask: parallel efficiency 1 vs 2 workers, CPU-busy fraction per worker, and the
per-member scheduling overhead.

    python benchmarks/run.py ensemble [--work-seconds 1.0] [--grid 3] [--noop-grid 4] [--size 192]

Members run the built-in ``synthetic`` runner: explicit 2-D diffusion sweeps (numpy, one thread) of a
random field drawn from the member's seed, calibrated in this process to ``--work-seconds`` of CPU time per member:
real CPU work of equal size in every member. The ensemble is a grid^3 factorial (default 3x3x3 = 27).

Measured in the same run:
* serial baseline: every member executed in this process, one after the other (same member code, result
  files written) -- no dask;
* the whole ``breachflow.ensemble.run`` call (submit, execute, gather, Dataset, NetCDF) on breachflow's
  LocalCluster (``local_cluster``) of 1 and of 2 worker processes (cluster start-up timed separately);
* scheduling overhead: a noop^3 ensemble of zero-work members (``steps = 0``) on both clusters;
* the machine: the same diffusion work in two plain processes at once vs one alone (no dask) -- the
  speed-up the machine gives two CPU-bound processes right now.

CPU time is measured per process (psutil: user + system of each worker process, of this process, which
holds the client, the scheduler and the nannies, and machine-wide /proc/stat counters), so the result
means something on a machine shared with other work:
* CPU-busy fraction of a worker = its process CPU time / wall time of the run. Near 100 %: the worker
  always had a core; lower: it waited for one (other processes, or our own client/scheduler);
* member CPU time per member, 1 vs 2 workers: whether the work itself got slower with two at once
  (cache / memory bandwidth), independent of load;
* worker CPU outside members and client-process CPU, per member: what the dask machinery costs;
* CPU-time efficiency = worker CPU (1 worker) / (2 x max over workers of worker CPU (2 workers)): what
  the wall efficiency T1 / (2 T2) is when every worker has a core to itself (load balance + extra CPU
  per member), short of the idle gaps between members, which the zero-work run measures;
* the other processes' CPU use during each run (machine busy time minus ours) and the VM's steal time.

Wall-clock parallel efficiency E = T1 / (2 T2); target >= 85 %. On a loaded machine E is bounded by the
plain-process reference printed next to it.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
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
    while True:   # CPU time of this thread: the member size does not depend on the machine's load
        t = time.thread_time()
        diffuse(u, probe)
        dt = time.thread_time() - t
        if dt > 0.2:
            break
        probe *= 2
    per_step = dt / probe
    return max(1, int(round(target / per_step))), per_step


def process_cpu() -> float:
    """User + system CPU time (s) of the calling process, all its threads."""
    import psutil

    t = psutil.Process().cpu_times()
    return t.user + t.system


def machine_cpu() -> tuple[float, float]:
    """Machine-wide (busy, steal) CPU seconds since boot, summed over cores."""
    import psutil

    t = psutil.cpu_times()
    idle = t.idle + getattr(t, "iowait", 0.0)
    steal = getattr(t, "steal", 0.0)
    return sum(t) - idle - steal, steal


@dataclass
class Measured:
    """One timed phase: wall time, CPU of our processes, machine-wide busy / steal, member sums."""

    wall: float
    client_cpu: float                      # this process: client (+ scheduler and nannies of a local cluster)
    main_thread_cpu: float = 0.0           # this process's main thread: run() (plan, gather, Dataset, NetCDF)
    worker_cpu: dict = field(default_factory=dict)
    machine_busy: float = 0.0
    steal: float = 0.0
    member_wall: float = 0.0
    member_cpu: float = 0.0
    n: int = 1

    @property
    def ours(self) -> float:
        return self.client_cpu + sum(self.worker_cpu.values())

    @property
    def others_cores(self) -> float:
        """Average number of cores other processes kept busy during the phase."""
        return max(0.0, self.machine_busy - self.ours) / self.wall

    def busy(self) -> str:
        return " / ".join(f"{100 * c / self.wall:.0f} %" for c in self.worker_cpu.values())


class meter:
    """Measure a phase: ``with meter(client) as m: ...`` then ``m.result`` (a :class:`Measured`)."""

    def __init__(self, client=None):
        self.client = client

    def _workers(self) -> dict:
        return self.client.run(process_cpu) if self.client is not None else {}

    def __enter__(self):
        self.w0 = self._workers()
        self.m0 = machine_cpu()
        self.c0 = process_cpu()
        self.th0 = time.thread_time()
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc):
        wall = time.perf_counter() - self.t0
        th = time.thread_time() - self.th0
        c1 = process_cpu()
        m1 = machine_cpu()
        w1 = self._workers()
        self.result = Measured(wall=wall, client_cpu=c1 - self.c0, main_thread_cpu=th,
                               worker_cpu={k: w1[k] - self.w0[k] for k in self.w0},
                               machine_busy=m1[0] - self.m0[0], steal=m1[1] - self.m0[1])
        return False


def serial(spec, out: Path) -> Measured:
    from breachflow.ensemble import execute_member, plan

    _, _, _, tasks = plan(spec, out=out)
    with meter() as m:
        records = [execute_member(task) for task in tasks]
    assert all(r["status"] == "ok" for r in records), [r.get("error_message") for r in records if r["status"] != "ok"]
    res = m.result
    res.member_wall = sum(r["elapsed"] for r in records)
    res.member_cpu = sum(r["cpu_time"] for r in records)
    res.n = len(records)
    return res


def on_cluster(n_workers: int, runs: list[tuple[str, str]], scratch: Path, *, dask_defaults: bool = False
               ) -> tuple[float, dict[str, Measured]]:
    from distributed import Client

    from breachflow.ensemble import parse_spec, run
    from breachflow.ensemble.execute import _quiet_distributed, local_cluster

    t = time.perf_counter()
    cluster = local_cluster(n_workers, dask_defaults=dask_defaults)
    client = Client(cluster)
    client.run(lambda: __import__("breachflow.ensemble.runners"))
    startup = time.perf_counter() - t
    results = {}
    try:
        for label, text in runs:
            out = scratch / f"{label}-{n_workers}-{dask_defaults}"
            with meter(client) as m:
                ds = run(parse_spec(text), client=client, out=out, progress=False, resume=False,
                         console=_null_console())
            assert int(ds.attrs["ensemble_failed"]) == 0
            res = m.result
            res.member_wall = float(ds["member_elapsed_time"].sum())
            res.member_cpu = float(ds["member_cpu_time"].sum())
            res.n = int(ds["member_status"].size)
            results[label] = res
    finally:
        with _quiet_distributed():
            client.close()
            cluster.close()
    return startup, results


def machine_reference(steps: int, size: int, members: int) -> tuple[float, float]:
    """Wall time of *members* members' diffusion work in one plain process alone, and in each of two
    plain processes running at once (no dask): the machine's own two-process speed-up right now."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from breachflow.ensemble.runners import diffuse

    u = np.random.default_rng(0).random((size, size))
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        list(pool.map(diffuse, [u, u], [1, 1]))           # start and import in both processes
        t = time.perf_counter()
        pool.submit(diffuse, u, steps * members).result()
        alone = time.perf_counter() - t
        t = time.perf_counter()
        list(pool.map(diffuse, [u, u], [steps * members] * 2))
        both = time.perf_counter() - t
    return alone, both


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
    ap.add_argument("--reference-members", type=int, default=3,
                    help="members' worth of work per process in the plain two-process machine reference")
    ap.add_argument("--dask-defaults", action="store_true",
                    help="also time 2 workers with dask's defaults for what breachflow's local cluster changes "
                         "(MALLOC_TRIM_THRESHOLD_, profiler, NUMBA_NUM_THREADS, housekeeping intervals)")
    args = ap.parse_args(argv)

    from rich.console import Console
    from rich.table import Table

    from breachflow.ensemble import parse_spec

    console = Console(width=140)
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
        ser = serial(parse_spec(work), scratch / "serial")
        ser_noop = serial(parse_spec(noop), scratch / "serial-noop")
        start1, r1 = on_cluster(1, [("work", work), ("noop", noop)], scratch)
        ref_alone, ref_both = machine_reference(steps, args.size, args.reference_members)
        start2, r2 = on_cluster(2, [("work", work), ("noop", noop)], scratch)
        r2d = (on_cluster(2, [("work", work)], scratch, dask_defaults=True)[1]
               if args.dask_defaults else {})
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    load1 = os.getloadavg()

    w1, w2 = r1["work"], r2["work"]
    eff = w1.wall / (2 * w2.wall)
    cpu_eff = sum(w1.worker_cpu.values()) / (2 * max(w2.worker_cpu.values()))
    table = Table(title=f"ensemble of {n} members x ~{args.work_seconds:g} s CPU (synthetic runner)", title_justify="left")
    for col in ("measurement", "serial", "dask, 1 worker", "dask, 2 workers", "ratio / note"):
        table.add_column(col, justify="left" if col in ("measurement", "ratio / note") else "right")
    table.add_row("wall time (s)", f"{ser.wall:.2f}", f"{w1.wall:.2f}", f"{w2.wall:.2f}",
                  f"speed-up vs serial {ser.wall / w1.wall:.2f} / {ser.wall / w2.wall:.2f}")
    table.add_row("[bold]parallel efficiency T1 / (2 T2)[/]", "", "", "", f"[bold]{100 * eff:.1f} %[/] (target 85 %)")
    table.add_row("efficiency vs serial T_serial / (2 T2)", "", "", "", f"{100 * ser.wall / (2 * w2.wall):.1f} %")
    table.add_row("machine reference: 2 plain processes at once vs 1 alone (s)", "", f"{ref_alone:.2f}",
                  f"{ref_both:.2f}", f"{100 * ref_alone / ref_both:.1f} % (the machine's own 2-process efficiency now)")
    table.add_row("[bold]CPU-busy fraction per worker[/] (process CPU / wall)", "", w1.busy(), w2.busy(),
                  "< 100 %: the worker waited for a core")
    table.add_row("[bold]CPU-time efficiency[/] CPU(1 w) / (2 max CPU(2 w))", "", f"{sum(w1.worker_cpu.values()):.2f}",
                  f"{max(w2.worker_cpu.values()):.2f}", f"[bold]{100 * cpu_eff:.1f} %[/] (E with a core per worker)")
    table.add_row("member CPU time per member (s)", f"{ser.member_cpu / n:.3f}", f"{w1.member_cpu / n:.3f}",
                  f"{w2.member_cpu / n:.3f}", f"2 w / 1 w {w2.member_cpu / w1.member_cpu:.2f} (>1: the work itself slowed)")
    table.add_row("member wall / member CPU", f"{ser.member_wall / ser.member_cpu:.2f}",
                  f"{w1.member_wall / w1.member_cpu:.2f}", f"{w2.member_wall / w2.member_cpu:.2f}", ">1: waiting for a core")
    for label, res, rn in (("work", (w1, w2), n), ("noop", (r1["noop"], r2["noop"]), n_noop)):
        a, b = res
        table.add_row(f"worker CPU outside members per member (ms), {label}", "",
                      f"{1e3 * (sum(a.worker_cpu.values()) - a.member_cpu) / rn:.1f}",
                      f"{1e3 * (sum(b.worker_cpu.values()) - b.member_cpu) / rn:.1f}", "dask worker machinery")
        table.add_row(f"client + scheduler + nanny CPU per member (ms), {label}",
                      f"{1e3 * ((ser if label == 'work' else ser_noop).client_cpu - (ser if label == 'work' else ser_noop).member_cpu) / rn:.1f}",
                      f"{1e3 * a.client_cpu / rn:.1f}", f"{1e3 * b.client_cpu / rn:.1f}",
                      "serial: this process outside members")
        table.add_row(f"  of which other threads: scheduler, nannies, comms (ms), {label}", "",
                      f"{1e3 * (a.client_cpu - a.main_thread_cpu) / rn:.1f}",
                      f"{1e3 * (b.client_cpu - b.main_thread_cpu) / rn:.1f}", "rest: run() in the main thread")
    no1, no2 = r1["noop"], r2["noop"]
    table.add_row(f"zero-work ensemble ({n_noop} members): wall (s)", f"{ser_noop.wall:.2f}", f"{no1.wall:.2f}",
                  f"{no2.wall:.2f}", "")
    table.add_row("[bold]scheduling overhead per member[/] (T_dask - T_serial) / n (ms)", "",
                  f"{1e3 * (no1.wall - ser_noop.wall) / n_noop:.1f}", f"{1e3 * (no2.wall - ser_noop.wall) / n_noop:.1f}",
                  "zero-work members; with 2 workers two run at once")
    table.add_row("overhead per member, work: (T1 - T_serial) / n (ms)", "", f"{1e3 * (w1.wall - ser.wall) / n:.1f}", "", "")
    table.add_row("other processes on the machine (cores busy, average)", f"{ser.others_cores:.2f}",
                  f"{w1.others_cores:.2f}", f"{w2.others_cores:.2f}",
                  f"VM steal {ser.steal:.1f} / {w1.steal:.1f} / {w2.steal:.1f} s")
    if r2d:
        d = r2d["work"]
        table.add_row("2 workers, dask's defaults (execute.WORKER_CONFIG off)", "", "",
                      f"{d.wall:.2f} s", f"busy {d.busy()}; worker CPU outside members "
                      f"{1e3 * (sum(d.worker_cpu.values()) - d.member_cpu) / n:.1f} ms/member; "
                      f"member CPU {d.member_cpu / w2.member_cpu:.2f}x breachflow's cluster")
    table.add_row("cluster start-up (s, not in the above)", "", f"{start1:.2f}", f"{start2:.2f}", "")
    console.print(table)
    console.print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, "
                  f"after {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f}. Wall-clock ratios on a loaded machine are "
                  "noisy; the CPU-busy fractions, CPU-time efficiency and the machine reference say why.")
    return 0
