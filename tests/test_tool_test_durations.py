"""tools/test_durations.py: per-directory test counts, wall and CPU seconds from pytest's junit report (with
its plugin) or from the text of ``--durations=0``, checked on a small suite made here whose times are known
by construction: a test that sleeps (wall, almost no CPU), one that computes (CPU) and one that compiles a
numba function (compile seconds)."""
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SLEEP, BUSY = 0.4, 0.4  # s


@pytest.fixture(scope="module")
def tool():
    spec = importlib.util.spec_from_file_location("test_durations_tool", ROOT / "tools" / "test_durations.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """Two directories: ``a`` with a sleeping, a busy and a skipped test; ``b/c`` with a failing one. Run
    with the plugin into junit XML and with ``--durations=0`` into text."""
    base = tmp_path_factory.mktemp("suite")
    (base / "a").mkdir()
    (base / "b" / "c").mkdir(parents=True)
    (base / "a" / "test_one.py").write_text(f"""
import time, pytest
def test_sleeps():
    time.sleep({SLEEP})
def test_computes():
    t0 = time.process_time()
    x = 0
    while time.process_time() - t0 < {BUSY}:
        x += 1
def test_compiles():
    import numba
    numba.njit(lambda x: x + 1)(1)  # compiled here (no on-disk cache): numba's compile event
@pytest.mark.skip(reason="shown as skipped")
def test_skipped():
    pass
""")
    (base / "b" / "c" / "test_two.py").write_text("def test_fails():\n    assert 1 == 2\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "tools")}
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", "--rootdir", str(base),
           "-c", os.devnull, str(base)]
    subprocess.run([*cmd, "-p", "test_durations", f"--junitxml={base / 'junit.xml'}"], cwd=base, env=env,
                   capture_output=True, text=True)
    plain = subprocess.run([*cmd, f"--junitxml={base / 'plain.xml'}", "--durations=0", "--durations-min=0"],
                           cwd=base, env=env, capture_output=True, text=True)
    (base / "durations.txt").write_text(plain.stdout)
    return base


def test_groups_count_wall_and_cpu_per_directory(tool, suite):
    rows = tool.read(suite / "junit.xml")
    by = {r["name"]: r for r in rows}
    assert set(by) == {"test_sleeps", "test_computes", "test_compiles", "test_skipped", "test_fails"}
    assert by["test_compiles"]["compile"] > 0.0 and by["test_compiles"]["cpu"] >= by["test_compiles"]["compile"] * 0.5
    assert by["test_sleeps"]["compile"] == 0.0 and by["test_computes"]["compile"] == 0.0
    assert by["test_sleeps"]["wall"] >= SLEEP and by["test_sleeps"]["cpu"] < 0.5 * SLEEP
    assert by["test_computes"]["cpu"] >= BUSY
    groups = {g["where"]: g for g in tool.group(rows)}
    assert set(groups) == {"a", "b/c"}
    a, bc = groups["a"], groups["b/c"]
    assert (a["tests"], a["skipped"], a["failed"]) == (4, 1, 0)
    assert a["compile"] == pytest.approx(by["test_compiles"]["compile"]) and a["compile_known"] == 4
    assert (bc["tests"], bc["failed"]) == (1, 1)
    assert a["wall"] == pytest.approx(sum(by[n]["wall"] for n in ("test_sleeps", "test_computes", "test_compiles",
                                                                   "test_skipped")))
    assert a["cpu"] >= BUSY and a["cpu_known"] == 4
    assert tool.group(rows)[0]["where"] == "a"  # the largest CPU first
    per_file = {g["where"] for g in tool.group(rows, "file")}
    assert per_file == {"a/test_one.py", "b/c/test_two.py"}
    per_test = {g["where"] for g in tool.group(rows, "test")}
    assert "a/test_one.py::test_compiles" in per_test and len(per_test) == 5


def test_without_the_plugin_wall_only_and_durations_text(tool, suite):
    plain = tool.group(tool.read(suite / "plain.xml"))
    assert all(g["cpu_known"] == 0 for g in plain) and "CPU s" not in tool.table(plain)
    assert "compile s" not in tool.table(plain)
    text = tool.read(suite / "durations.txt")
    sleeps = [r for r in text if r["name"] == "test_sleeps"]
    assert len(sleeps) == 1 and sleeps[0]["wall"] >= SLEEP and sleeps[0]["file"].endswith("a/test_one.py")


def test_command_line_prints_the_table(suite):
    res = subprocess.run([sys.executable, str(ROOT / "tools" / "test_durations.py"), str(suite / "junit.xml")],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[0].split()[:4] == ["where", "tests", "wall", "s"] and "CPU s" in lines[0]
    assert "compile s" in lines[0]
    assert lines[2].split()[0] == "a" and lines[-1].split()[:2] == ["total", "5"]
    for top in (1, 50):  # the total once, of every group, whether --top cuts the rows or not
        res = subprocess.run([sys.executable, str(ROOT / "tools" / "test_durations.py"), str(suite / "junit.xml"),
                              "--top", str(top)], capture_output=True, text=True)
        rows = res.stdout.splitlines()
        assert [r.split()[0] for r in rows].count("total") == 1 and rows[-1].split()[:2] == ["total", "5"], res.stdout
        assert len(rows) == (5 if top == 1 else len(lines))
    bad = suite / "not_a_report.xml"
    bad.write_text("<testsuites><oops")
    res = subprocess.run([sys.executable, str(ROOT / "tools" / "test_durations.py"), str(bad)],
                         capture_output=True, text=True)
    assert res.returncode == 2 and "cannot read it" in res.stderr
