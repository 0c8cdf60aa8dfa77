"""Issue 27: many `breachflow run` started at once into the same and different directories, some killed
(SIGKILL) at random moments: every directory ends as a complete valid run (verify() passes), a resumable
partial one (--resume completes it, then verify() passes), or a directory without a run (a new run starts
there without --overwrite). Every process that was not killed either ran or was refused cleanly (exit 2,
one line naming the directory), never a traceback. Seeded; the default run is small (two cycles of the CI
scene with short solves, a few CPU s per run), the larger one is marked slow."""
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from breachflow.io import RunDirectory
from breachflow.scenario.toml import scenario_with

CI = (Path(__file__).parents[1] / "data" / "ci_closure.toml").read_text()
#: the smallest scene that runs the real cycle: the CI closure with short solves, 2 masses a cycle
TINY = scenario_with(CI, {"hydro.t_max_initial": "20 s", "hydro.t_max": "5 s", "dem.max_time": "1 s",
                          "placement.batch": 2, "criteria.max_cycles": 2})


def _run(scenario, out, *extra):
    return subprocess.Popen([sys.executable, "-m", "breachflow", "run", str(scenario), "--out", str(out), "--no-plots",
                             *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "COLUMNS": "200"})


def _settle(out: Path, scenario: Path) -> str:
    """Classify *out* after the storm and bring it to a finished run; returns the class."""
    rd = RunDirectory(out)
    if not rd.exists():
        assert not list(out.glob("cycle_*")) if out.exists() else True
        p = _run(scenario, out)  # no run there: a new one starts without --overwrite
        o, e = p.communicate(timeout=600)
        assert p.returncode == 0, (o, e)
        kind = "untouched"
    elif rd.manifest().get("finished"):
        kind = "complete"
    else:
        p = _run(scenario, out, "--resume")
        o, e = p.communicate(timeout=600)
        assert p.returncode == 0, (o, e)
        kind = "resumable"
    rd = RunDirectory(out)
    assert rd.verify() == [], (kind, rd.verify())
    man = rd.manifest()
    assert man["finished"] and [c["cycle"] for c in man["cycles"]] == list(range(1, len(man["cycles"]) + 1))
    return kind


def _storm(tmp_path, *, seed: int, procs: int, dirs: int, kills: int):
    rng = random.Random(seed)
    scen = tmp_path / "tiny.toml"
    scen.write_text(TINY)
    outs = [tmp_path / f"run{k}" for k in range(dirs)]
    targets = [outs[rng.randrange(dirs)] for _ in range(procs)]
    started = []
    for out in targets:
        started.append((_run(scen, out), out))
        time.sleep(rng.uniform(0.0, 0.3))
    victims = set(rng.sample(range(procs), kills))
    deadline = {i: time.monotonic() + rng.uniform(1.0, 12.0) for i in victims}
    while any(p.poll() is None for p, _ in started):
        now = time.monotonic()
        for i in list(deadline):
            if now >= deadline[i]:
                started[i][0].send_signal(signal.SIGKILL)
                del deadline[i]
        time.sleep(0.05)
    outcomes = []
    for i, (p, out) in enumerate(started):
        o, e = p.communicate()
        if p.returncode == -signal.SIGKILL:
            outcomes.append("killed")
            continue
        assert "Traceback" not in e, e
        if p.returncode == 0:
            outcomes.append("ran")
        else:
            assert p.returncode == 2, (o, e)
            text = " ".join(e.split())
            assert str(out) in text and ("in use by another breachflow process" in text or "holds a run of" in text), text
            outcomes.append("refused")
    kinds = [_settle(out, scen) for out in outs]
    return outcomes, kinds


def test_simultaneous_runs_and_kills_leave_only_valid_runs(tmp_path):
    outcomes, kinds = _storm(tmp_path, seed=27, procs=4, dirs=2, kills=1)
    assert outcomes.count("ran") >= 1 and outcomes.count("killed") <= 1
    assert set(kinds) <= {"complete", "resumable", "untouched"}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_simultaneous_runs_and_kills_leave_only_valid_runs_large(tmp_path, seed):
    outcomes, kinds = _storm(tmp_path, seed=seed, procs=12, dirs=3, kills=5)
    assert set(kinds) <= {"complete", "resumable", "untouched"}


def test_kill_and_resume_repeatedly_until_finished(tmp_path):
    """A run killed at random moments and resumed each time ends as the complete, valid run."""
    rng = random.Random(5)
    scen = tmp_path / "tiny.toml"
    scen.write_text(TINY)
    out = tmp_path / "run"
    for attempt in range(3):
        p = _run(scen, out, *(["--resume"] if RunDirectory(out).exists() else []))
        time.sleep(rng.uniform(0.5, 6.0))
        p.send_signal(signal.SIGKILL)
        p.communicate()
    assert _settle(out, scen) in {"complete", "resumable", "untouched"}
