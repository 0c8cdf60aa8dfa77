"""The closure in time on a nested finer grid ([hydro] refine with [closure] method), as the verdict
check's finer grid runs it: the nested grid's edges follow the flood stage and the polder level of the
timeline, not the levels of the coarse model's first solve."""
from importlib.resources import files

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.config.nested_timeline import NestedTimelineSolver
from breachflow.cycle.criteria import section_discharge
from breachflow.scenario import parse_scenario


def _edge_levels(snap):
    ws, wet = snap.water_surface.values, snap.wet.values.astype(bool)
    return (float(np.nanmean(np.where(wet[0], ws[0], np.nan))),     # flood side (smallest y)
            float(np.nanmean(np.where(wet[-1], ws[-1], np.nan))))   # polder side


# 1 m divides the 12 m breach; 0.9 m does not, so the nested grid's cells are 12 / 13 m (the breach's ends on
# cell faces) and the rebuilt edges must be laid on that grid, not on one of 0.9 m cells
@pytest.fixture(scope="module", params=["1 m", "0.9 m"])
def refined(request):
    text = files("breachflow.data").joinpath("closure_default.toml").read_text()
    # the embedded default, a closure in time by crane barge, started at the breach (the levels below are the
    # flood's from its crest on)
    assert 'method = "barge_crane"\n' in text and 'start = "1 h"\n' in text
    text = text.replace('start = "1 h"\n', 'start = "0 h"\n')
    text = text.replace('resolution = "1 m"', f'resolution = "2 m"\nrefine = "{request.param}"')
    return closure_setup(parse_scenario(text))


def test_refined_grid_carries_the_timeline(refined):
    s = refined
    assert isinstance(s.solver, NestedTimelineSolver)
    tl = s.timeline
    tl.begin()
    first = s.solver.solve(s.domain)
    flood0, _ = _edge_levels(first)
    # [flood] of the default: 3 m at the crest at the breach, falling 0.3 m/h
    assert flood0 == pytest.approx(3.0, abs=0.02)
    assert s.solver.coarse_solves == 0
    # two hours later, the polder filled to 1 m above its ground: 3.0 - 2 x 0.3 = 2.4 m on the flood side
    tl.time = 7200.0
    tl.polder_level = tl.ground + 1.0
    assert tl.flood_level == pytest.approx(2.4, abs=1e-9)
    later = s.solver.solve(s.domain, initial=first)
    assert s.solver.coarse_solves == 1
    flood1, polder1 = _edge_levels(later)
    assert flood1 == pytest.approx(2.4, abs=0.02)
    assert polder1 == pytest.approx(tl.ground + 1.0, abs=0.1)
    # the same levels again: no further coarse solve
    s.solver.solve(s.domain, initial=later)
    assert s.solver.coarse_solves == 1
    # the polder filled to 2 m, 0.4 m under the flood: a drowned breach. The nested grid's protected edges
    # stand at the polder level (not a free outflow), so its breach discharge is that of the coarse model at
    # the same levels, up to the difference of the two grids (a few per cent when the cells are halved). Warm
    # start from the first state, with the polder empty: the protected edges must fill it to its level (free
    # outflow edges let it drain: -13.5 % against the coarse model). Filling it takes longer than one solve's
    # t_max: solved on to its steady state, as the run does before it judges a cycle
    from breachflow.cycle.rock_end import continue_to_steady

    tl.polder_level = tl.ground + 2.0
    drowned, steady, _, _ = continue_to_steady(lambda prev: s.solver.solve(s.domain, initial=prev),
                                               s.solver.solve(s.domain, initial=first), 1800.0)
    assert steady
    assert s.solver.coarse_solves == 2
    _, polder2 = _edge_levels(drowned)
    assert polder2 == pytest.approx(tl.ground + 2.0, abs=0.05)
    q_nested = section_discharge(drowned, s.breach_x, s.levee_y)
    q_coarse = section_discharge(s.solver._regional, s.breach_x, s.levee_y)
    assert q_nested == pytest.approx(q_coarse, rel=0.03), (q_nested, q_coarse)
