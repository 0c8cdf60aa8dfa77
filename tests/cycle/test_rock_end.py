"""When the rock stage of a sealed closure may end (breachflow.cycle.rock_end): only on a steady re-solve, and
only with the pile's crest above the flood level in every gap column. The crests against hand arithmetic; a
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


def test_gap_crests_are_the_highest_pile_top_of_each_gap_column_by_hand():
    """Columns x = 0..9 m (1 m cells), the levee row y = 1; the gap x in [2, 7] where the levee row's ground is
    below the flood (5 m); x = 2 is a levee head (ground 6 m) and not a gap column. Pile rows 0 and 1."""
    x = np.arange(10.0)
    y = np.arange(4.0)
    bed = np.zeros((4, 10))
    bed[1, 2] = 6.0  # levee head in the breach section
    h = np.zeros((4, 10))
    h[0, 3:8] = [5.5, 4.0, 5.0, 1.0, 7.0]
    h[1, 3:8] = [4.0, 4.5, 3.0, 4.9, 2.0]
    xs, crest = gap_crests(x, y, bed, h, (2.0, 7.0), 1.0, 5.0)
    np.testing.assert_array_equal(xs, [3.0, 4.0, 5.0, 6.0, 7.0])
    np.testing.assert_allclose(crest, [5.5, 4.5, 5.0, 4.9, 7.0])
    # no pile at all: the levee row's ground, all below the flood
    xs, crest = gap_crests(x, y, bed, None, (2.0, 7.0), 1.0, 5.0)
    np.testing.assert_allclose(crest, np.zeros(5))


@pytest.mark.parametrize("low", [4.99, 4.0, -1.0])
def test_a_submerged_crest_is_not_held_even_steady_and_with_the_overflow_met(low):
    crests = np.array([5.2, 5.0, low, 6.0])
    end = judge("emergent", True, 900.0, 3, crests, 5.0, overflow_ok=True)
    assert not end.held and not end.emergent and end.submerged == 1 and end.columns == 4
    assert "1 of 4 gap columns" in end.reason() and "not held" in end.statement()
    # the crest raised to the flood everywhere: held
    assert judge("emergent", True, 900.0, 3, np.maximum(crests, 5.0), 5.0, overflow_ok=False).held
    # the overflow rule accepts a crest awash when the overflow criterion is met on a steady solve ...
    assert judge("overflow", True, 900.0, 3, crests, 5.0, overflow_ok=True).held
    assert not judge("overflow", True, 900.0, 3, crests, 5.0, overflow_ok=False).held
    # ... but never on an unsteady one, and no rule holds on an unsteady one
    for rule in ("emergent", "overflow"):
        end = judge(rule, False, 1800.0, 15, np.full(4, 9.0), 5.0, overflow_ok=True)
        assert not end.held and "not steady after 1,800 s" in end.reason()
    with pytest.raises(ValueError):
        judge("awash", True, 1.0, 1, crests, 5.0, True)


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
    setup = SimpleNamespace(solver=solver, criteria=Criteria(), domain=dom, breach_x=(0.0, 2.0), levee_y=15.0)
    fake = SimpleNamespace(setup=setup, _seepage=lambda snap, p: 0.0)
    snap = solver.solve(domain)
    ctx = CycleContext(cycle=1, snapshot=snap, breach_x=(0.0, 2.0), levee_y=15.0, flood_level=3.0)
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
    assert end.steady and not end.held and not closed and end.submerged == end.columns == 2


@pytest.mark.parametrize("cut", [2.0, 5.0, 50.0])
def test_a_submerged_crest_is_judged_on_the_cut_resolve_without_continuing_it(cut, monkeypatch):
    """With ``CONTINUE_SUBMERGED`` off, the crest 0.5 m under the flood cannot hold whatever the flow: the
    re-solve cut at *cut* s is not continued (one solve, its simulated time), the dam is not held, and the
    reason is the crest, not the unsteady flow; the state is the cut solve's own (the criteria are not judged
    again)."""
    assert rock_end.CONTINUE_SUBMERGED  # the default continues every judged re-solve
    monkeypatch.setattr(rock_end, "CONTINUE_SUBMERGED", False)
    (snap, ctx, closed, _, _, end), crit = _judge_on_swe(2.5, t_max=cut, cap=3000.0)
    assert not end.held and not closed and not end.emergent and end.submerged == end.columns == 2
    assert end.resolves == 1 and end.simulated_s == pytest.approx(cut) and crit.evaluated == 0
    assert snap.attrs["simulated_time_s"] == pytest.approx(cut) and not end.steady
    assert "2 of 2 gap columns have their crest below the flood level 3.00 m" in end.reason()
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
