"""Where the test suite spends its time: seconds and test counts per test directory.

Reads what pytest writes with ``--junitxml=FILE`` (or the text of ``--durations=0``) and prints, per test
directory (or per file with ``--by file``, per test with ``--by test``), the number of tests, their wall
seconds and, when the run recorded them, their CPU and numba compile seconds, the largest first::

    PYTHONPATH=tools python3 tasks.py test -p test_durations --junitxml=junit.xml
    python3 tools/test_durations.py junit.xml

Loaded as a pytest plugin (``-p test_durations`` with ``tools`` on ``PYTHONPATH``) this module records
each test's CPU seconds (setup, call and teardown: user + system time of the test process and of the child
processes it waited for, e.g. ``gdalinfo``) as the junit property ``cpu_s`` and, when numba is installed,
the wall seconds the test spent compiling numba kernels as ``compile_s`` (numba's ``numba:compile`` events,
outermost only; a kernel loaded from the on-disk cache fires none); it works with pytest-xdist, each worker
timing its own tests. A test that compiles a kernel the warmed cache does not hold (another argument type,
a test-only wrapper) shows up in the ``compile s`` column. Without the plugin only wall seconds are known:
pytest's junit ``time`` (setup + call + teardown) or the ``--durations`` lines.

Wall seconds of a test are the time its worker was busy with it; summed over a directory they are the
directory's share of the suite's worker time, not of the run's wall clock (the workers run in parallel).
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import time
import xml.etree.ElementTree as ET
from collections import defaultdict
from pathlib import PurePosixPath

CPU_PROPERTY = "cpu_s"
COMPILE_PROPERTY = "compile_s"


# ------------------------------------------------------------------------------------------ pytest plugin
def _cpu() -> float:
    """CPU seconds of this process (``time.process_time``: nanosecond clock) plus those of the child
    processes it waited for (``os.times``: clock ticks, the only record of children; ``os.times`` alone
    would round this process's own time to ticks of 10 ms)."""
    t = os.times()
    return time.process_time() + t.children_user + t.children_system


def _timed(item, phase):
    start = _cpu()
    try:
        yield
    finally:
        item.__dict__.setdefault("_cpu_s", {})[phase] = _cpu() - start


def _compile_clock():
    """A listener of numba's ``numba:compile`` events whose ``total`` is the wall seconds inside outermost events
    (a kernel's compile also compiles the kernels it calls: nested events are not counted twice); None without
    numba."""
    try:
        from numba.core import event
    except ImportError:
        return None

    class CompileClock(event.Listener):
        depth, start, total = 0, 0.0, 0.0

        def on_start(self, ev):
            if self.depth == 0:
                self.start = time.perf_counter()
            self.depth += 1

        def on_end(self, ev):
            self.depth -= 1
            if self.depth == 0:
                self.total += time.perf_counter() - self.start

    clock = CompileClock()
    event.register("numba:compile", clock)
    return clock


try:
    import pytest
except ImportError:  # the reader below needs no pytest
    pytest = None

if pytest is not None:
    _COMPILE = None

    def pytest_configure(config):
        global _COMPILE
        _COMPILE = _compile_clock()

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_setup(item):
        item.__dict__["_compile_s0"] = _COMPILE.total if _COMPILE is not None else 0.0
        yield from _timed(item, "setup")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_call(item):
        yield from _timed(item, "call")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_teardown(item, nextitem):
        yield from _timed(item, "teardown")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(item, call):
        outcome = yield
        report = outcome.get_result()
        if call.when == "teardown":
            report.user_properties.append((CPU_PROPERTY, f"{sum(item.__dict__.get('_cpu_s', {}).values()):.6f}"))
            if _COMPILE is not None:
                spent = _COMPILE.total - item.__dict__.get("_compile_s0", _COMPILE.total)
                report.user_properties.append((COMPILE_PROPERTY, f"{spent:.6f}"))


# ------------------------------------------------------------------------------------------ reading
def _module_path(classname: str, file: str | None) -> str:
    """``tests/output/test_x.py`` from junit's ``file`` attribute, else from ``classname``
    (``tests.output.test_x`` or ``tests.output.test_x.TestClass``: the last dotted part starting with
    ``test_`` is the module)."""
    if file:
        return PurePosixPath(file.replace(os.sep, "/")).as_posix()
    parts = classname.split(".")
    idx = max((i for i, p in enumerate(parts) if p.startswith("test_")), default=len(parts) - 1)
    return "/".join(parts[: idx + 1]) + ".py"


def read_junit(path) -> list[dict]:
    """One record per test case of a junit XML file: ``file``, ``name``, ``wall`` (s), ``cpu`` and
    ``compile`` (s or None), ``outcome`` (passed, failed, error, skipped)."""
    rows = []
    for case in ET.parse(path).getroot().iter("testcase"):
        props = {p.get("name"): p.get("value") for p in case.iter("property")}
        outcome = "passed"
        for tag in ("failure", "error", "skipped"):
            if case.find(tag) is not None:
                outcome = {"failure": "failed"}.get(tag, tag)
        cpu, comp = props.get(CPU_PROPERTY), props.get(COMPILE_PROPERTY)
        rows.append({"file": _module_path(case.get("classname", ""), case.get("file")), "name": case.get("name", ""),
                     "wall": float(case.get("time") or 0.0), "cpu": None if cpu is None else float(cpu),
                     "compile": None if comp is None else float(comp), "outcome": outcome})
    return rows


_DURATION = re.compile(r"^\s*([0-9.]+)s\s+(setup|call|teardown)\s+(\S+?\.py)::(\S.*?)\s*$")


def read_durations(path) -> list[dict]:
    """Records from the text pytest prints with ``--durations=0`` (wall only; setup, call and teardown of a
    test are added up)."""
    by_test: dict[tuple[str, str], float] = defaultdict(float)
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            m = _DURATION.match(line)
            if m:
                by_test[(m.group(3), m.group(4))] += float(m.group(1))
    return [{"file": f, "name": n, "wall": w, "cpu": None, "compile": None, "outcome": "passed"}
            for (f, n), w in by_test.items()]


def read(path) -> list[dict]:
    with open(path, "rb") as fh:
        head = fh.read(512).lstrip()
    return read_junit(path) if head.startswith(b"<") else read_durations(path)


def group(rows: list[dict], by: str = "dir") -> list[dict]:
    """Totals per test directory (``by="dir"``), per file (``by="file"``) or per test (``by="test"``), the
    largest CPU (else wall) first."""
    acc: dict[str, dict] = {}
    for r in rows:
        key = {"file": r["file"], "test": f"{r['file']}::{r['name']}"}.get(
            by, PurePosixPath(r["file"]).parent.as_posix() or ".")
        a = acc.setdefault(key, {"where": key, "tests": 0, "wall": 0.0, "cpu": 0.0, "cpu_known": 0,
                                 "compile": 0.0, "compile_known": 0, "failed": 0, "skipped": 0})
        a["tests"] += 1
        a["wall"] += r["wall"]
        if r["compile"] is not None:
            a["compile"] += r["compile"]
            a["compile_known"] += 1
        if r["cpu"] is not None:
            a["cpu"] += r["cpu"]
            a["cpu_known"] += 1
        a["failed"] += r["outcome"] in ("failed", "error")
        a["skipped"] += r["outcome"] == "skipped"
    out = list(acc.values())
    out.sort(key=lambda a: (a["cpu"] if a["cpu_known"] else 0.0, a["wall"]), reverse=True)
    return out


def table(groups: list[dict]) -> str:
    has_cpu = any(g["cpu_known"] for g in groups)
    tot_wall = sum(g["wall"] for g in groups) or 1.0
    tot_cpu = sum(g["cpu"] for g in groups) or 1.0
    width = max([len("total"), *(len(g["where"]) for g in groups)])
    head = f"{'where':<{width}}  {'tests':>6}  {'wall s':>9}  {'wall %':>6}"
    if has_cpu:
        head += f"  {'CPU s':>9}  {'CPU %':>6}"
    has_compile = any(g["compile_known"] for g in groups)
    if has_compile:
        head += f"  {'compile s':>9}"
    lines = [head + "  notes", "-" * (len(head) + 7)]

    def row(g):
        s = f"{g['where']:<{width}}  {g['tests']:>6}  {g['wall']:>9.1f}  {100 * g['wall'] / tot_wall:>6.1f}"
        if has_cpu:
            s += f"  {g['cpu']:>9.1f}  {100 * g['cpu'] / tot_cpu:>6.1f}"
        if has_compile:
            s += f"  {g['compile']:>9.1f}"
        notes = []
        if g["failed"]:
            notes.append(f"{g['failed']} failed")
        if g["skipped"]:
            notes.append(f"{g['skipped']} skipped")
        if has_cpu and g["cpu_known"] < g["tests"]:
            notes.append(f"CPU of {g['cpu_known']} tests only")
        return s + ("  " + ", ".join(notes) if notes else "")

    lines += [row(g) for g in groups]
    total = {"where": "total", "tests": sum(g["tests"] for g in groups), "wall": sum(g["wall"] for g in groups),
             "cpu": sum(g["cpu"] for g in groups), "cpu_known": sum(g["cpu_known"] for g in groups),
             "compile": sum(g["compile"] for g in groups), "compile_known": sum(g["compile_known"] for g in groups),
             "failed": sum(g["failed"] for g in groups), "skipped": sum(g["skipped"] for g in groups)}
    lines += ["-" * (len(head) + 7), row(total)]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("reports", nargs="+", help="pytest --junitxml files or saved --durations=0 output")
    ap.add_argument("--by", choices=("dir", "file", "test"), default="dir",
                    help="group per test directory, per file or per test")
    ap.add_argument("--top", type=int, default=0, help="show only the N largest groups (the total is of all)")
    args = ap.parse_args(argv)
    rows = []
    for p in args.reports:
        try:
            rows += read(p)
        except (OSError, ET.ParseError) as exc:
            print(f"{p}: cannot read it ({exc})", file=sys.stderr)
            return 2
    if not rows:
        print("no test cases found in " + ", ".join(args.reports), file=sys.stderr)
        return 1
    groups = group(rows, args.by)
    text = table(groups)
    if 0 < args.top < len(groups):
        lines = text.splitlines()
        text = "\n".join(lines[: 2 + args.top] + lines[-2:])
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
