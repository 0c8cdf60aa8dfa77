"""Issue 27: the run directory is a transaction — one process at a time (an exclusive lock with its holder
named, stale locks of killed processes reported), no run replaced without --overwrite, committed cycles
1, 2, ... without gaps, a process writes only into the run it started, and verify() checks the whole
directory."""
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.io import RunDirectory
from breachflow.io.lock import LOCK, RunLock, RunLockedError, read_holder

from .test_rundir import _field, _traj

HOLD = textwrap.dedent("""
    import sys, time
    from breachflow.io.lock import RunLock
    with RunLock(sys.argv[1]):
        print("locked", flush=True)
        time.sleep(float(sys.argv[2]))
""")


def _holder(path, seconds):
    """A separate process holding *path*'s lock for *seconds*; returns once it holds it."""
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(path), str(seconds)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "locked"
    return p


def test_a_second_process_is_refused_naming_the_directory_and_the_holder(tmp_path):
    run = tmp_path / "run"
    p = _holder(run, 30)
    try:
        with pytest.raises(RunLockedError) as info:
            RunLock(run).acquire()
        msg = str(info.value)
        assert str(run) in msg and f"pid {p.pid} on host {socket.gethostname()}" in msg
        # start() takes the lock before it looks at anything: nothing is written
        with pytest.raises(RunLockedError):
            RunDirectory(run).start("s", seed=1)
        assert sorted(x.name for x in run.iterdir()) == [LOCK]
    finally:
        p.kill()
        p.wait()


def test_a_killed_holder_leaves_a_stale_lock_that_is_reported_and_taken_over(tmp_path):
    run = tmp_path / "run"
    p = _holder(run, 60)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert read_holder(run)["pid"] == p.pid  # the record outlives the process; the flock does not
    rd = RunDirectory(run)
    rd.start("s", seed=1)
    assert rd.stale_lock["pid"] == p.pid and rd.stale_lock["host"] == socket.gethostname()
    assert read_holder(run)["pid"] == os.getpid()
    rd.close()
    assert not (run / LOCK).exists()  # a clean release removes the lock file


def test_the_lock_is_reentrant_in_one_process_and_a_refused_new_directory_is_removed(tmp_path):
    run = tmp_path / "new"
    with RunLock(run) as outer:
        assert outer.created_dir
        with RunLock(run):
            pass
        assert (run / LOCK).exists()  # still held by the outer lock
    assert not run.exists()  # nothing but the lock was written: the directory goes again


