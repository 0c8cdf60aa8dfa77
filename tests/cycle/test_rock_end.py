"""When the rock stage of a sealed closure may end (breachflow.cycle.rock_end): only on a steady re-solve, and
only with the pile's crest, read from the masses, above the flood level all along the gap. The crests against
hand arithmetic and on three grids; a
re-solve cut off before its steady state and a submerged crest are never "held", on the embedded solver."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from breachflow.cycle.criteria import CriterionResult, CycleContext
from breachflow.cycle.driver import ClosureRun
from breachflow.cycle.leakage import PolderLeakage
from breachflow.cycle import rock_end
from breachflow.cycle.rock_end import continue_to_steady, gap_crests, judge
from breachflow.errors import InputError
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.porous import PorousPile
from breachflow.swe.solver import SWESolver


def test_gap_crests_are_the_highest_unit_top_over_each_point_by_hand():
    """The levee row (y = 1) of a 1 m grid has ground 0 m over x = 0..7 and rises to a head of 6 m at x = 8: it
    crosses the flood (5 m) at x = 7 + 5/6. Resting units: A at x = 2 (r 1 m, top 5 m) covers 1..3, B at x = 5
    (r 1.5 m, top 5 m) covers 3.5..6.5; C (top 11 m over x = 3.2) is not resting. By hand: the crest is 5 m
    over A and B, the ground elsewhere, and the gap's water part ends at x = 7.83."""
    x = np.arange(11.0)
    y = np.arange(4.0)
    bed = np.zeros((4, 11))
    bed[1, 8:] = 6.0
    pos = np.array([[2.0, 1.0, 4.0], [5.0, 0.0, 3.5], [3.2, 1.0, 10.0]])
    radius = np.array([1.0, 1.5, 1.0])
    resting = np.array([True, True, False])
    xs, crest = gap_crests(pos, radius, resting, x, y, bed, (0.0, 8.0), 1.0, 5.0)
    step = xs[1] - xs[0]
    assert step == pytest.approx(0.05) and xs[0] == 0.0 and xs[-1] == pytest.approx(7.8)  # 7.85: ground 5.1 m
    at = lambda v: crest[np.argmin(np.abs(xs - v))]  # noqa: E731
    assert at(1.0) == at(2.0) == at(3.0) == at(3.5) == at(5.0) == at(6.5) == 5.0
    assert at(0.5) == at(3.25) == at(6.75) == 0.0 and at(7.5) == pytest.approx(3.0)  # ground, linear 7..8
    # three stretches below the flood: 0..1, 3..3.5 and 6.5..7.83 m, each read within a step
    end = judge("emergent", True, 900.0, 1, xs, crest, 5.0, overflow_ok=False)
    assert end.openings == 3 and end.notches == 0 and not end.held and not end.emergent
    assert end.widest_opening == pytest.approx(7 + 5 / 6 - 6.5, abs=step)
    assert end.submerged_width == pytest.approx(1.0 + 0.5 + 7 + 5 / 6 - 6.5, abs=3 * step)
    assert end.gap_width == pytest.approx(7 + 5 / 6, abs=step)
    # stretches narrower than a unit are notches: a 1.2 m unit leaves one opening, a 1.4 m unit none
    end = judge("emergent", True, 900.0, 1, xs, crest, 5.0, overflow_ok=False, unit_diameter=1.2)
    assert (end.openings, end.notches) == (1, 2) and not end.held and "1 opening(s) wider than a unit (1.20 m)" in end.reason()
    end = judge("emergent", True, 900.0, 1, xs, crest, 5.0, overflow_ok=False, unit_diameter=1.4)
    assert (end.openings, end.notches) == (0, 3) and end.emergent and end.held
    # no unit at all: the ground, all below the flood
    xs, crest = gap_crests(pos, radius, np.zeros(3, bool), x, y, bed, (0.0, 8.0), 1.0, 5.0)
    np.testing.assert_allclose(crest, np.interp(xs, x, bed[1]))


