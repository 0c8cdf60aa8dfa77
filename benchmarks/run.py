#!/usr/bin/env python3
"""Benchmark dispatcher: ``python3 tasks.py bench NAME [ARGS...]`` runs ``bench_NAME.py``'s ``main(argv)``;
``python3 tasks.py bench --help`` lists the benchmarks, one line each (the first line of each docstring);
``python3 tasks.py bench NAME --help`` gives a benchmark's options.

``benchmarks/`` holds one command per comparison users care about, the ones docs/performance.md reports
(:data:`PUBLISHED`). ``benchmarks/dev/`` holds the developers' diagnostics: A/B runs between two source
trees or two settings, kernel timings and the studies behind the defaults; they run the same way
(``python3 tasks.py bench dem_kernel``)."""
from __future__ import annotations

import ast
import importlib.util
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEV = HERE / "dev"
#: The published comparisons, in the order the help lists them; any other benchmark belongs in ``dev/``.
PUBLISHED = ("dem", "swe", "closure", "ensemble", "atlas")
WIDTH = 118


def available(folder: Path = HERE) -> list[str]:
    return sorted(p.stem[len("bench_"):] for p in folder.glob("bench_*.py"))


def summary(path: Path) -> str:
    """The first line of the module docstring of *path* (read, not imported: no benchmark is run)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    return doc.strip().splitlines()[0].strip() if doc.strip() else ""


def listing() -> str:
    names = [n for n in PUBLISHED if (HERE / f"bench_{n}.py").exists()]
    names += [n for n in available() if n not in PUBLISHED]
    dev = available(DEV)
    lines = ["usage: python3 tasks.py bench NAME [ARGS...]   (NAME --help: its options)", "",
             "comparisons (benchmarks/, reported in docs/performance.md and docs/atlas.md):"]

    def row(name: str, path: Path, pad: int) -> str:
        text = f"  {name:<{pad}}{summary(path)}"
        return text if len(text) <= WIDTH else text[:WIDTH - 1] + "…"

    pad = max(map(len, names)) + 2  # each section its own column, so a long diagnostic name cuts no comparison
    lines += [row(n, HERE / f"bench_{n}.py", pad) for n in names]
    lines += ["", "developers' diagnostics and A/B runs (benchmarks/dev/):"]
    pad = max(map(len, dev), default=0) + 2
    lines += [row(n, DEV / f"bench_{n}.py", pad) for n in dev]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(listing())
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
