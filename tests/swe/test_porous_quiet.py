"""Quiet-cell skipping on the closure's default re-solve: a warm start with a porous pile (issue 16).

The pile's Forchheimer resistance is applied inside the compiled time loop after every step, so the
quiet ranges of one step carry over to the next (before, the porous path called the loop one step at a
time and every step re-examined every cell). Tested at the defaults users get: the embedded default
scenario (``breachflow run``), its steady open breach, a pile of about five 2 m masses in the breach
(heights 1.2-1.9 m, i.e. below and near the 3 m water depth, porosity 0.42, stones 2 m), and the warm
re-solve of its ``[hydro]`` settings (tolerance 2e-4 1/s, steady state judged near the breach and on the
breach discharge) with and without skipping.
"""
import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import section_discharge
from breachflow.cycle.main import default_scenario_text
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe import kernels as K
from breachflow.swe.porous import PorousPile
from breachflow.scenario.config import parse_scenario


@pytest.fixture(scope="module")
def default_scene():
    setup = closure_setup(parse_scenario(default_scenario_text()))
    snap = setup.solver.solve(setup.domain)
    dom = setup.domain
    X, Y = np.meshgrid(dom.x, dom.y)
    x0, x1 = setup.breach_x
    # a mound across the levee line, off-centre towards the west wall, higher in the middle
    r = np.hypot((X - (0.6 * x0 + 0.4 * x1)) / 4.0, (Y - setup.levee_y) / 2.0)
    height = np.where(r < 1.0, 1.2 + 0.7 * (1.0 - r), 0.0)
    pile = PorousPile.build(height, np.full(dom.shape, 0.42), np.full(dom.shape, 2.0))
    return setup, snap, dom.with_porous(pile)


def _resolve(setup, snap, piled, **options):
    warm = setup.solver.warm
    o = SWEOptions(order=warm.options.order, courant=warm.options.courant, **options)
    sim = SWESimulation(piled, o, initial=snap)
    sim.run_to_steady(warm.tolerance, warm.t_max, warm.check_interval, region=warm.region, section=warm.section)
    return sim


def test_skipping_quiet_cells_in_the_porous_resolve_matches_the_full_computation(default_scene):
    setup, snap, piled = default_scene
    runs = {name: _resolve(setup, snap, piled, **kw) for name, kw in (
        ("all", dict(skip_quiet=False)), ("default", {}), ("exact", dict(quiet_tolerance=0.0)))}
    full, skip, exact = runs["all"], runs["default"], runs["exact"]
    for sim in runs.values():
        assert sim.history.converged
    # the pile changed the flow (the test is not on a state at rest)
    q_open = section_discharge(snap, setup.breach_x, setup.levee_y)
    q = {k: sim.section_discharge(setup.solver.warm.section) for k, sim in runs.items()}
    assert q["all"] < 0.97 * q_open
    # exact skipping (tolerance 0) is bitwise the full computation, steps and all
    assert exact.steps == full.steps
    for a, b in ((exact.h, full.h), (exact.hu, full.hu), (exact.hv, full.hv)):
        assert np.array_equal(a, b)
    # the default tolerance (1e-14) changes depth and discharge by round-off, far inside the steady-state
    # tolerance's effect (README: 0.37 % of the breach discharge at 2e-4 1/s)
    assert skip.steps == full.steps
    assert np.abs(skip.depth - full.depth).max() <= 1e-9
    assert np.abs(np.hypot(*skip.discharge) - np.hypot(*full.discharge)).max() <= 1e-9
    assert abs(q["default"] - q["all"]) <= 1e-9 * abs(q["all"])
    # and quiet cells (dry polder land, water at rest) did cost no flux work
    print(f"\nporous re-solve, default scene: {full.steps} steps, cell-stages skipped "
          f"{100 * (1 - skip.stats[3] / full.stats[3]):.1f} %, max |dh| default vs unskipped "
          f"{np.abs(skip.depth - full.depth).max():.3g} m, Q {q['default']:.4f} vs {q['all']:.4f} m3/s "
          f"(open breach {q_open:.4f})")
    assert skip.stats[3] < 0.95 * full.stats[3]


def test_the_porous_path_marches_in_one_compiled_call(default_scene, monkeypatch):
    """The pile's resistance is applied inside :func:`~breachflow.swe.kernels.advance`: one call per
    ``advance_to``, so the quiet ranges carry over between steps (the former path called it per step)."""
    setup, snap, piled = default_scene
    calls = []
    inner = K.advance

    def counting(*args):
        calls.append(args[23])  # max_steps
        return inner(*args)

    monkeypatch.setattr(K, "advance", counting)
    sim = SWESimulation(piled, initial=snap)
    sim.advance_to(2.0)
    assert sim.steps > 5 and len(calls) == 1
