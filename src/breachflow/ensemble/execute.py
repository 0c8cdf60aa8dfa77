"""Running an ensemble on dask.distributed: local cluster or an existing scheduler, resume, failure isolation.

Output directory layout::

    OUT/spec.toml                     the spec as run (base scenario inlined)
    OUT/ensemble.nc                   the result Dataset (written atomically, schema-checked)
    OUT/members/<key>/scenario.toml   the member's scenario
    OUT/members/<key>/result.json     status, results with units, error, seed, timing (atomic)
    OUT/members/<key>/...             whatever the runner writes

``<key>`` hashes the runner, its options, the base scenario and the member's values, so a rerun reuses
exactly the members whose computation is unchanged (resume) and never a stale one. Run directories
must be on a file system the workers share with the client (always true for a local cluster; on an
HPC cluster use a shared scratch directory).
"""
from __future__ import annotations

import os
import time
import traceback
import uuid
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from ..atomic import atomic_write_text
from ..errors import InputError
from .dataset import build_dataset, write_result
from .io import read_json, write_record
from .runners import MemberScenario, member_runners, normalise_results
from .spec import EnsembleSpec, Member, as_spec

RESULT_FILE = "result.json"
RECORD_FORMAT = "breachflow.ensemble.member/1"


@dataclass
class MemberTask:
    """Everything a worker needs to run one member (pickled to the worker)."""

    runner_cls: type
    runner_name: str
    options: dict
    scenario: MemberScenario
    run_dir: str
    seed: int
    index: tuple
    fingerprint: str
    #: the command that planned the ensemble (recorded in the member's files instead of the worker's)
    command: str | None = None


def execute_member(task: MemberTask) -> dict:
    """Run one member in its directory and write ``result.json`` atomically; never raises for member
    errors (they are recorded with their type and message). The member's files record the ensemble's
    command (``task.command``), not the worker process's command line."""
    from ..numba_cache import serialise_cache_saves
    from ..provenance import using_command

    serialise_cache_saves()  # workers compiling into one cache at once (breachflow.numba_cache)
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / RESULT_FILE).unlink(missing_ok=True)
    record = _record_head(task)
    record["started"] = time.time()
    t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
    try:
        with using_command(task.command):
            sections = getattr(task.runner_cls, "sections", None)
            task.scenario.write(run_dir / "scenario.toml", sections=sections)
            runner = task.runner_cls(**task.options)
            raw = runner.run(task.scenario, run_dir, task.seed)
            results = normalise_results(raw, getattr(task.runner_cls, "outputs", {}) or {})
        record.update(status="ok", results={k: v.to_json() for k, v in results.items()})
    except Exception as exc:  # failure isolation: any member error is data, not a crash
        record.update(status="failed", error_type=type(exc).__name__, error_message=str(exc),
                      traceback=traceback.format_exc(limit=20))
    record["elapsed"] = time.perf_counter() - t0
    record["cpu_time"] = time.thread_time() - c0   # CPU time of this thread: elapsed - cpu = waiting for a core
    # CPU time of the whole worker process meanwhile (the member's thread and the worker's own threads)
    record["process_cpu_time"] = time.process_time() - p0
    record["worker"] = _worker_name()
    write_record(run_dir / RESULT_FILE, record)
    return record


def _record_head(task: MemberTask) -> dict:
    sc = task.scenario
    return {"format": RECORD_FORMAT, "key": sc.key, "number": sc.number, "index": list(task.index),
            "values": sc.values, "values_si": sc.values_si, "parameters": sc.paths, "seed": task.seed,
            "runner": task.runner_name, "options": task.options, "fingerprint": task.fingerprint,
            "run_dir": task.run_dir, "command": task.command}


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"local:{os.getpid()}"


def _warm_up(modules: tuple[str, ...]) -> int:
    import importlib

    from ..numba_cache import serialise_cache_saves

    serialise_cache_saves()
    for m in modules:
        importlib.import_module(m)
    return os.getpid()


# ------------------------------------------------------------------------------------------ run
def default_output_dir(spec: EnsembleSpec) -> Path:
    if spec.output is not None:
        return spec.output
    if spec.path is not None:
        return spec.path.parent / f"{spec.path.stem}.ensemble"
    return Path.cwd() / f"{_slug(spec.name)}.ensemble"


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in text).strip("_") or "ensemble"