def test_the_crest_is_the_same_on_every_grid():
    """The same units read on grids of 0.25, 1 and 4 m cells give the same crest over a flat floor: it is the
    masses' (a 0.5 m notch between two 2 m units is seen on the 4 m grid). By hand: below the flood (2.9 m)
    are 6..6.5 and 8.5..11 m (the third unit, top 3.5 m, covers 11..13), each read within a step (0.05 m)."""
    pos = np.array([[5.0, 0.0, 2.0], [7.5, 0.0, 2.0], [12.0, 1.0, 2.5]])
    radius = np.ones(3)
    ends = []
    for cells in (0.25, 1.0, 4.0):
        x = np.arange(0.0, 20.01, cells)
        y = np.arange(-4.0, 4.01, cells)
        xs, crest = gap_crests(pos, radius, np.ones(3, bool), x, y, np.zeros((y.size, x.size)), (4.0, 13.0), 0.0, 2.9)
        ends.append(judge("emergent", True, 1.0, 1, xs, crest, 2.9, overflow_ok=False, unit_diameter=0.4))
    assert ends[0] == ends[1] == ends[2]
    assert ends[0].openings == 2 and ends[0].widest_opening == pytest.approx(2.5, abs=0.05 + 1e-9)
    assert ends[0].submerged_width == pytest.approx(3.0, abs=2 * 0.05 + 1e-9)


@pytest.mark.parametrize("low", [4.99, 4.0, -1.0])
def test_a_submerged_crest_is_not_held_even_steady_and_with_the_overflow_met(low):
    xs = np.arange(4) * 0.05
    crests = np.array([5.2, 5.0, low, 6.0])
    end = judge("emergent", True, 900.0, 3, xs, crests, 5.0, overflow_ok=True)
    assert not end.held and not end.emergent and end.openings == 1 and end.gap_width == pytest.approx(0.2)
    assert "1 opening(s) wider than a unit (0.00 m)" in end.reason() and "not held" in end.statement()
    # the crest raised to the flood everywhere: held
    assert judge("emergent", True, 900.0, 3, xs, np.maximum(crests, 5.0), 5.0, overflow_ok=False).held
    # the overflow rule accepts a crest awash when the overflow criterion is met on a steady solve ...
    assert judge("overflow", True, 900.0, 3, xs, crests, 5.0, overflow_ok=True).held
    assert not judge("overflow", True, 900.0, 3, xs, crests, 5.0, overflow_ok=False).held
    # ... but never on an unsteady one, and no rule holds on an unsteady one
    for rule in ("emergent", "overflow"):
        end = judge(rule, False, 1800.0, 15, xs, np.full(4, 9.0), 5.0, overflow_ok=True)
        assert not end.held and "not steady after 1,800 s" in end.reason()
    with pytest.raises(ValueError):
        judge("awash", True, 1.0, 1, xs, crests, 5.0, True)


def test_a_summary_written_before_the_masses_crest_is_stated_by_its_reason():
    """A run summary from before the crest was read from the masses (no ``openings``) is still rendered."""
    from breachflow.cycle.rock_end import RockEnd

    end = judge("emergent", True, 900.0, 3, [0.0, 0.05], [5.0, 4.0], 4.5, overflow_ok=False)
    assert RockEnd.from_dict(end.as_dict()) == end
    assert RockEnd.from_dict({"rule": "emergent", "columns": 4, "submerged": 1}) is None


def test_the_rule_keys_are_checked():
    c = PolderLeakage("1 cm/day", area="10 ha", seal=["sand", "gravel", "quarry_run"])
    assert c.rock_end == "emergent" and c.steady_cap == 1800.0
    assert PolderLeakage("1 cm/day", steady_cap="1 h").steady_cap == 3600.0
    with pytest.raises(InputError, match="rock_end"):
        PolderLeakage("1 cm/day", rock_end="awash")
    with pytest.raises(InputError, match="steady_cap"):
        PolderLeakage("1 cm/day", steady_cap="0 s")


