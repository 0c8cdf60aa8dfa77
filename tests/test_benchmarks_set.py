"""The published benchmark set: one command per comparison users care about, the rest in benchmarks/dev/.

``python3 tasks.py bench --help`` lists every benchmark with one line; the published folder holds exactly
the comparisons of :data:`run.PUBLISHED` (DEM vs LAMMPS, shallow water vs ANUGA, closure end to end,
ensembles, the atlas), none of them an A/B run between two source trees; every ``tasks.py bench NAME`` the
documents quote names a benchmark that exists. Nothing here runs a benchmark (the scripts are parsed, not
imported)."""
from __future__ import annotations

import ast
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
DEV = BENCH / "dev"


@pytest.fixture(scope="module")
def run():
    spec = importlib.util.spec_from_file_location("benchmarks_run", BENCH / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _names(folder: Path) -> set[str]:
    return {p.stem[len("bench_"):] for p in folder.glob("bench_*.py")}


def test_published_folder_holds_exactly_the_user_comparisons(run):
    assert {"dem", "swe", "closure", "ensemble"} <= set(run.PUBLISHED)
    extra = _names(BENCH) - set(run.PUBLISHED)
    missing = set(run.PUBLISHED) - _names(BENCH)
    assert not extra, f"benchmarks/ holds {sorted(extra)}: move them to benchmarks/dev/ or declare them in PUBLISHED"
    assert not missing, f"PUBLISHED names {sorted(missing)} without a benchmarks/bench_NAME.py"
    assert not _names(BENCH) & _names(DEV), "a name in both benchmarks/ and benchmarks/dev/"


def test_no_published_benchmark_is_an_ab_run_between_source_trees():
    for name in _names(BENCH):
        tree = ast.parse((BENCH / f"bench_{name}.py").read_text(encoding="utf-8"))
        options = {a.value for node in ast.walk(tree) if isinstance(node, ast.Call)
                   and getattr(node.func, "attr", "") == "add_argument"
                   for a in node.args if isinstance(a, ast.Constant) and isinstance(a.value, str)}
        assert "--old" not in options, f"bench_{name}.py compares with another source tree: it belongs in dev/"


def test_help_lists_every_benchmark_on_one_line(run):
    out = subprocess.run([sys.executable, str(BENCH / "run.py"), "--help"], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout
    lines = out.splitlines()
    assert all(len(line) <= run.WIDTH for line in lines)
    for folder in (BENCH, DEV):
        for name in _names(folder):
            rows = [line for line in lines if line.split()[:1] == [name]]
            assert len(rows) == 1, f"{name}: {rows}"
            text = rows[0].split(None, 1)[1] if len(rows[0].split()) > 1 else ""
            assert len(text) > 20, f"{name} has no one-line summary (the first line of its docstring)"
    published = [line.split()[0] for line in lines[lines.index(next(x for x in lines if x.startswith("comparisons"))) + 1:]
                 if line.startswith("  ")][:len(run.PUBLISHED)]
    assert published == list(run.PUBLISHED)
    for name in run.PUBLISHED:  # the comparisons' lines are whole sentences, not cut to the width
        row = next(line for line in lines if line.split()[:1] == [name])
        assert not row.endswith("…") and row.endswith("."), row


def test_every_quoted_bench_command_exists():
    quoted = set()
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted(BENCH.rglob("*.py"))]:
        quoted |= {(doc.name, m) for m in re.findall(r"tasks\.py bench ([a-z_]+)", doc.read_text(encoding="utf-8"))}
    assert quoted, "no quoted bench command found: the pattern is wrong"
    known = _names(BENCH) | _names(DEV)
    unknown = sorted((doc, name) for doc, name in quoted if name not in known)
    assert not unknown, f"documents quote benchmarks that do not exist: {unknown}"


def test_every_quoted_benchmark_path_exists():
    docs = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "src").rglob("*.py"))]
    quoted = {(doc.name, m) for doc in docs
              for m in re.findall(r"benchmarks/(?:dev/)?bench_[a-z_]+\.py", doc.read_text(encoding="utf-8"))}
    assert quoted, "no quoted benchmark path found: the pattern is wrong"
    missing = sorted((doc, path) for doc, path in quoted if not (ROOT / path).exists())
    assert not missing, f"documents quote benchmark files that do not exist: {missing}"
