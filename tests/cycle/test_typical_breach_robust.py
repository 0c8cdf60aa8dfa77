"""The typical breach's verdict is grid- and seed-robust at the shipped settings (issue "verdicts that hold").

``examples/typical_breach.toml`` as shipped (4 m cells, 10-15 t rock by split barges in time, porous remap, sealed)
runs at 4 m, at uniform
2 m and on a nested 2 m grid at the breach, for placement seeds 1-3 each, through the verdict check
(:func:`breachflow.ensemble.check.run_check`: the members are closures of the ensemble runner), and its open
breach is solved once more on a nested 1 m grid. Asserted:

* the same outcome (closed / not closed) for every grid and seed;
* ranges of the tonnage needed over the seeds that overlap between the grids
  (:func:`breachflow.ensemble.check.tonnage_overlap`: a closure is judged after each load, so a run that closed
  needed more than the tonnage in place before its last load and at most that after it; end values alone would
  call two runs closed by the same number of loads different when their random unit sizes differ by a tonne);
* the open breach's discharge and gap speed — the mean speed at the breach's control section, where the flow
  passes critical depth (:func:`breachflow.cycle.criteria.control_speed`; docs/verdict-check.md, *The gap
  speed that converges*) — within 2 % between 4 m and 2 m cells, between uniform and nested 2 m, and between
  the two finest grids, nested 2 m and nested 1 m (both with the breach's exact terrain).

The expected values are not numbers this code produced: a closure answer that a user can act on must not
change with the cell size or the random placement, and a grid-converged flow changes by less than 2 %
when the cells are halved. Slow: one closure of the shipped file at 4 m alone takes several CPU minutes
(docs/closure-timeline.md), and this test runs it for three seeds on three grids.
"""
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SEEDS = 3
TOLERANCE = 0.02


@pytest.mark.slow
def test_typical_breach_same_verdict_on_4m_2m_nested_2m_for_three_seeds(tmp_path):
    from breachflow.ensemble.check import CheckSection, GridTonnage, _open_breach_on, run_check, tonnage_overlap
    from breachflow.cycle.main import run_closure
    from breachflow.scenario import parse_scenario

    path = ROOT / "examples" / "typical_breach.toml"
    text = path.read_text()
    out = tmp_path / "run"
    run_closure(path, out, plots=False)
    # the two finest grids' open breach first: it holds whatever the closures below answer
    sc = parse_scenario(text, path=path)
    nested_1m = _open_breach_on(sc, path, 2.0, CheckSection(grid="nested"))
    uniform = run_check(out, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="uniform"))
    # the nested check in a copy of the run: its seed members resumed from the uniform check's, its grid
    # members in their own folder (not the uniform grid's members resumed)
    out_nested = tmp_path / "run_nested"
    shutil.copytree(out, out_nested, ignore=lambda d, names: ["grid"] if Path(d).name == "check" else [])
    nested = run_check(out_nested, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="nested"))
    runs = {}
    for r in uniform.runs + [r for r in nested.runs if "nested" in r.label]:
        runs.setdefault(r.label, {})[r.seed] = r
    assert set(runs) == {"4 m", "2 m", "2 m nested"}, runs.keys()
    table = "\n".join(f"{g} seed {s}: {r.outcome}, {r.in_place:,.0f} t in place (needed {r.needed[0]:,.0f}-"
                      f"{r.needed[1]:,.0f} t), Q {r.discharge:.1f} m3/s, "
                      f"control {r.control_speed:.3f} m/s, gap {r.gap_mean_speed:.3f} m/s"
                      for g, rs in runs.items() for s, r in sorted(rs.items()))
    table += (f"\n1 m nested, open breach: Q {nested_1m.discharge:.1f} m3/s, control {nested_1m.control_speed:.3f} m/s,"
              f" gap {nested_1m.gap_mean_speed:.3f} m/s")

    def flow(r):
        return np.array([r.discharge, r.control_speed])

    problems = []
    for a, b in ((runs["4 m"][1], runs["2 m"][1]), (runs["2 m"][1], runs["2 m nested"][1]),
                 (runs["2 m nested"][1], nested_1m)):
        rel = np.abs(flow(b) - flow(a)) / np.abs(flow(a))
        if not np.all(rel <= TOLERANCE):
            problems.append(f"{a.label} vs {b.label}: discharge {100 * rel[0]:.2f} %, control speed {100 * rel[1]:.2f} %")
    if not all(len(rs) == SEEDS and not any(r.error for r in rs.values()) for rs in runs.values()):
        problems.append("a check run is missing or failed")
    outcomes = {r.closed for rs in runs.values() for r in rs.values()}
    if len(outcomes) != 1:
        problems.append("verdict differs between grids or seeds")
    elif outcomes == {True}:
        ranges = {g: GridTonnage() for g in runs}
        for g, rs in runs.items():
            for r in rs.values():
                ranges[g].add(r)
        if not tonnage_overlap(ranges):
            problems.append("ranges of the tonnage needed do not overlap: "
                            + ", ".join(f"{g}: {t.words()}" for g, t in ranges.items()))
    print(table)
    assert not problems, "\n".join(problems) + "\n" + table
