#!/usr/bin/env python3
"""One-file bootstrap for breachflow: needs only Python >= 3.11 and pip.

    python3 tasks.py run  [ARGS...]   # create .venv if needed, install, run `breachflow run ARGS...`
    python3 tasks.py test [--slow] [--serial] [PYTEST ARGS...]   # same set-up + the CF/GDAL check tools, then the
                                      # test suite on every core (pytest-xdist, up to 4 workers; --serial: one process)
    python3 tasks.py bench [NAME]     # same set-up, then the benchmarks in benchmarks/
    python3 tasks.py shell CMD...     # run CMD inside the environment

The environment is re-installed only when pyproject.toml changes (a stamp file records its hash); the numba
kernels are compiled into the cache (.numba_cache) whenever the sources changed since it was last warmed.
"""
from __future__ import annotations

import ctypes.util
import hashlib
import os
import shutil
import subprocess
import sys
import threading
import time
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = Path(os.environ.get("BREACHFLOW_VENV", ROOT / ".venv"))
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / "python"
STAMP = VENV / ".breachflow-installed"


def _pyproject_hash() -> str:
    return hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()


def _numba_cache_module():
    """src/breachflow/numba_cache.py, loaded by path: this bootstrap runs before the environment exists."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_breachflow_numba_cache", ROOT / "src" / "breachflow" / "numba_cache.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _numba_cache_dir() -> str:
    """numba's on-disk cache (``cache=True``), one folder per state of the sources; folders of earlier source
    states are removed. Defined once, in src/breachflow/numba_cache.py, which the package also uses to find
    the cache when started directly (``.venv/bin/breachflow``)."""
    return str(_numba_cache_module().source_cache_dir(ROOT, prune=True))


def warm_numba_cache() -> None:
    """Compile the numba kernels into the cache folder of the sources as they are now (``NUMBA_CACHE_DIR``
    when set) unless the warm-up already filled it: each edit of a source file starts a new folder, and a run
    on an empty one compiles its kernels on first use (most of a short run's CPU time)."""
    mod = _numba_cache_module()
    folder = os.environ.get("NUMBA_CACHE_DIR") or _numba_cache_dir()
    if mod.is_warmed(folder):
        return
    with mod.warm_up_lock(folder):
        if mod.is_warmed(folder):  # another tasks.py warmed it while this one waited
            return
        print("[tasks] compiling the numba kernels into the cache (once per state of the sources, about 90 CPU s)",
              flush=True)
        env = dict(os.environ, NUMBA_CACHE_DIR=folder)
        t0 = time.perf_counter()
        if subprocess.run([str(PY), "-m", "breachflow.warmup"], env=env).returncode:
            print("[tasks] warning: the numba warm-up failed; kernels compile on first use", file=sys.stderr, flush=True)
            return
        mod.mark_warmed(folder, f"breachflow.warmup, {time.perf_counter() - t0:.0f} s wall")
        print(f"[tasks] warm-up done ({time.perf_counter() - t0:.0f} s)", flush=True)


def ensure_env() -> None:
    """The environment installed for this pyproject.toml, and the numba cache warmed for these sources."""
    install_env()
    # compile the numba kernels now, so that the first run does not spend most of its time compiling
    warm_numba_cache()


def install_env() -> None:
    if not PY.exists():
        print(f"[tasks] creating virtual environment in {VENV}", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    want = _pyproject_hash()
    if STAMP.exists() and STAMP.read_text().strip() == want:
        return
    print("[tasks] installing breachflow and its dependencies (first run takes a minute)", flush=True)
    t0 = time.perf_counter()
    subprocess.run(
        [str(PY), "-m", "pip", "install", "--disable-pip-version-check", "-q", "-e", f"{ROOT}[test]"],
        check=True,
    )
    print(f"[tasks] installed ({time.perf_counter() - t0:.0f} s)", flush=True)
    STAMP.write_text(want)


#: Debian packages the CF/GIS check of the test suite needs (tests/output/test_cf_gis_check.py)
CHECK_DEBS = {"gdal-bin": lambda: shutil.which("gdalinfo"), "libudunits2-0": lambda: ctypes.util.find_library("udunits2")}


def ensure_check_tools() -> None:
    """The tools the CF/GIS test runs: gdalinfo and UDUNITS-2 (apt-get, when missing and this is root with
    apt-get, as in CI) and the cfchecker environment (``tools/cf_check.py --setup``). A failure is reported
    and the test then says what is missing (it skips on a developer machine, fails in CI)."""
    t0 = time.perf_counter()
    missing = [deb for deb, present in CHECK_DEBS.items() if not present()]
    can_apt = hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")
    if missing and not can_apt:
        print(f"[tasks] the CF/GDAL check needs the Debian packages {' '.join(missing)}, which are not installed; "
              f"not installing them ({'apt-get missing' if not shutil.which('apt-get') else 'not root'}): the CF/GDAL "
              f"tests skip, naming what is missing (install them with `sudo apt-get install {' '.join(missing)}`)",
              flush=True)
    if missing and can_apt:
        print(f"[tasks] installing the Debian packages {' '.join(missing)} with apt-get (as root: apt-get update, then "
              f"apt-get install) for the CF/GDAL check", flush=True)
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        ok = subprocess.run(["apt-get", "update", "-qq"], env=env, stdout=subprocess.DEVNULL).returncode == 0
        ok = ok and subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", *missing],
                                   env=env, stdout=subprocess.DEVNULL).returncode == 0
        if not ok:
            print(f"[tasks] warning: could not install {' '.join(missing)}; the CF/GDAL tests will skip, naming them",
                  file=sys.stderr, flush=True)
    res = subprocess.run([sys.executable, str(ROOT / "tools" / "cf_check.py"), "--setup"], stdout=subprocess.DEVNULL)
    if res.returncode:
        print("[tasks] warning: could not set up the cfchecker environment (tools/cf_check.py --setup)",
              file=sys.stderr, flush=True)
    print(f"[tasks] CF/GDAL check tools ready ({time.perf_counter() - t0:.0f} s)", flush=True)


#: most pytest-xdist workers `tasks.py test` starts (each holds ~0.5 GB and its own loaded numba kernels)
MAX_TEST_WORKERS = 4


def _test_workers() -> int:
    """The cores this process may use (CI: 2), at most :data:`MAX_TEST_WORKERS`."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, MAX_TEST_WORKERS))


def pytest_args(rest: list[str]) -> list[str]:
    """pytest's arguments for ``tasks.py test [--slow] [--serial] ARGS``: ``-m "not slow"`` unless ``--slow``;
    the tests spread over the cores by pytest-xdist (``-n N --dist loadfile``: every test of a file in one worker,
    so a module-scoped fixture — a closure run several tests check — is computed once; ``loadgroup`` would not
    keep it so: xdist 3.8 marks a group by rewriting ``item._nodeid``, which pytest 9.2's ``nodeid`` ignores)
    unless ``--serial``, one core, or the caller chose ``-n`` / ``-p no:xdist`` itself (``--dist load``: another
    order)."""
    rest = list(rest)
    markers = ["-m", "not slow"]
    if "--slow" in rest:
        rest.remove("--slow")
        markers = []
    parallel = []
    if "--serial" in rest:
        rest.remove("--serial")
    elif not any(a in {"-n", "--numprocesses", "no:xdist"} or a.startswith(("-n", "--numprocesses="))
                 for a in rest) and _test_workers() > 1:
        parallel = ["-n", str(_test_workers())]
        if not any(a.startswith("--dist") for a in rest):
            parallel += ["--dist", "loadfile"]
    return [*markers, *parallel, *rest]


def main(argv: list[str]) -> int:
    if not argv or argv[0] in {"-h", "--help"}:
        print(__doc__)
        return 0
    task, rest = argv[0], argv[1:]
    tools = None
    if task == "test":
        # the CF/GDAL tools (apt-get, the cfchecker venv: network and disk) install while this environment is
        # installed and the numba warm-up compiles (one core): on CI's 2 cores they overlap
        tools = threading.Thread(target=ensure_check_tools, name="check-tools")
        tools.start()
    ensure_env()
    env = dict(os.environ)
    # numba's on-disk cache lives next to the sources (cache=True), keyed on their state (_numba_cache_dir)
    env.setdefault("NUMBA_CACHE_DIR", _numba_cache_dir())
    if task == "run":
        cmd = [str(BIN / "breachflow"), "run", *rest]
    elif task == "test":
        tools.join()
        cmd = [str(PY), "-m", "pytest", *pytest_args(rest)]
    elif task == "bench":
        cmd = [str(PY), str(ROOT / "benchmarks" / "run.py"), *rest]
    elif task == "shell":
        cmd = rest
        env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    else:
        print(f"unknown task {task!r}; use run, test, bench or shell", file=sys.stderr)
        return 2
    return subprocess.call(cmd, cwd=ROOT, env=env)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