def test_two_starts_at_the_same_moment_exactly_one_runs(tmp_path):
    """Many processes start a run in one directory at once: exactly one gets it, every other is refused
    with the directory named, and the manifest and scenario.toml are the winner's."""
    code = textwrap.dedent("""
        import sys, time
        from breachflow.io import RunDirectory
        from breachflow.errors import InputError
        go = float(sys.argv[2])
        while time.time() < go:
            pass
        rd = RunDirectory(sys.argv[1])
        try:
            rd.start(f"scenario {sys.argv[3]}", seed=int(sys.argv[3]))
        except InputError as exc:
            print("refused", exc, flush=True)
            sys.exit(3)
        time.sleep(1.0)
        rd.close()
        print("ran", flush=True)
    """)
    run = tmp_path / "run"
    go = time.time() + 3.0
    procs = [subprocess.Popen([sys.executable, "-c", code, str(run), str(go), str(k)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for k in range(6)]
    outs = [(p.wait(60), p.stdout.read(), p.stderr.read()) for p in procs]
    winners = [k for k, (rc, out, _) in enumerate(outs) if rc == 0]
    assert len(winners) == 1, outs
    for rc, out, err in outs:
        if rc != 0:
            assert rc == 3 and out.startswith("refused") and str(run) in out, (out, err)
            assert "in use by another breachflow process" in out or "holds a run already" in out
    man = RunDirectory(run).manifest()
    assert man["seed"] == winners[0]
    assert (run / "scenario.toml").read_text() == f"scenario {winners[0]}"
    assert RunDirectory(run).verify() == []


def test_cycles_start_at_one_without_gaps(tmp_path):
    rd = RunDirectory(tmp_path / "run")
    rd.start("s", seed=1)
    with pytest.raises(InputError, match="cannot commit cycle 2: no cycle is complete yet; the first cycle is 1"):
        rd.write_cycle(2, _field(2), None, {"k": np.arange(3)}, {})
    rd.write_cycle(1, _field(1), None, {"k": np.arange(3)}, {})
    with pytest.raises(InputError, match="cannot commit cycle 3: it does not follow the last complete cycle 1"):
        rd.write_cycle(3, _field(3), None, {"k": np.arange(3)}, {})
    assert rd.completed_cycles() == [1]


def test_a_process_never_writes_into_a_run_that_replaced_its_own(tmp_path):
    """The old failure: a second run replaced the first's directory, and the first kept committing its
    cycles into the new manifest. The manifest's run_id now stops it."""
    run = tmp_path / "run"
    first = RunDirectory(run)
    first.start("first", seed=1)
    first.write_cycle(1, _field(1), None, {"k": np.arange(3)}, {})
    # what a second process does when it holds the lock (simulated in-process: same lock)
    second = RunDirectory(run)
    second.start("second", seed=2, overwrite=True)
    with pytest.raises(InputError, match="replaced by another process"):
        first.write_cycle(2, _field(2), None, {"k": np.arange(3)}, {})
    with pytest.raises(InputError, match="replaced by another process"):
        first.finish({"cycles": 2})
    assert RunDirectory(run).completed_cycles() == []
    assert RunDirectory(run).verify() == []


def test_verify_checks_the_whole_directory(tmp_path):
    rd = RunDirectory(tmp_path / "run")
    rd.start("s", seed=1)
    for g in (1, 2):
        rd.write_cycle(g, _field(g), _traj(g, 3), {"k": np.arange(3)}, {})
    rd.finish({"cycles": 2})
    assert rd.verify() == []
    path = rd.path
    # a cycle file no manifest entry lists, a temp file, another scenario.toml, a gap in the cycles
    (path / "cycle_0003.nc").write_bytes(b"x")
    (path / ".cycle_0003.nc.abcd1234.nc").write_bytes(b"x")
    (path / "scenario.toml").write_text("other")
    man = json.loads((path / "manifest.json").read_text())
    man["cycles"][0]["cycle"] = 0
    (path / "manifest.json").write_text(json.dumps(man))
    problems = "\n".join(rd.verify())
    assert "cycle_0003.nc: not in the manifest" in problems
    assert ".cycle_0003.nc.abcd1234.nc: temp file left by an interrupted write" in problems
    assert "scenario.toml: not the scenario the manifest records" in problems
    assert "committed cycles [0, 2] are not 1, 2, ... without gaps" in problems
    (path / "restart_0002.npz").unlink()
    assert "restart_0002.npz: missing" in "\n".join(rd.verify())


def test_a_crash_during_overwrite_never_mixes_two_runs(tmp_path, monkeypatch):
    """--overwrite removes the old manifest first: killed half-way, the directory holds no run (a new run
    starts there) rather than the old manifest listing files of which some are gone."""
    rd = RunDirectory(tmp_path / "run")
    rd.start("old", seed=1)
    rd.write_cycle(1, _field(1), None, {"k": np.arange(3)}, {})
    rd.close()
    import breachflow.io.rundir as rundir_mod

    def killed(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(rundir_mod, "atomic_write_text", killed)
    with pytest.raises(KeyboardInterrupt):
        RunDirectory(rd.path).start("new", seed=2, overwrite=True)
    monkeypatch.undo()
    assert not RunDirectory(rd.path).exists() and not list(rd.path.glob("cycle_*"))
    fresh = RunDirectory(rd.path)
    fresh.start("new", seed=2)  # no --overwrite needed: there is no run
    assert fresh.verify() == []


def test_the_command_line_reports_a_stale_lock_before_anything_else(tmp_path):
    from typer.testing import CliRunner

    from breachflow.cli import app

    run = tmp_path / "run"
    p = _holder(run, 60)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    res = CliRunner().invoke(app, ["run", "--out", str(run), "--resume"], env={"COLUMNS": "300"})
    out = " ".join(res.output.split())
    assert f"note: a previous process died holding the lock of {run} (pid {p.pid} on host {socket.gethostname()}" in out
    assert res.exit_code != 0 and "nothing to resume" in str(res.exception)
    assert not (run / LOCK).exists()
