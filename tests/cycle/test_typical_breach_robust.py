"""The typical breach's verdict is grid- and seed-robust at the shipped settings (issue "verdicts that hold").

``examples/typical_breach.toml`` as shipped (4 m cells, 10-15 t rock by split barges in time, porous remap, sealed)
runs at 4 m, at uniform
2 m and on a nested 2 m grid at the breach, for placement seeds 1-3 each, through the verdict check
(:func:`breachflow.ensemble.check.run_check`: the members are closures of the ensemble runner). Asserted:

* the same outcome (closed / not closed) for every grid and seed;
* tonnage in place (placed minus carried away) ranges over the seeds that overlap between the grids;
* the open breach's discharge and depth-weighted mean gap speed within 2 % between 4 m and 2 m cells (the
  two finest uniform grids), and between uniform 2 m and the nested 2 m grid.

The expected values are not numbers this code produced: a closure answer that a user can act on must not
change with the cell size or the random placement, and a grid-converged flow changes by less than 2 %
when the cells are halved. About 20 CPU min.
"""
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SEEDS = 3


@pytest.mark.slow
def test_typical_breach_same_verdict_on_4m_2m_nested_2m_for_three_seeds(tmp_path):
    from breachflow.ensemble.check import CheckSection, run_check
    from breachflow.cycle.main import run_closure

    path = ROOT / "examples" / "typical_breach.toml"
    text = path.read_text()
    out = tmp_path / "run"
    run_closure(path, out, plots=False)
    uniform = run_check(out, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="uniform"))
    nested = run_check(out, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="nested"))
    runs = {}
    for r in uniform.runs + [r for r in nested.runs if "nested" in r.label]:
        runs.setdefault(r.label, {})[r.seed] = r
    assert set(runs) == {"4 m", "2 m", "2 m nested"}, runs.keys()
    table = "\n".join(f"{g} seed {s}: {r.outcome}, {r.in_place:,.0f} t in place, Q {r.discharge:.1f} m3/s, "
                      f"gap {r.gap_mean_speed:.3f} m/s" for g, rs in runs.items() for s, r in sorted(rs.items()))
    assert all(len(rs) == SEEDS and not any(r.error for r in rs.values()) for rs in runs.values()), table
    outcomes = {r.closed for rs in runs.values() for r in rs.values()}
    assert len(outcomes) == 1, "verdict differs between grids or seeds:\n" + table
    if outcomes == {True}:
        ranges = {g: (min(r.in_place for r in rs.values()), max(r.in_place for r in rs.values())) for g, rs in runs.items()}
        lo = max(a for a, _ in ranges.values())
        hi = min(b for _, b in ranges.values())
        assert lo <= hi, f"tonnage ranges do not overlap: {ranges}\n" + table

    def flow(g):
        r = runs[g][1]
        return np.array([r.discharge, r.gap_mean_speed])

    for a, b in (("4 m", "2 m"), ("2 m", "2 m nested")):
        rel = np.abs(flow(b) - flow(a)) / np.abs(flow(a))
        assert np.all(rel <= 0.02), f"{a} vs {b}: discharge {100 * rel[0]:.2f} %, gap speed {100 * rel[1]:.2f} %\n" + table
