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
    assert rows["  grid difference of the open breach's breach discharge"] == "+0.50 % (single states; tolerance 2 %)"
    assert rows["  grid difference of the open breach's control speed"] == "+0.30 % (single states; tolerance 2 %)"
    for k, v in (("gap mean speed", "+10.00 %"), ("gap max speed", "+9.09 %")):
        assert rows[f"  grid difference of the open breach's {k}"].startswith(f"{v} (reported, not judged")


def closed_after(label, size, seed, loads, *, lost=0.0, own=False):
    """A closed run whose cycles placed *loads* (t each); *lost* carried away before its last load."""
    r = run(label, size, seed, True, tonnage=float(sum(loads)), lost=lost, own=own)
    r.in_place_before = float(sum(loads[:-1])) - lost
    r.cycles = len(loads)
    return r


def test_a_finer_grid_that_needs_more_loads_makes_the_tonnage_grid_dependent():
    # three seeds close after 11, 12 and 12 loads of 750 t at 4 m; the finer grid needs 15
    coarse = [closed_after("4 m", 4, 1, [750.0] * 11, own=True), closed_after("4 m", 4, 2, [750.0] * 12),
              closed_after("4 m", 4, 3, [750.0] * 12, lost=30.0)]
    fine = closed_after("2 m", 2, 1, [750.0] * 15, lost=10.0)
    r = judge(coarse + [fine], 0.02)
    assert r.tonnage_grid_dependent and not r.robust
    assert r.p_closure == 1.0  # every run closed: the verdict agrees, the amount does not
    # needed at 4 m: from 10 loads (7,500 t) to 12 loads (9,000 t); at 2 m: 14 loads - 10 t to 15 loads - 10 t
    assert r.statement == ("closed in every run, but unconfirmed; the tonnage depends on the grid (needed: "
                           "over 7,500 up to 9,000 t at 4 m, over 10,490 up to 11,240 t at 2 m; the ranges do not overlap)")
    rows = dict(r.rows())
    assert rows["  tonnage at 4 m"] == "8,250-9,000 t in place (3 seeds); needed over 7,500 up to 9,000 t"
    assert rows["  tonnage at 2 m"] == "11,240 t in place (1 seed); needed over 10,490 up to 11,240 t"
    assert rows["  tonnage needed on the grids"].startswith("ranges do not overlap")
    s = r.summary()
    assert s["tonnage_grid_dependent"] is True
    assert s["tonnage_by_grid_t"]["2 m"] == {"in_place": [11_240.0, 11_240.0], "needed": [10_490.0, 11_240.0],
                                             "closed_runs": 1}
    assert r.dataset().attrs["tonnage_grid_dependent"] == 1


def test_tonnage_known_to_one_load_overlaps_where_the_end_values_miss_by_a_tonne():
    # 4 m ends at 8,167-8,907.5 t, the finer grid at 8,908.3 t after as many loads: the same tonnage to the load
    coarse = [closed_after("4 m", 4, 1, [742.5] * 11, own=True), closed_after("4 m", 4, 2, [742.3] * 12)]
    fine = closed_after("2 m nested", 2, 1, [742.36] * 12)
    assert max(r.in_place for r in coarse) < fine.in_place  # the end values alone do not overlap
    r = judge(coarse + [fine], 0.02)
    assert not r.tonnage_grid_dependent and r.robust
    assert r.statement.startswith("closed in all 3 runs")
    assert dict(r.rows())["  tonnage needed on the grids"] == "ranges overlap"


def test_the_same_units_that_close_one_grid_and_not_the_other_do_not_overlap():
    # seed 1 places the same units on both grids: 1 m closes with the 7th load, 0.5 m is still open after it
    loads = [58.8] * 8
    coarse = [closed_after("1 m", 1, 1, loads[:7], own=True), closed_after("1 m", 1, 2, loads[:6])]
    fine = closed_after("0.5 m", 0.5, 1, loads)
    assert fine.in_place_before == coarse[0].in_place  # the ranges touch at one tonnage
    r = judge(coarse + [fine], 0.02)
    assert r.tonnage_grid_dependent and not r.robust
    assert "needed: over 294 up to 412 t at 1 m, over 412 up to 470 t at 0.5 m" in r.statement
    # a run recorded without the tonnage before its last load counts its end value as enough: touching overlaps
    point = run("0.5 m", 0.5, 1, True, tonnage=sum(loads[:7]))
    assert judge(coarse + [point], 0.02).robust


def test_a_flow_difference_and_a_tonnage_difference_are_both_named():
    r = judge([closed_after("4 m", 4, 1, [500.0] * 4, own=True), closed_after("2 m", 2, 1, [500.0] * 7)], 0.02)
    assert r.robust is False and r.tonnage_grid_dependent
    r2 = judge([closed_after("4 m", 4, 1, [500.0] * 4, own=True),
                run("2 m", 2, 1, True, q=1800 * 1.03, tonnage=3500.0)], 0.02)
    assert "breach discharge +3.0 %" in r2.statement and "the tonnage depends on the grid" in r2.statement


def test_one_grid_or_unclosed_runs_make_no_tonnage_comparison():
    r = judge([closed_after("4 m", 4, 1, [500.0] * 4, own=True), closed_after("4 m", 4, 2, [500.0] * 9)], 0.02)
    assert not r.tonnage_grid_dependent and r.robust and len(r.tonnage_by_grid) == 1
    assert not any(k.startswith("  tonnage at") for k, _ in r.rows())
    r = judge([closed_after("4 m", 4, 1, [500.0] * 4, own=True),
               run("2 m", 2, 1, False, verdict="not closable: 9 lost")], 0.02)
    assert not r.tonnage_grid_dependent and r.statement.startswith("grid-dependent")


def test_a_run_read_from_its_manifest_knows_the_tonnage_before_its_last_load():
    from breachflow.ensemble.check import _run_of

    def cycle(k, tonnage, lost, closed=False):
        return {"cycle": k, "summary": {"cycle": k, "tonnage": tonnage, "lost_tonnage": lost, "closed": closed}}

    man = {"cycles": [cycle(1, 700.0, 0.0), cycle(2, 1400.0, 40.0), cycle(3, 2150.0, 55.0, closed=True)],
           "final": {"verdict": "closed"}, "metadata": {"initial": {"breach_discharge": 100.0}}}
    r = _run_of(man, 4.0, None, 1)
    assert r.closed and r.in_place == 2150.0 - 55.0 and r.in_place_before == 1400.0 - 40.0
    assert r.needed == (1360.0, 2095.0)
    one = _run_of({"cycles": [cycle(1, 700.0, 0.0, closed=True)], "final": {}, "metadata": {}}, 4.0, None, 1)
    assert one.needed == (0.0, 700.0)  # closed by its first load: it needed more than nothing
