"""Issue 27: the numba kernel cache warmed by tasks.py is found wherever breachflow is started from
(``.venv/bin/breachflow`` run directly, from any directory), not only under tasks.py's environment."""
import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

import breachflow

PKG = Path(breachflow.__file__).resolve().parent
ROOT = PKG.parent.parent
pytestmark = pytest.mark.skipif(not (PKG.parent.name == "src" and (ROOT / "pyproject.toml").is_file()),
                                reason="an installed package keeps numba's default cache beside its sources")


def _expected() -> Path:
    """The folder tasks.py warms, computed here from its definition: the first 16 hex digits of the sha256
    over every src/breachflow/**.py (relative path, NUL, bytes), in sorted order."""
    h = hashlib.sha256()
    for f in sorted((ROOT / "src" / "breachflow").rglob("*.py")):
        h.update(f.relative_to(ROOT).as_posix().encode() + b"\0" + f.read_bytes())
    return ROOT / ".numba_cache" / h.hexdigest()[:16]


def test_the_program_finds_the_warmed_cache_from_any_directory(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    code = "import breachflow, numba.core.config as c; print(c.CACHE_DIR)"
    for cwd in (tmp_path, ROOT / "src", Path("/")):
        r = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == str(_expected()), cwd
    # numba imported first (a plug-in, a notebook): the package still points it at the cache
    r = subprocess.run([sys.executable, "-c", "import numba.core.config as c, breachflow; print(c.CACHE_DIR)"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == str(_expected())


def test_a_set_numba_cache_dir_wins(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "mine")}
    r = subprocess.run([sys.executable, "-c", "import breachflow, numba.core.config as c; print(c.CACHE_DIR)"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == str(tmp_path / "mine")


def test_tasks_py_warms_the_same_folder():
    import importlib.util

    spec = importlib.util.spec_from_file_location("tasks_under_test", ROOT / "tasks.py")
    tasks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tasks)
    assert tasks._numba_cache_dir() == str(_expected())
