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
  the two finest grids, nested 2 m and nested 1 m (both with the breach's exact terrain), as the check
  judges them: time means of a march on each grid (:func:`breachflow.ensemble.check.open_breach_mean`), the
  difference plus twice its error within 2 %.

The expected values are not numbers this code produced: a closure answer that a user can act on must not
change with the cell size or the random placement, and a grid-converged flow changes by less than 2 %
when the cells are halved. Slow: one closure of the shipped file at 4 m alone takes several CPU minutes
(docs/closure-timeline.md), and this test runs it for three seeds on three grids.
"""
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SEEDS = 3
TOLERANCE = 0.02


@pytest.mark.slow
def test_typical_breach_same_verdict_on_4m_2m_nested_2m_for_three_seeds(tmp_path):
    from breachflow.ensemble.check import (FLOW_MEAN_WINDOWS, CheckSection, GridTonnage, _open_breach_on,
                                           relative_difference, run_check, tonnage_overlap)
    from breachflow.cycle.main import run_closure
    from breachflow.scenario import parse_scenario

    path = ROOT / "examples" / "typical_breach.toml"
    text = path.read_text()
    out = tmp_path / "run"
    run_closure(path, out, plots=False)
    # the two finest grids' open breach first: it holds whatever the closures below answer
    sc = parse_scenario(text, path=path)
    nested_1m = _open_breach_on(sc, path, 2.0, CheckSection(grid="nested"), windows=FLOW_MEAN_WINDOWS)
    uniform = run_check(out, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="uniform"))
    # the nested check in a copy of the run: its seed members resumed from the uniform check's, its grid
    # members in their own folder (not the uniform grid's members resumed)
    out_nested = tmp_path / "run_nested"
    shutil.copytree(out, out_nested, ignore=lambda d, names: ["grid"] if Path(d).name == "check" else [])
    nested = run_check(out_nested, text, path, section=CheckSection(seeds=SEEDS, refine_seeds=SEEDS, grid="nested"))
    runs, marched = {}, {}
    for r in uniform.runs + [r for r in nested.runs if "nested" in r.label]:
        if r.closed is None:  # the open breach marched on for the flow's time means
            marched[r.label] = r
        else:
            runs.setdefault(r.label, {})[r.seed] = r
    marched["1 m nested"] = nested_1m
    assert set(runs) == {"4 m", "2 m", "2 m nested"}, runs.keys()
    table = "\n".join(f"{g} seed {s}: {r.outcome}, {r.in_place:,.0f} t in place (needed {r.needed[0]:,.0f}-"
                      f"{r.needed[1]:,.0f} t), Q {r.discharge:.1f} m3/s, "
                      f"control {r.control_speed:.3f} m/s, gap {r.gap_mean_speed:.3f} m/s"
                      for g, rs in runs.items() for s, r in sorted(rs.items()))
    table += "".join(f"\n{g}, open breach (time mean over {r.mean_interval:.0f} s): Q {r.discharge:.1f} ± "
                     f"{r.discharge_error:.1f} m3/s, control {r.control_speed:.3f} ± {r.control_speed_error:.3f} m/s"
                     for g, r in marched.items())

    problems = []
    if set(marched) != {"4 m", "2 m", "2 m nested", "1 m nested"}:
        problems.append(f"open breaches marched: {sorted(marched)}")
    for a, b in (("4 m", "2 m"), ("2 m", "2 m nested"), ("2 m nested", "1 m nested")):
        if a not in marched or b not in marched:
            continue
        for k, name in (("discharge", "breach discharge"), ("control_speed", "control speed")):
            ra, rb = marched[a], marched[b]
            d, e = relative_difference(getattr(ra, k), getattr(ra, f"{k}_error"), getattr(rb, k), getattr(rb, f"{k}_error"))
            if not abs(d) + 2 * e <= TOLERANCE:  # the check's reading of a grid difference of time means
                problems.append(f"{a} vs {b}: {name} {100 * d:+.2f} ± {100 * e:.2f} %")
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