def plan(spec, out=None) -> tuple[EnsembleSpec, Path, list[Member], list[MemberTask]]:
    """Members and their tasks (no execution): useful to inspect an ensemble before running it."""
    spec = as_spec(spec)
    out_dir = Path(out) if out is not None else default_output_dir(spec)
    runner_cls = member_runners.get(spec.runner)
    try:  # options are checked once here rather than failing every member
        runner_cls(**spec.options)
    except TypeError as exc:
        raise InputError(f"[ensemble.options]: member runner {spec.runner!r} does not accept them ({exc})") from None
    members = spec.members()
    fp = spec.fingerprint()
    from ..provenance import command

    cmd = command()
    paths = {p.name: p.dotted for p in spec.parameters}
    tasks = []
    for m in members:
        run_dir = out_dir / "members" / m.key
        sc = MemberScenario(key=m.key, number=m.number, table=spec.member_table(m), values=m.values,
                            values_si=m.values_si, paths=paths, path=run_dir / "scenario.toml",
                            replicate=m.replicate)
        tasks.append(MemberTask(runner_cls, spec.runner, dict(spec.options), sc, str(run_dir), m.seed, m.index, fp,
                                cmd))
    return spec, out_dir, members, tasks


def check_scenarios(tasks: list[MemberTask]) -> None:
    """Refuse, before anything runs, a varied parameter the scenario does not have (a misspelt
    ``"breach.lenght"`` in ``[ensemble.vary]``): it would fail every member alike. The first member's scenario
    is parsed (:func:`breachflow.scenario.parse_scenario`; only the sections the runner declares it reads —
    a runner reading the whole table checks it itself with ``check`` — and a runner's own sections that are no
    scenario section are left to it); an unknown key or section that is
    a varied parameter raises :class:`~breachflow.errors.InputError` naming it. Other problems of single
    members stay theirs: the member fails and is recorded, the others run."""
    from ..errors import BreachflowError
    from ..scenario import parse_scenario
    from ..scenario.config import _section_class
    from ..scenario.toml import dump_toml

    if not tasks:
        return
    t = tasks[0]
    wanted = getattr(t.runner_cls, "sections", None)
    if wanted is None:  # a runner that reads the whole table reads it its own way (and checks it: ``check``)
        return

    def known(name):
        try:
            _section_class(name, "", None)
            return True
        except BreachflowError:
            return False

    names = [s for s in t.scenario.table if wanted is None or (s in wanted and known(s))]
    try:
        parse_scenario(dump_toml(t.scenario.table, names))
    except BreachflowError as exc:
        reason = getattr(exc, "reason", None) or str(exc)
        for dotted in t.scenario.paths.values():
            section, key = dotted.split(".")[0], dotted.split(".")[-1]
            if f"[{section}] {key}: unknown key" in reason or f"unknown section [{section}]" in reason:
                raise InputError(f"[ensemble.vary] {dotted!r}: the scenario has no such parameter ({reason}); "
                                 f"nothing was run") from None


def check_members(tasks: list[MemberTask]) -> list[str]:
    """Ask the runner to check every member before anything runs (runners with a ``check(member)``
    method, e.g. ``closure``: physically impossible scenarios). Raises one :class:`~breachflow.errors.InputError` naming
    each refused member and its varied values; returns the distinct warnings with member counts."""
    check_scenarios(tasks)
    if not tasks or not hasattr(tasks[0].runner_cls, "check"):
        return []
    import json

    runner = tasks[0].runner_cls(**tasks[0].options)
    refused, warned = [], {}
    checked: dict[str, tuple[list[str], InputError | None]] = {}  # replicates share their scenario: checked once
    for t in tasks:
        values = ", ".join(f"{k} = {v}" for k, v in t.scenario.values.items())
        same = json.dumps(t.scenario.table, sort_keys=True, default=str)
        if same not in checked:
            try:
                checked[same] = (list(runner.check(t.scenario) or []), None)
            except InputError as exc:
                checked[same] = ([], exc)
        warnings, exc = checked[same]
        for w in warnings:
            warned[w] = warned.get(w, 0) + 1
        if exc is not None:
            refused.append(f"member {t.scenario.number} ({values}): {exc}")
    if refused:
        shown = refused[:10] + ([f"... and {len(refused) - 10} more"] if len(refused) > 10 else [])
        raise InputError(f"{len(refused)} of {len(tasks)} ensemble members cannot run (nothing was run):\n  "
                         + "\n  ".join(shown))
    return [f"{w} ({n} of {len(tasks)} members)" for w, n in warned.items()]


