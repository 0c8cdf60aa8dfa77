#!/bin/bash
# run the named scenarios one after another with the worktree's sources
cd /work/runs10
for n in "$@"; do
  PYTHONPATH=/work/wt/L4/src NUMBA_CACHE_DIR=/work/runs10/.numba /usr/bin/time -v /work/main/.venv/bin/breachflow run $n.toml --out $n --no-check --no-plots > $n.log 2>&1
done
