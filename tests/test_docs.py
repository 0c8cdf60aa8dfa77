"""The API reference builds from the docstrings with every cross-reference resolved (Sphinx nitpicky,
warnings are errors), as CI runs it; and a broken reference does fail that build."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.docs


def _build(src: Path, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_CACHE_DIR=os.environ.get("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache")))
    return subprocess.run([sys.executable, "-m", "sphinx", "-E", "-W", "--keep-going", "-n", "-q", "-b", "html",
                           str(src), str(out)], capture_output=True, text=True, env=env, timeout=600)


def test_api_reference_builds_without_broken_references(tmp_path):
    res = _build(ROOT / "docs", tmp_path / "html")
    assert res.returncode == 0, res.stdout + res.stderr
    api = (tmp_path / "html" / "api.html").read_text()
    for name in ("breachflow.cycle.driver.ClosureRun", "breachflow.field.crs.resolve_crs", "breachflow.units.to_si"):
        assert f'id="{name}"' in api, name


def test_a_broken_reference_fails_the_build(tmp_path):
    src = tmp_path / "docs"
    src.mkdir()
    shutil.copy(ROOT / "docs" / "conf.py", src / "conf.py")
    (src / "index.rst").write_text("Broken\n======\n\nSee :func:`breachflow.units.no_such_function`.\n")
    res = _build(src, tmp_path / "html")
    assert res.returncode != 0 and "no_such_function" in res.stdout + res.stderr
