"""The warm re-solve started from a coarse grid's level change (``[hydro] resolve = "coarse"``,
:mod:`breachflow.hydro.coarse_resolve`) reaches the fine grid's own steady state.

* a lake at rest with a new mound stays at rest at its level (exact, well-balanced);
* a frictionless transcritical flow over a hump (the SWASHES bump, q = 1.53 m²/s) whose crest is raised:
  the re-solved crest depth is critical, h_c = (q²/g)^(1/3), and the upstream depth follows the energy
  balance h + q²/(2 g h²) = z_c + 1.5 h_c (analytic, within 1 %), as the plain full re-solve;
* the default scene's breach with an off-centre pile raised to 60 % of the flood depth (breach discharge
  down by 17–28 %; both walls): the breach discharge and the largest speed near the breach within 1 % of
  the plain full re-solve at the same tolerance.
"""
import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import section_discharge
from breachflow.errors import InputError, ParseError
from breachflow.hydro.coarse_resolve import CoarseCorrectedResolver
from breachflow.scenario.config import parse_scenario
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid
from breachflow.swe.solver import SWESolver

G = 9.81


def test_lake_at_rest_with_a_new_mound_stays_at_rest():
    level = 2.0
    dom = uniform_grid(0.0, 40.0, 0.0, 30.0, 1.0, bed=lambda X, Y: 0.02 * X, initial_surface=level)
    solver = SWESolver(tolerance=1e-6, t_max=50.0)
    rest = solver.solve(dom)
    X, Y = np.meshgrid(dom.x, dom.y)
    mound = (X - 20.0) ** 2 + (Y - 15.0) ** 2 < 25.0
    piled = dom.with_raised_bed(mound, 1.5)
    res = CoarseCorrectedResolver(solver)
    ds = res.solve(piled, initial=rest)
    wet = ds.depth.values > 0
    np.testing.assert_allclose((ds.bed_elevation.values + ds.depth.values)[wet], level, atol=1e-10)
    assert np.abs(ds.u.values).max() < 1e-10 and np.abs(ds.v.values).max() < 1e-10
    assert res.last_info["max_level_change"] < 1e-10


Q = 1.53
H_OUT = 0.66
CREST = 10.0


def _hump(top):
    return lambda X, Y: np.where((Y > 8) & (Y < 12), top - 0.05 * (Y - CREST) ** 2 * (top / 0.2), 0.0)


def _channel(top, dy=0.25):
    return uniform_grid(0.0, 4 * dy, dy / 4, dy / 4 + 25.0, dy, bed=_hump(top), initial_surface=H_OUT,
                        boundaries={"south": [BC.inflow(Q)], "north": [BC.water_level(H_OUT)]})


def _upstream_depth(zc, hc):
    """Subcritical root of h + q²/(2 g h²) = z_c + 1.5 h_c (Newton from above)."""
    e = zc + 1.5 * hc
    h = e
    for _ in range(60):
        f = h + Q * Q / (2 * G * h * h) - e
        h -= f / (1.0 - Q * Q / (G * h ** 3))
    return h


@pytest.mark.parametrize("factor", [2, 4])
def test_weir_resolve_reaches_critical_depth_at_the_crest(factor):
    solver = SWESolver(tolerance=1e-6, t_max=2000.0)
    before = solver.solve(_channel(0.2))
    raised = _channel(0.3)
    full = SWESolver(tolerance=1e-6, t_max=2000.0).solve(raised, initial=before)
    res = CoarseCorrectedResolver(SWESolver(tolerance=1e-6, t_max=2000.0), factor=factor)
    ds = res.solve(raised, initial=before)
    assert res.last.history.converged
    hc = (Q * Q / G) ** (1.0 / 3.0)
    y = ds.y.values
    h = ds.depth.values.mean(axis=1)
    q = (ds.depth.values * ds.v.values).mean(axis=1)
    np.testing.assert_allclose(q[(y > 1) & (y < 7.5)], Q, rtol=1e-3)  # steady: the inflow upstream of the hump
    h_crest = np.interp(CREST, y, h)
    assert h_crest == pytest.approx(hc, rel=0.02)
    up = (y > 2) & (y < 6)
    assert h[up].mean() == pytest.approx(_upstream_depth(0.3, hc), rel=0.01)
    h_full = full.depth.values.mean(axis=1)
    assert h[up].mean() == pytest.approx(h_full[up].mean(), rel=2e-3)
    assert h_crest == pytest.approx(np.interp(CREST, y, h_full), rel=5e-3)


SCENE = """
[scenario]
name = "coarse re-solve"
[site]
preset = "demo_breach"
levee_length_each_side = "54 m"
flood_side_extent = "60 m"
protected_side_extent = "48 m"
[hydro]
resolution = "1.5 m"
tolerance = "5e-5 1/s"
resolve = "coarse"
"""


@pytest.fixture(scope="module")
def scene():
    setup = closure_setup(parse_scenario(SCENE))
    return setup, setup.solver.solve(setup.domain)


@pytest.mark.parametrize("wall", ["west", "east"])
def test_coarse_resolve_matches_the_full_resolve_after_an_asymmetric_pile(scene, wall):
    setup, snap = scene
    assert isinstance(setup.solver.region, CoarseCorrectedResolver)
    dom = setup.domain
    X, Y = np.meshgrid(dom.x, dom.y)
    x0, x1 = setup.breach_x
    B = x1 - x0
    a, b = (x0, x0 + 0.4 * B) if wall == "west" else (x1 - 0.3 * B, x1)
    mask = (X > a) & (X < b) & (np.abs(Y - setup.levee_y) < 0.12 * B)
    piled = dom.with_raised_bed(mask, dom.bed.min() + 0.6 * (setup.flood_level - dom.bed.min()))
    near = (np.abs(X) <= B) & (np.abs(Y) <= B)
    full = setup.solver.warm.solve(piled, initial=snap)
    assert setup.solver.warm.last.history.converged
    res = CoarseCorrectedResolver(setup.solver.warm)
    coarse = res.solve(piled, initial=snap)
    assert res.last.history.converged
    q0 = section_discharge(snap, setup.breach_x, setup.levee_y)
    qf = section_discharge(full, setup.breach_x, setup.levee_y)
    qc = section_discharge(coarse, setup.breach_x, setup.levee_y)
    assert qf < 0.85 * q0  # the pile changed the flow a lot
    assert abs(qc / qf - 1.0) < 0.01, (qc, qf)
    sf, sc = np.hypot(full.u.values, full.v.values), np.hypot(coarse.u.values, coarse.v.values)
    assert abs(sc[near].max() / sf[near].max() - 1.0) < 0.01
    assert res.last_info["max_level_change"] > 0.0 and "coarse x2" in coarse.attrs["hydro_resolve"]


def test_coarse_resolve_option_is_checked():
    assert closure_setup(parse_scenario(SCENE.replace('resolution = "1.5 m"', 'resolution = "6 m"'))).solver.region
    with pytest.raises(InputError):
        CoarseCorrectedResolver(SWESolver(), factor=1)
    with pytest.raises(ParseError):
        parse_scenario(SCENE.replace('resolve = "coarse"', 'resolve = "coarser"'))
