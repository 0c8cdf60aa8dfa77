"""The user guide (MyST pages and the API reference from the docstrings) builds with every cross-reference
resolved (Sphinx nitpicky, warnings are errors), as CI runs it; a broken reference does fail that build; and
a new page of docs/ joins the guide's toctree without failing it."""
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
    for page in ("index", "getting-started", "tutorials", "scenario_reference", "theory", "validation",
                 "performance", "api"):
        assert (tmp_path / "html" / f"{page}.html").exists(), page
    theory = (tmp_path / "html" / "theory.html").read_text()
    for section in ("closure-window", "breach-growth", "dem-contact", "porous-flow-through-the-pile"):
        assert f'id="{section}"' in theory, section
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


def test_a_new_page_joins_the_topics_toctree(tmp_path):
    """A page added to docs/ without a toctree entry is listed under Topics (conf.py) instead of failing
    the -W build with "document isn't included in any toctree"."""
    src = tmp_path / "docs"
    src.mkdir()
    shutil.copy(ROOT / "docs" / "conf.py", src / "conf.py")
    index = (ROOT / "docs" / "index.md").read_text()
    # every page of the guide is left out of the copied index (none is copied), so the new page is the only one
    listed = {p.stem for p in (ROOT / "docs").iterdir() if p.suffix in (".md", ".rst")}
    index = "\n".join(line for line in index.splitlines() if line.strip() not in listed)
    index = index.replace("{doc}", "")  # no cross-references to the pages left out
    (src / "index.md").write_text(index)
    (src / "a-new-topic.md").write_text("# A new topic\n\nText.\n")
    res = _build(src, tmp_path / "html")
    assert res.returncode == 0, res.stdout + res.stderr
    assert 'href="a-new-topic.html"' in (tmp_path / "html" / "index.html").read_text()
