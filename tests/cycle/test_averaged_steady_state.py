"""The averaged steady-state criterion in the closure's solvers (issue 16), and the region re-solve's
fall-back to the full domain.

* ``[hydro] steady_average``: validated (a boolean, the error names the key and the value) and given to
  every ``swe`` solve of the run (cold, warm, region).
* The region re-solve of a flow that never settles converges on the running mean: a 4 m gap in a wall
  between a basin whose level oscillates (±0.15 m, period 6 s; the scene of
  ``tests/swe/test_steady_mean.py``) and a channel held at a fixed level, in a domain 100 m wide so that
  the region (the section ± 16 m, reaching both forced edges) is 44 % of it; a 0.4 m mound in the gap,
  re-solved warm from the averaged open state. (Its mean is not the full domain's: the region's frozen
  absorbing sides change the sloshing of the basin, +1.5 % here; docs/performance.md, work–precision of the region re-solve.)
* A region that has to fall back to the full domain gives the full re-solve from the previous steady
  state, bit for bit (it started from the region's merged state before, and on the typical breach
  stopped 4.0–5.7 % below the full re-solve: README).
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.errors import ParseError
from breachflow.swe.section import snapshot_discharge
from breachflow.swe.solver import SWESolver
from breachflow.swe.domain import BoundaryCondition, uniform_grid
from breachflow.hydro.resolve_region import RegionResolver
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

PERIOD = 6.0
SECTION = (-6.0, 6.0, 0.0)


def wide_tidal_gap(bed=None):
    times = np.arange(0.0, 4000.01, 0.25)
    dom = uniform_grid(-50, 50, -12, 12, 1.0, bed=0.0, manning=0.02,
                       obstacle=lambda X, Y: (np.abs(Y) < 1.0) & (np.abs(X) > 2.0),
                       initial_surface=lambda X, Y: np.where(Y < 0, 2.0, 1.6))
    if bed is not None:
        dom.bed = bed
    dom.boundaries = {"south": [BoundaryCondition.water_level(2.0 + 0.15 * np.sin(2 * np.pi * times / PERIOD),
                                                              times=times)],
                      "north": [BoundaryCondition.water_level(1.6)]}
    return dom


@pytest.fixture(scope="module")
def open_state():
    solver = SWESolver(tolerance=1e-3, t_max=1500.0, section=SECTION, average=True)
    ds = solver.solve(wide_tidal_gap())
    assert solver.last.history.averaged
    return ds


def test_region_resolve_of_an_oscillating_flow_converges_on_the_running_mean(open_state):
    dom = wide_tidal_gap()
    X, Y = np.meshgrid(dom.x, dom.y)
    bed = dom.bed.copy()
    bed[(np.abs(X) < 2.0) & (np.abs(Y) < 1.0)] = 0.4  # a mound in the gap
    full = SWESolver(tolerance=1e-3, t_max=1500.0, section=SECTION, average=True)
    solver = RegionResolver(full, margin=16.0)
    ds = solver.solve(wide_tidal_gap(bed), initial=open_state)
    assert solver.last_info["mode"] == "region" and solver.last_info["fraction"] < 0.5, solver.last_info
    hist = solver.last.history
    assert hist.converged and hist.averaged
    mean, err = hist.section_mean[-1], hist.section_se[-1]
    assert err <= 1e-3 * (hist.time[1] - hist.time[0]) * abs(mean) * (1 + 1e-12)
    # the state left is the region's time mean, merged into the full domain: its discharge is the mean
    assert snapshot_discharge(ds, SECTION[:2], SECTION[2]) == pytest.approx(mean, rel=1e-9)
    # the mound cuts the mean flow by far more than the error
    assert snapshot_discharge(open_state, SECTION[:2], SECTION[2]) - mean > 20.0 * err


def test_a_region_that_falls_back_gives_the_full_resolve_from_the_previous_state():
    setup = closure_setup(parse_scenario(SCENE))
    snap = setup.solver.solve(setup.domain)
    dom = setup.domain
    X, Y = np.meshgrid(dom.x, dom.y)
    x0, x1 = setup.breach_x
    mask = (X > x0) & (X < 0.5 * (x0 + x1)) & (np.abs(Y - setup.levee_y) < 2.0)
    piled = dom.with_raised_bed(mask, float(dom.bed.min()) + 0.6 * (setup.flood_level - float(dom.bed.min())))
    # a small region whose edge level must not move by 0.1 mm and may not grow: it is solved, then falls back
    region = RegionResolver(setup.solver.warm, margin=2.0, edge_level=1e-4, max_grow=0)
    got = region.solve(piled, initial=snap)
    assert region.last_info["mode"] == "full" and region.last_info["grown"] == 1, region.last_info
    want = setup.solver.warm.solve(piled, initial=snap)
    for name in ("depth", "u", "v"):
        np.testing.assert_array_equal(got[name].values, want[name].values, err_msg=name)


SCENE = (__import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def test_steady_average_reaches_every_swe_solve_of_the_run():
    setup = closure_setup(parse_scenario(scenario_with(SCENE, {"hydro.steady_average": True,
                                                               "hydro.resolve": "region"})))
    assert setup.solver.cold.average and setup.solver.warm.average
    assert setup.solver.region.full is setup.solver.warm
    default = closure_setup(parse_scenario(SCENE))
    assert not default.solver.cold.average and not default.solver.warm.average


@pytest.mark.parametrize("value", ["yes", 1, "true"])
def test_steady_average_must_be_a_boolean(value):
    # the error names the section, the key, the value and the line of the scenario
    with pytest.raises(ParseError, match=r"\[hydro\] steady_average: expected bool, got .*" + re.escape(repr(value))):
        closure_setup(parse_scenario(scenario_with(SCENE, {"hydro.steady_average": value})))