def run(spec, *, out=None, scheduler: str | None = None, workers: int | None = None, client=None,
        resume: bool = True, retry_failed: bool = True, progress: bool = True, console=None,
        write: bool = True) -> xr.Dataset:
    """Run an ensemble and return its result Dataset (also written to ``OUT/ensemble.nc``).

    *spec*: path to a spec TOML, TOML text, a dict or an :class:`~breachflow.ensemble.spec.EnsembleSpec`. *out*: output directory
    (default: the spec's ``output``, else ``<spec>.ensemble/`` next to the spec file).
    Execution: an existing dask *client*; or a *scheduler* address (``"tcp://host:8786"``); or a local
    cluster of *workers* processes (default: the spec's ``workers``, else one per core). With a client or
    scheduler, *workers* restricts the run to that many of its workers.
    *resume*: skip members whose ``result.json`` says ok (and, unless *retry_failed*, failed ones).
    """
    from rich.console import Console

    spec, out_dir, members, tasks = plan(spec, out)
    console = console or Console(stderr=True)
    member_warnings = check_members(tasks)  # before the output directory exists
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(spec.to_toml(), out_dir / "spec.toml")
    for note in unused_parameters(spec, tasks[0].runner_cls if tasks else None):
        console.print(f"note: {note}", highlight=False, markup=False)
    for w in member_warnings:
        console.print(f"warning: {w}", highlight=False, markup=False)

    records: list[dict | None] = [None] * len(tasks)
    if resume:
        for i, t in enumerate(tasks):
            rec = read_json(Path(t.run_dir) / RESULT_FILE)
            if rec and rec.get("format") == RECORD_FORMAT and rec.get("key") == t.scenario.key and (
                    rec.get("status") == "ok" or (rec.get("status") == "failed" and not retry_failed)):
                rec["run_dir"] = t.run_dir
                records[i] = rec
    pending = [i for i, r in enumerate(records) if r is None]
    shape = " x ".join(map(str, spec.shape))
    console.print(f"ensemble [bold]{spec.name}[/]: {len(tasks)} members ({shape}; {', '.join(spec.dims)}), "
                  f"runner [bold]{spec.runner}[/]" + (f", {len(tasks) - len(pending)} done earlier (resume)"
                                                      if len(pending) < len(tasks) else ""), highlight=False)
    if pending:
        _execute(spec, tasks, pending, records, scheduler=scheduler, workers=workers, client=client,
                 progress=progress, console=console)
    ds = build_dataset(spec, records, tasks[0].runner_cls, out_dir=out_dir)
    from .cycles import add_per_cycle

    ds = add_per_cycle(ds, [{**(r or {}), "run_dir": (r or {}).get("run_dir") or t.run_dir} for r, t in zip(records, tasks)],
                       tasks[0].runner_cls)
    n_failed = int(ds.attrs["ensemble_failed"])
    if write:
        path = write_result(ds, out_dir / "ensemble.nc")
        console.print(f"wrote {path}", highlight=False)
    if n_failed:
        console.print(f"[yellow]{n_failed} of {len(tasks)} members failed[/] (see member_error / member_error_type)")
    return ds


def unused_parameters(spec: EnsembleSpec, runner_cls) -> list[str]:
    """Notes on varied parameters the runner does not read (results are constant along them)."""
    sections = getattr(runner_cls, "sections", None)
    if sections is None:
        return []
    return [f"varied parameter {p.dotted} is not read by member runner {spec.runner!r} (it reads "
            f"[{'], ['.join(sorted(sections))}]): its results are constant along {p.name}"
            for p in spec.parameters if p.path[0] not in sections]


