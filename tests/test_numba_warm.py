"""A process started on the numba cache that ``tasks.py`` warmed compiles no kernel in a closure cycle, and
``tasks.py`` warms the cache of the sources as they are (each source edit starts a new, empty cache folder),
not only after installing. Before, a run after any source edit spent about 85 CPU s of its first DEM cycle
compiling kernels on first use (docs/verdict-check.md, *What it costs*)."""
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import breachflow
from breachflow import numba_cache

PKG = Path(breachflow.__file__).resolve().parent
ROOT = PKG.parent.parent
pytestmark = pytest.mark.skipif(not (PKG.parent.name == "src" and (ROOT / "tasks.py").is_file()),
                                reason="tasks.py warms the cache of a source checkout")

#: a closure cycle of the warm-up's scenario (one cycle) with every numba compilation recorded: numba fires
#: "numba:compile" only when a signature is neither loaded in the process nor found in the on-disk cache
_CHILD = r"""
import json, re, sys, tempfile
from numba.core import event

compiled = []


class Record(event.Listener):
    def on_start(self, ev):
        pass

    def on_end(self, ev):
        f = ev.data["dispatcher"].py_func
        compiled.append(f"{f.__module__}.{f.__qualname__}{tuple(ev.data['args'])}")


event.register("numba:compile", Record())
from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.scenario.config import parse_scenario
from breachflow.warmup import warm_up_scenario

text = re.sub(r"max_cycles = \d+", "max_cycles = 1", warm_up_scenario())
with tempfile.TemporaryDirectory() as tmp:
    result = ClosureRun(closure_setup(parse_scenario(text)), tmp + "/run", text).run()
import numba.core.config as config
print(json.dumps({"compiled": compiled, "cache": config.CACHE_DIR, "cycles": len(result)}))
"""


def _load_tasks():
    spec = importlib.util.spec_from_file_location("tasks_under_test", ROOT / "tasks.py")
    tasks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tasks)
    return tasks


def test_a_closure_cycle_on_the_warmed_cache_compiles_no_kernel():
    """The cycle runs the solver's cold and warm solves, the DEM with terrain and fluid forces, the porous
    pile and the remap: every one of their kernels must come from the cache (tasks.py warmed it before the
    tests started)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DEBUG_CACHE"}
    r = subprocess.run([sys.executable, "-c", _CHILD], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["cycles"] == 1
    kernels = [c for c in out["compiled"] if c.startswith("breachflow.")]
    assert kernels == [], (f"{len(kernels)} kernels compiled on the cache {out['cache']} "
                           f"(warmed: {numba_cache.is_warmed(out['cache'])}): {kernels[:10]}")


@pytest.fixture
def tasks_env(tmp_path, monkeypatch):
    """tasks.py with its environment taken as installed (the stamp of this pyproject.toml in place) and its
    subprocesses recorded instead of run."""
    tasks = _load_tasks()
    py = tmp_path / "venv" / "python"
    py.parent.mkdir()
    py.write_text("")
    stamp = tmp_path / "venv" / "stamp"
    stamp.write_text(tasks._pyproject_hash())
    monkeypatch.setattr(tasks, "PY", py)
    monkeypatch.setattr(tasks, "STAMP", stamp)
    calls = []
    rc = {"value": 0}

    def fake_run(cmd, *args, **kw):
        calls.append((list(map(str, cmd)), dict(kw.get("env") or {})))
        return subprocess.CompletedProcess(cmd, rc["value"])

    monkeypatch.setattr(tasks.subprocess, "run", fake_run)
    return tasks, calls, rc


def test_tasks_py_warms_the_cache_of_changed_sources_once(tasks_env, tmp_path, monkeypatch):
    tasks, calls, rc = tasks_env
    first = tmp_path / "cache" / "aaaa"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(first))
    tasks.ensure_env()  # installed, but this state of the sources never warmed: the warm-up runs into it
    warm = [c for c in calls if c[0][1:] == ["-m", "breachflow.warmup"]]
    assert len(warm) == 1 and warm[0][1]["NUMBA_CACHE_DIR"] == str(first)
    assert numba_cache.is_warmed(first)
    tasks.ensure_env()  # warmed: not again
    assert len([c for c in calls if c[0][1:] == ["-m", "breachflow.warmup"]]) == 1
    second = tmp_path / "cache" / "bbbb"  # the sources changed: their new folder is warmed
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(second))
    tasks.ensure_env()
    warm = [c for c in calls if c[0][1:] == ["-m", "breachflow.warmup"]]
    assert len(warm) == 2 and warm[1][1]["NUMBA_CACHE_DIR"] == str(second)


def test_a_failed_warm_up_is_not_recorded_as_warmed(tasks_env, tmp_path, monkeypatch, capsys):
    tasks, calls, rc = tasks_env
    folder = tmp_path / "cache" / "cccc"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(folder))
    rc["value"] = 1
    tasks.ensure_env()
    assert not numba_cache.is_warmed(folder)
    assert "warm-up failed" in capsys.readouterr().err
    rc["value"] = 0
    tasks.ensure_env()  # tried again next time
    assert numba_cache.is_warmed(folder)
    assert len([c for c in calls if c[0][1:] == ["-m", "breachflow.warmup"]]) == 2


def test_read_only_positions_are_sampled_without_a_kernel_of_their_own():
    """The check samples the finer grid at read-only positions (views of a dataset): that must not compile a
    second bilinear kernel at run time, and must give what the scipy reference gives."""
    import numpy as np
    from scipy.interpolate import RegularGridInterpolator

    from breachflow.field import FieldSampler, grid_snapshot
    from breachflow.field.sampling.grid_kernels import _grid_bilinear_packed

    rng = np.random.default_rng(3)
    x, y = 10.0 + 2.0 * np.arange(14), -5.0 + 1.5 * np.arange(9)
    bed, depth, u, v = (rng.uniform(0.5, 3.0, (9, 14)) for _ in range(4))
    sampler = FieldSampler(grid_snapshot(x, y, bed, depth, u, v), "bilinear")
    px, py = rng.uniform(x[0], x[-1], 50), rng.uniform(y[0], y[-1], 50)
    sampler.sample(px, py)  # the writable signature, as a run calls it
    before = len(_grid_bilinear_packed.signatures)
    ro_x, ro_y = px.copy(), py.copy()
    ro_x.flags.writeable = ro_y.flags.writeable = False
    s = sampler.sample(ro_x, ro_y)
    assert len(_grid_bilinear_packed.signatures) == before, _grid_bilinear_packed.signatures
    ref = RegularGridInterpolator((y, x), depth)(np.column_stack([py, px]))
    np.testing.assert_allclose(s.depth, ref, rtol=1e-12, atol=1e-12)