def test_continue_to_steady_stops_at_the_cap_with_a_solver_that_never_settles():
    """A solver whose every solve runs 120 s and is never steady: solved on 120 s at a time up to the cap."""
    calls = []

    def solve(prev):
        calls.append(prev)
        return SimpleNamespace(attrs={"steady_state": 0, "simulated_time_s": 120.0})

    first = SimpleNamespace(attrs={"steady_state": 0, "simulated_time_s": 120.0})
    snap, steady, t, n = continue_to_steady(solve, first, cap=500.0)
    assert not steady and t == pytest.approx(600.0) and n == 5 and len(calls) == 4
    # steady at the first solve: no further solve
    snap, steady, t, n = continue_to_steady(solve, SimpleNamespace(attrs={"steady_state": 1, "simulated_time_s": 30.0}))
    assert steady and n == 1 and t == 30.0 and len(calls) == 4


def _scene(height, manning=0.0):
    """A 2 m wide frictionless channel along y (1 m cells), levels 3 m at y = 0 and 2 m at y = 30 m, a rock
    pile (0.5 m stones, porosity 0.4) of *height* over y = 10..20 m; the levee line at y = 15 m, flood 3 m."""
    dom = uniform_grid(0, 2.0, 0, 30.0, 1.0, manning=manning,
                       boundaries={"south": BC("level", level=3.0), "north": BC("level", level=2.0)})
    yy = dom.y[:, None] * np.ones(dom.shape)
    dom.initial_surface = np.clip(3.0 - (yy - 10.0) / 10.0, 2.0, 3.0)
    inside = (yy > 10.0) & (yy < 20.0)
    pile = PorousPile.build(np.where(inside, height, 0.0), np.full(dom.shape, 0.4), np.full(dom.shape, 0.5))
    return dom, pile


def _judge_on_swe(height, t_max, cap):
    """The driver's rock-stage end on the channel, with the embedded solver cut at *t_max* a solve and
    continued up to *cap*: the criteria (a stand-in) say "closed" on every solve."""
    dom, pile = _scene(height)
    solver = SWESolver(order=2, tolerance=1e-4, t_max=t_max)
    crit = PolderLeakage("1 cm/day", area="10 ha", seal=["sand", "gravel", "quarry_run"], steady_cap=f"{cap} s")
    over = CriterionResult("overflow_discharge", 0.0, 18.0, "m3 s-1", True)

    class Criteria:
        items = [crit]
        evaluated = 0

        def evaluate(self, ctx):
            Criteria.evaluated += 1
            return True, [over], "overflow_discharge+polder_leakage"

    domain = dom.with_porous(pile)
    setup = SimpleNamespace(solver=solver, criteria=Criteria(), domain=dom, breach_x=(0.0, 2.0), levee_y=15.0,
                            placement=SimpleNamespace(diameter=(0.5, 0.5)))
    fake = SimpleNamespace(setup=setup, _seepage=lambda snap, p: 0.0)
    snap = solver.solve(domain)
    # the pile's top row: 0.5 m stones side by side across the gap, their tops at *height*
    xs = np.arange(0.25, 2.0, 0.5)
    pos = np.column_stack([xs, np.full(xs.size, 15.0), np.full(xs.size, height - 0.25)])
    ctx = CycleContext(cycle=1, snapshot=snap, breach_x=(0.0, 2.0), levee_y=15.0, flood_level=3.0, pos=pos,
                       radius=np.full(xs.size, 0.25), resting=np.ones(xs.size, bool))
    return ClosureRun._rock_end(fake, snap, ctx, pile, domain, None, True, [over], "overflow_discharge"), Criteria


def test_a_resolve_cut_off_before_steady_is_not_held():
    """The channel's flow from its initial state needs minutes of simulated time to settle: cut at 2 s a solve
    and capped at 6 s, the stage does not end although the crest stands 7 m above the flood."""
    (snap, ctx, closed, results, governing, end), crit = _judge_on_swe(10.0, t_max=2.0, cap=6.0)
    assert not closed and governing == "" and not end.held and not end.steady and end.emergent
    assert end.resolves == 3 and end.simulated_s == pytest.approx(6.0)
    assert snap.attrs["steady_state"] == 0 and crit.evaluated == 1  # judged again on the continued solve
    assert "NOT steady" in end.statement()


