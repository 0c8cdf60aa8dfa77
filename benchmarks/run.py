#!/usr/bin/env python3
"""Benchmark dispatcher: ``python benchmarks/run.py NAME [ARGS...]`` runs ``bench_NAME.py``'s ``main(argv)``;
without NAME it lists the available benchmarks.

The published comparisons are in ``benchmarks/``: ``dem`` (the DEM against LAMMPS), ``swe`` (the
shallow-water solver against analytic solutions and ANUGA), ``closure`` (a closure end to end) and
``ensemble`` (ensembles on dask). ``benchmarks/dev/`` holds the developers' diagnostics and A/B runs
between two source trees; they run the same way (``python3 tasks.py bench dem_kernel``)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEV = HERE / "dev"


def available(folder: Path = HERE) -> list[str]:
    return sorted(p.stem[len("bench_"):] for p in folder.glob("bench_*.py"))


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: run.py NAME [ARGS...]\navailable: " + ", ".join(available())
              + "\ndevelopers' diagnostics (benchmarks/dev): " + ", ".join(available(DEV)))
        return 0
    name, rest = argv[0], argv[1:]
    path = HERE / f"bench_{name}.py"
    if not path.exists():
        path = DEV / f"bench_{name}.py"
    if not path.exists():
        print(f"unknown benchmark {name!r}; available: {', '.join(available() + available(DEV))}", file=sys.stderr)
        return 2
    for folder in (DEV, HERE):  # a diagnostic may import a published benchmark's helpers, or another one's
        if str(folder) not in sys.path:
            sys.path.insert(0, str(folder))
    spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return int(mod.main(rest) or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
