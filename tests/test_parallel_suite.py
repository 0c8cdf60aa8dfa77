"""The settings that let the suite run in parallel (tests/conftest.py, ``tasks.py test``)."""
import io
import os
import subprocess
import sys
import time


#: one process adding N entries to a function's numba cache index, as a worker compiling N signatures
SAVER = """
import sys, time
from numba.core.caching import IndexDataCacheFile
from breachflow.numba_cache import serialise_cache_saves
path, tag, n, start = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
assert serialise_cache_saves()
cache = IndexDataCacheFile(path, "kernel-1.py311", "stamp")
while time.time() < start:  # both processes start saving at the same moment
    pass
for i in range(n):
    cache.save((tag, i), (tag, i))
"""


def test_two_processes_saving_into_one_numba_cache_keep_every_entry_with_its_own_code(tmp_path):
    """Two processes add 300 entries each to one function's cache at the same time (as two xdist workers
    compiling different signatures of one kernel, or two ensemble workers). With the saves serialised
    (:func:`breachflow.numba_cache.serialise_cache_saves`) every entry is
    kept and each points at its own data. numba's own save, the same two processes on this machine: 568 of
    600 entries kept, 13 of them pointing at the other process's data."""
    from numba.core.caching import IndexDataCacheFile

    n, start = 300, time.time() + 2.0
    procs = [subprocess.Popen([sys.executable, "-c", SAVER, str(tmp_path), tag, str(n), str(start)])
             for tag in ("a", "b")]
    assert [p.wait(120) for p in procs] == [0, 0]
    cache = IndexDataCacheFile(str(tmp_path), "kernel-1.py311", "stamp")
    index = cache._load_index()
    assert sorted(index) == sorted((tag, i) for tag in ("a", "b") for i in range(n))
    assert [k for k in index if cache.load(k) != k] == []


def test_the_cli_console_in_a_worker_is_as_wide_as_in_the_run_that_started_it(request):
    """Piped CLI output wraps at ``$COLUMNS`` or not at all (4096 columns); an xdist worker starts with
    ``COLUMNS=80``, which broke the paths two tests look for (``test_run_safety``, ``test_cli_run``) in a
    worker only. The worker's console has the width the run's own environment gives."""
    from breachflow.cli._common import PIPE_WIDTH, _width

    run_env = getattr(request.config, "workerinput", {}).get("breachflow_env")
    if run_env is None:  # not a worker: this process is the run
        run_env = {"COLUMNS": os.environ.get("COLUMNS")}
    cols = run_env["COLUMNS"]
    assert _width(io.StringIO()) == (int(cols) if cols and cols.isdigit() and int(cols) > 0 else PIPE_WIDTH)


def test_ensemble_workers_serialise_their_numba_cache_saves(monkeypatch, tmp_path):
    """An ensemble's dask workers compile into the one cache at the same time (numba issue #4807): the
    function each worker runs before any member (``execute._warm_up``) and each member itself
    (``execute.execute_member``, here one whose scenario cannot be written: a recorded failure) serialise the
    saves of their process."""
    from types import SimpleNamespace

    from numba.core.caching import IndexDataCacheFile

    from breachflow.ensemble import execute

    def plain_save(self, key, data):  # numba's own, unlocked
        raise AssertionError("not called here")

    def unwritable(*args, **kwargs):
        raise OSError("no scenario here")

    locked = lambda: getattr(IndexDataCacheFile.save, "_breachflow_locked", False)  # noqa: E731
    monkeypatch.setattr(IndexDataCacheFile, "save", plain_save)
    execute._warm_up(())
    assert locked()
    monkeypatch.setattr(IndexDataCacheFile, "save", plain_save)
    scenario = SimpleNamespace(key="m0", number=0, values={}, values_si={}, paths=[], write=unwritable)
    task = SimpleNamespace(run_dir=str(tmp_path / "m0"), scenario=scenario, index=(0,), seed=0, runner_name="x",
                           options={}, fingerprint="", command="test", runner_cls=object)
    record = execute.execute_member(task)
    assert record["status"] == "failed" and locked()
