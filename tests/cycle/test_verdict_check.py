"""The verdict check (`[check]`, breachflow.ensemble.check): how its runs are planned and read.

The reading is tested on hand-made runs whose answer is known by counting: P(closure) = k / n with the
Wilson interval from its closed form, the tonnage range from the runs' own numbers, and the statement
for every way the runs can disagree (grids, seeds, the open breach's flow)."""
import math

import numpy as np
import pytest

from breachflow.ensemble.check import CheckRun, CheckSection, check_members, judge
from breachflow.errors import BreachflowError
from breachflow.scenario import parse_scenario


def run(label, size, seed, closed, *, q=1800.0, u=8.0, tonnage=10_000.0, lost=0.0, verdict="", own=False):
    return CheckRun(label=label, cell_size=size, seed=seed, closed=closed, verdict=verdict, tonnage=tonnage,
                    lost_tonnage=lost, cycles=8, discharge=q, gap_mean_speed=u, gap_max_speed=u + 1, own=own)


def wilson(k, n, z=1.959963984540054):
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return c - h, c + h


def test_all_closed_on_both_grids_with_converged_flow_is_robust():
    runs = [run("4 m", 4, 1, True, tonnage=14_000, lost=500, own=True), run("4 m", 4, 2, True, tonnage=15_000),
            run("4 m", 4, 3, True, tonnage=13_000, lost=1_000), run("2 m", 2, 1, True, q=1810.0, u=8.1, tonnage=12_500)]
    r = judge(runs, 0.02)
    assert r.robust and r.statement.startswith("closed in all 4 runs")
    assert r.p_closure == 1.0
    assert r.p_interval == pytest.approx(wilson(4, 4), abs=1e-9)
    assert r.tonnage_range == (12_000, 15_000)  # in place = placed - lost
    assert r.flow_difference["breach discharge"] == pytest.approx(10 / 1800)
    assert r.flow_difference["gap mean speed"] == pytest.approx(0.1 / 8)


@pytest.mark.parametrize("fine_closed", [False])
def test_grids_that_disagree_are_named_and_closed_is_not_claimed(fine_closed):
    runs = [run("4 m", 4, 1, True, own=True), run("4 m", 4, 2, True), run("4 m", 4, 3, True),
            run("2 m", 2, 1, fine_closed, verdict="not closable: 14 masses lost", q=1850, u=9.2),
            run("2 m", 2, 2, fine_closed, verdict="not closable: 12 masses lost", q=1850, u=9.2)]
    r = judge(runs, 0.02)
    assert not r.robust
    assert r.statement.startswith("grid-dependent: closed (3 of 3 seeds) at 4 m, not closable (0 of 2 seeds) at 2 m")
    assert "gap mean speed +15.0 %" in r.statement  # (9.2 - 8) / 8
    assert r.p_closure == pytest.approx(3 / 5)
    assert r.p_interval == pytest.approx(wilson(3, 5), abs=1e-9)
    assert r.tonnage_range == (10_000, 10_000)  # the closed runs only


def test_seeds_that_disagree_give_the_probability():
    runs = [run("4 m", 4, 1, True, own=True), run("4 m", 4, 2, False, verdict="not closable: 9 lost"),
            run("4 m", 4, 3, True)]
    r = judge(runs, 0.02)
    assert not r.robust and r.statement.startswith("seed-dependent: closed in 2 of 3 runs (P(closure) = 0.67")


def test_a_flow_difference_beyond_the_tolerance_withholds_closed():
    runs = [run("4 m", 4, 1, True, own=True), run("2 m", 2, 1, True, q=1800 * 1.03)]
    r = judge(runs, 0.02)
    assert not r.robust and r.statement.startswith("closed in every run, but unconfirmed")
    assert "breach discharge +3.0 %" in r.statement
    # within the tolerance it is confirmed
    assert judge([run("4 m", 4, 1, True), run("2 m", 2, 1, True, q=1800 * 1.015)], 0.02).robust


def test_open_breach_only_fine_grid_counts_for_the_flow_not_for_p():
    fine = CheckRun(label="2 m", cell_size=2, seed=-1, closed=None, discharge=1900.0, gap_mean_speed=8.0,
                    gap_max_speed=9.0)
    r = judge([run("4 m", 4, 1, True, own=True), run("4 m", 4, 2, True), fine], 0.02)
    assert r.p_closure == 1.0 and r.p_interval == pytest.approx(wilson(2, 2), abs=1e-9)
    assert r.flow_difference["breach discharge"] == pytest.approx(100 / 1800)
    assert not r.robust and "unconfirmed" in r.statement


def test_none_closed_is_a_robust_no():
    r = judge([run("4 m", 4, 1, False, verdict="not closable: x", own=True),
               run("2 m", 2, 1, False, verdict="not closable: y")], 0.02)
    assert r.robust and r.statement.startswith("not closed in any of 2 runs") and r.p_closure == 0.0
    assert np.isnan(r.tonnage_range[0])


def test_members_planned_seeds_and_finer_grid():
    sec = CheckSection(seeds=4, refine_seeds=2)
    coarse, fine, grid = check_members(sec, 4.0, 7)
    assert coarse == [8, 9, 10] and fine == [7, 8] and grid == {"resolution": "2 m"}
    coarse, fine, grid = check_members(CheckSection(seeds=1, grid="nested"), 4.0, 1)
    assert coarse == [] and fine == [1] and grid == {"refine": "2 m"}
    assert check_members(CheckSection(refine=False), 4.0, 1)[1] == []
    assert check_members(CheckSection(), 4.0, 1, refine_allowed=False)[1] == []


@pytest.mark.parametrize("line, key", [("seeds = 0", "seeds"), ("refine_seeds = 5", "refine_seeds"),
                                       ('grid = "fine"', "grid"), ("workers = 0", "workers"),
                                       ("seed = 3", "seed"), ('enabled = "yes"', "enabled")])
def test_bad_check_keys_name_the_key_and_line(line, key):
    text = f'[scenario]\nname = "x"\n\n[check]\n{line}\n'
    with pytest.raises(BreachflowError) as err:
        parse_scenario(text)
    msg = str(err.value)
    assert "[check]" in msg and key in msg and ":5:" in msg


def test_check_section_defaults():
    sc = parse_scenario('[scenario]\nname = "x"\n\n[check]\nseeds = 5\n')
    c = sc["check"]
    assert (c.enabled, c.seeds, c.refine, c.grid, c.refine_seeds, c.tolerance, c.workers) == (
        True, 5, True, "uniform", 1, 0.02, 1)


def test_the_summary_says_which_grid_differences_are_judged():
    # discharge +0.5 % and control speed +0.3 % are judged; the levee line's speeds (+10 %, +9.1 %) are not
    runs = [run("1 m", 1, 1, True, u=10.0, own=True), run("0.5 m", 0.5, 1, True, q=1809.0, u=11.0)]
    runs[0].control_speed, runs[1].control_speed = 6.0, 6.018
    r = judge(runs, 0.02)
    assert r.robust
    rows = dict(r.rows())
    assert rows["  grid difference of the open breach's breach discharge"] == "+0.50 % (tolerance 2 %)"
    assert rows["  grid difference of the open breach's control speed"] == "+0.30 % (tolerance 2 %)"
    for k, v in (("gap mean speed", "+10.00 %"), ("gap max speed", "+9.09 %")):
        assert rows[f"  grid difference of the open breach's {k}"].startswith(f"{v} (reported, not judged")
