#!/usr/bin/env python3
"""Benchmark dispatcher: ``python benchmarks/run.py NAME [ARGS...]`` runs ``benchmarks/bench_NAME.py``'s
``main(argv)``; without NAME it lists the available benchmarks."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def available() -> list[str]:
    return sorted(p.stem[len("bench_"):] for p in HERE.glob("bench_*.py"))


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: run.py NAME [ARGS...]\navailable: " + ", ".join(available()))
        return 0
    name, rest = argv[0], argv[1:]
    path = HERE / f"bench_{name}.py"
    if not path.exists():
        print(f"unknown benchmark {name!r}; available: {', '.join(available())}", file=sys.stderr)
        return 2
    spec = importlib.util.spec_from_file_location(f"bench_{name}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return int(mod.main(rest) or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