def _execute(spec, tasks, pending, records, *, scheduler, workers, client, progress, console) -> None:
    from distributed import Client, as_completed

    own_cluster = own_client = None
    scheduler = scheduler or (spec.scheduler if client is None else None)
    try:
        if client is None and scheduler:
            client = own_client = Client(scheduler)
        elif client is None:
            own_cluster, client = _local_cluster(workers or spec.workers)
            own_client = client
            workers = None
        restrict = _choose_workers(client, workers)
        _report_dashboard(client, console, restrict)
        try:
            client.run(_warm_up, _modules_of(tasks[0].runner_cls), workers=restrict)
        except ImportError as exc:
            raise InputError(f"dask workers cannot import the member runner's modules ({exc}); install breachflow "
                             "(and the runner's package) in the workers' environment") from None
        tag = uuid.uuid4().hex[:8]
        # one graph update for all members: dask then sees a large group of root tasks and queues them on
        # the scheduler, handing them out as workers free up
        submitted = client.map(execute_member, [tasks[i] for i in pending],
                               key=[f"ensemble-member-{tasks[i].scenario.key}-{tag}" for i in pending], pure=False,
                               workers=restrict, allow_other_workers=False, retries=0)
        futures = dict(zip(submitted, pending))
        with _progress(console, len(pending), progress) as advance:
            for fut in as_completed(futures):
                i = futures.pop(fut)
                try:
                    rec = fut.result()
                except Exception as exc:  # the worker died or the task could not run at all
                    rec = _client_side_failure(tasks[i], exc)
                fut.release()
                rec["run_dir"] = tasks[i].run_dir
                records[i] = rec
                advance(rec.get("status") == "ok")
    finally:
        close_own(own_client, own_cluster)


def close_own(client, cluster) -> None:
    """Close the dask client and local cluster a run started itself (None: not its own), without the
    shutdown chatter of ``distributed``."""
    with _quiet_distributed():
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


class _quiet_distributed:
    """Silence distributed's shutdown chatter (closed-comm tracebacks of heartbeats) while closing."""

    def __enter__(self):
        import logging

        self.loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
        self.levels = [lg.level for lg in self.loggers]
        for lg in self.loggers:
            lg.setLevel(logging.CRITICAL)

    def __exit__(self, *exc):
        for lg, level in zip(self.loggers, self.levels):
            lg.setLevel(level)
        return False


def _client_side_failure(task: MemberTask, exc: BaseException) -> dict:
    rec = _record_head(task)
    rec.update(status="failed", error_type=type(exc).__name__, error_message=str(exc) or repr(exc),
               elapsed=float("nan"), worker="")
    try:
        write_record(Path(task.run_dir) / RESULT_FILE, rec)
    except OSError:
        pass
    return rec


def _local_cluster(n_workers: int | None):
    cluster = local_cluster(n_workers)
    from distributed import Client

    return cluster, Client(cluster)