def test_the_same_resolve_continued_to_steady_holds_and_a_submerged_crest_does_not():
    (snap, ctx, closed, _, _, end), _ = _judge_on_swe(10.0, t_max=2.0, cap=3000.0)
    assert end.steady and end.held and closed and snap.attrs["steady_state"] == 1
    assert end.resolves > 3 and end.simulated_s <= 3000.0 + 2.0
    # the crest 0.5 m under the flood (3 m): steady, the overflow criterion met, still not held
    (snap, ctx, closed, _, _, end), _ = _judge_on_swe(2.5, t_max=2.0, cap=3000.0)
    assert end.steady and not end.held and not closed and end.openings == 1
    assert end.submerged_width == pytest.approx(end.gap_width) == pytest.approx(2.05)


@pytest.mark.parametrize("cut", [2.0, 5.0, 50.0])
def test_a_submerged_crest_is_judged_on_the_cut_resolve_without_continuing_it(cut, monkeypatch):
    """With ``CONTINUE_SUBMERGED`` off, the crest 0.5 m under the flood cannot hold whatever the flow: the
    re-solve cut at *cut* s is not continued (one solve, its simulated time), the dam is not held, and the
    reason is the crest, not the unsteady flow; the state is the cut solve's own (the criteria are not judged
    again)."""
    assert rock_end.CONTINUE_SUBMERGED  # the default continues every judged re-solve
    monkeypatch.setattr(rock_end, "CONTINUE_SUBMERGED", False)
    (snap, ctx, closed, _, _, end), crit = _judge_on_swe(2.5, t_max=cut, cap=3000.0)
    assert not end.held and not closed and not end.emergent and end.openings == 1
    assert end.resolves == 1 and end.simulated_s == pytest.approx(cut) and crit.evaluated == 0
    assert snap.attrs["simulated_time_s"] == pytest.approx(cut) and not end.steady
    assert "1 opening(s) wider than a unit (0.50 m) below the flood level 3.00 m" in end.reason()
    assert "not steady" not in end.reason() and "NOT steady" in end.statement()
    # an emergent crest on the same cut solve is continued as before
    (snap, ctx, closed, _, _, end), crit = _judge_on_swe(10.0, t_max=cut, cap=3000.0)
    assert end.resolves > 1 and end.steady and end.held


@pytest.mark.parametrize("t_max, sealed", [(2.0, False), (3000.0, True)])
def test_a_seal_leakage_read_from_an_unsteady_resolve_does_not_seal(t_max, sealed):
    """The seal on the channel's emergent pile, judged by a polder so large that any leakage is taken: a
    re-solve cut at 2 s is not steady and does not seal the dam; solved to its steady state it does (a rough
    channel, n = 0.03: the sealed channel's seiche dies out)."""
    from breachflow.cycle.sealing import seal_dam

    dom, pile = _scene(10.0, manning=0.03)
    solver = SWESolver(order=2, tolerance=1e-4, t_max=t_max)
    snap = SWESolver(order=2, tolerance=1e-4, t_max=3000.0).solve(dom.with_porous(pile))
    assert snap.attrs["steady_state"] == 1
    # the leakage read as the flow through the sealed pile cells (a face closed in the flow would leave a
    # channel this narrow with no flow at all, whose relative rates of change never settle)
    crit = PolderLeakage("1 cm/day", area="1000000 ha", seal=["sand", "gravel", "quarry_run"], seal_leakage="flow_model")
    res = seal_dam(lambda p, initial, block: solver.solve(dom.with_porous(p), obstacles=block, initial=initial),
                   pile, snap, crit, breach_x=(0.0, 2.0), levee_y=15.0, y=dom.y, x=dom.x, max_steps=2,
                   flood_level=3.0, bed=np.asarray(dom.bed, float))
    assert res.last.steady is sealed and res.sealed is sealed
    assert ("not steady" in res.verdict) is (not sealed)