def local_cluster(n_workers: int | None = None, *, dask_defaults: bool = False):
    """A dask LocalCluster for ensembles: *n_workers* processes (default one per core), one thread each.

    Dask settings that differ from dask's defaults (:data:`WORKER_CONFIG`; *dask_defaults* keeps only the
    first; on other clusters set them in the dask configuration):

    * ``distributed.scheduler.worker-saturation: 1.0`` -- a worker holds only the member it runs, none
      queued behind it, so a member that kills its worker (a segfault) takes no innocent member down
      with it, and long members balance across workers;
    * ``distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_: null``: dask's
      default 65536 also pins glibc's mmap threshold, so every numpy temporary above 128 kB is mmap'ed
      and unmapped again, which doubled the time of numpy-heavy members here (``bench_ensemble.py``); a
      value this process inherited (or an earlier dask cluster set in it) is hidden from the workers;
    * ``distributed.nanny.environ.NUMBA_NUM_THREADS: 1`` -- one compute thread per worker process, as
      dask already does for OpenMP / MKL / OpenBLAS: a member's numba ``parallel=True`` kernels (the
      shallow-water solver) cannot start one thread per core in every worker. Set in the worker after
      it is spawned, not in ``pre-spawn-environ``: the nanny applies that to its own process (the client's,
      for a local cluster), and numba refuses a changed thread count once its threads run there;
    * ``distributed.worker.profile.enabled: false``: the statistical profiler samples
      the running member every 10 ms in the worker's event loop; with CPU-bound members it cost 3-4 %
      of a core per worker (``bench_ensemble.py`` prints the workers' CPU time outside members);
    * ``distributed.admin.tick.interval: 1s``, ``distributed.worker.memory.monitor-interval: 1s``,
      ``distributed.admin.system-monitor.interval: 2s`` (dask: 20 ms, 100 ms, 500 ms) -- the event-loop
      watchdog, the nannies' memory polls and the dashboard's system samples cost an idle 2-worker
      cluster 5-6 % of a core in the client's process (scheduler and nannies) and 2 % per worker here;
      with these intervals about 1 % and 0.3 %. Members run for seconds to minutes, so a memory limit
      is enforced within a second instead of 0.1 s.
    """
    import logging

    import dask
    from distributed import LocalCluster

    n = n_workers or os.cpu_count() or 1
    # the scheduler's HTTP server starts with or without the dashboard; on a free port, so that a busy 8787
    # (another cluster, a notebook) gives no "Port 8787 is already in use" warning; without bokeh it
    # serves only health and metrics, on this machine alone
    dashboard = ":0" if _has_bokeh() else "127.0.0.1:0"
    overrides = dict(SATURATION_CONFIG if dask_defaults else WORKER_CONFIG)
    malloc_trim = "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_" not in overrides
    # spawned workers inherit this process's environment, where an earlier dask cluster's nanny may have
    # left MALLOC_TRIM_THRESHOLD_=65536 (nannies apply pre-spawn-environ to their own process)
    hidden = {} if malloc_trim else {k: os.environ.pop(k) for k in ("MALLOC_TRIM_THRESHOLD_",) if k in os.environ}
    try:
        with dask.config.set(overrides):
            return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=dashboard,
                                silence_logs=logging.ERROR)
    finally:
        os.environ.update(hidden)


#: One member per worker at a time (kept with ``local_cluster(dask_defaults=True)``).
SATURATION_CONFIG = {"distributed.scheduler.worker-saturation": 1.0}
#: The dask configuration of :func:`local_cluster` (see there why).
WORKER_CONFIG = {
    **SATURATION_CONFIG,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.nanny.environ.NUMBA_NUM_THREADS": 1,
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
}


def _has_bokeh() -> bool:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return False
    return True


def _choose_workers(client, n: int | None):
    if n is None:
        return None
    if n < 1:
        raise InputError(f"workers: must be >= 1, got {n}")
    addresses = sorted(client.scheduler_info()["workers"])
    if n > len(addresses):
        raise InputError(f"workers: {n} requested, the scheduler has {len(addresses)}")
    return addresses[:n] if n < len(addresses) else None


def _report_dashboard(client, console, restrict) -> None:
    n = len(restrict) if restrict else len(client.scheduler_info()["workers"])
    where = client.scheduler.address if client.scheduler is not None else "?"
    link = client.dashboard_link if _has_bokeh() else None
    console.print(f"dask scheduler {where}, {n} worker(s); dashboard: "
                  + (link if link else "not available (install bokeh>=3.1 for the dask dashboard)"), highlight=False)


def _modules_of(runner_cls) -> tuple[str, ...]:
    mods = ["breachflow.ensemble.runners", "xarray", "numpy"]
    mod = getattr(runner_cls, "__module__", None)
    if mod and mod != "__main__":
        mods.append(mod)
    return tuple(mods)


class _progress:
    """Progress over members (ok / failed counts): :class:`breachflow.progress.Progress`, a bar on a
    terminal and a line at least every 10 s when piped or logged."""

    def __init__(self, console, total: int, enabled: bool):
        self.console, self.total, self.enabled = console, total, enabled
        self.ok = self.failed = 0

    def __enter__(self):
        from ..progress import Progress

        self.bar = Progress("members", total=self.total, unit="members", console=self.console,
                            quiet=not self.enabled).__enter__()
        return self._advance

    def _advance(self, ok: bool) -> None:
        self.ok += bool(ok)
        self.failed += not ok
        self.bar.update(advance=1, note=f"{self.ok} ok, {self.failed} failed")

    def __exit__(self, *exc):
        self.bar.__exit__(*exc)
        return False
