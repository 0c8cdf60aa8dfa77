"""Absorbing level boundaries and warm starts from a snapshot on another grid.

References: linear long-wave theory — a right-going simple wave (u - 2c uniform) reaching a boundary
held at a fixed level is reflected with coefficient -1 (the level is a node of the surface), while a
boundary that takes the incoming Riemann invariant from outer water at the level lets it pass
(coefficient O(amplitude, duration / relaxation time)). In a steady state both impose the same stage:
uniform Manning flow q = h^(5/3) S^(1/2) / n at the prescribed depth. Grid sequencing: the wet-weighted
bilinear transfer maps a lake at rest to a lake at rest and reproduces fields linear in x and y exactly.
"""
import math

import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

from ._util import channel

H0, AMP, G = 5.0, 0.02, 9.81


def _right_going_wave(east):
    """Channel 0..1000 m at depth H0 with a Gaussian right-going wave at x = 600 m; wall at the west end."""
    dom = channel(1000, 1000.0, lambda X, Y: H0 + AMP * np.exp(-(((X - 600.0) / 40.0) ** 2)), west=BC.wall(), east=east)
    sim = SWESimulation(dom, SWEOptions(order=2))
    c0 = math.sqrt(G * H0)
    sim.hu[2:-2, 2:-2] = sim.depth * 2.0 * (np.sqrt(G * sim.depth) - c0)   # simple wave: u - 2c = -2 c0
    assert (sim.depth - H0).max() == pytest.approx(AMP, rel=1e-3)
    return sim, c0


@pytest.mark.parametrize("absorbing", [None, 600.0])
def test_a_wave_is_reflected_by_a_fixed_level_and_leaves_through_an_absorbing_one(absorbing):
    sim, c0 = _right_going_wave(BC.water_level(H0, absorbing=absorbing))
    # the crest reaches the east end after 400 m / c0; a reflection is back near x = 800 m after 600 m / c0
    sim.advance_to(600.0 / c0)
    eta = (sim.depth[0] - H0)[sim.domain.x < 950.0]
    if absorbing is None:
        assert eta.min() < -0.8 * AMP        # coefficient -1: a trough of about the incident amplitude
    else:
        assert np.abs(eta).max() < 0.03 * AMP


def test_absorbing_and_exact_levels_give_the_same_steady_uniform_flow():
    n, slope, depth = 0.03, 1e-3, 1.0
    bed = lambda X, Y: 1.0 - slope * X
    q_manning = depth ** (5.0 / 3.0) * math.sqrt(slope) / n
    results = {}
    for absorbing in (None, 20.0):
        dom = channel(100, 200.0, lambda X, Y: bed(X, Y) + 0.5, bed=bed, manning=n,
                      west=BC.water_level(bed(1.0, 0) + depth, absorbing=absorbing),
                      east=BC.water_level(bed(199.0, 0) + depth))
        sim = SWESimulation(dom).advance_to(900.0)
        q = sim.discharge[0][0]
        assert q[50] == pytest.approx(q_manning, rel=0.01)
        np.testing.assert_allclose(sim.depth[0], depth, rtol=0.005)
        results[absorbing] = (sim.depth[0].copy(), q.copy())
    np.testing.assert_allclose(results[20.0][0], results[None][0], rtol=1e-3)
    np.testing.assert_allclose(results[20.0][1], results[None][1], rtol=5e-3)


def test_absorbing_level_keeps_a_lake_at_rest():
    bed = lambda X, Y: 0.2 * np.sin(X / 3.0)
    dom = uniform_grid(0, 30, 0, 3, 0.5, bed=bed, initial_surface=2.0,
                       boundaries={"west": [BC.water_level(2.0, absorbing=10.0)],
                                   "east": [BC.water_level(2.0, absorbing=10.0)]})
    sim = SWESimulation(dom).advance_to(20.0)
    u, v = sim.velocity()
    assert np.abs(u).max() < 1e-12 and np.abs(v).max() < 1e-12


@pytest.mark.parametrize("kwargs", [dict(kind="level", level=1.0, absorbing=0.0),
                                    dict(kind="outflow", absorbing=5.0)])
def test_absorbing_needs_a_positive_time_on_a_level_boundary(kwargs):
    with pytest.raises(InputError, match="absorbing"):
        BC(**kwargs)


def _sloped_lake(dx):
    bed = lambda X, Y: 0.1 * X + 0.3 * np.cos(Y)       # shore line crosses the grid: wet and dry cells
    return uniform_grid(0, 20, 0, 10, dx, bed=bed, initial_surface=1.2,
                        boundaries={s: [BC.wall()] for s in ("west", "east", "south", "north")})


def test_warm_start_from_a_coarser_grid_keeps_a_lake_at_rest():
    coarse = SWESimulation(_sloped_lake(1.0)).snapshot(derived=False)
    fine_dom = _sloped_lake(0.25)
    fine = SWESimulation(fine_dom, initial=coarse)
    wet = fine.depth > 0
    assert wet.any() and (~wet).any()
    np.testing.assert_allclose((fine.depth + fine_dom.bed)[wet], 1.2, atol=1e-12, rtol=0)
    fine.advance_to(2.0)
    u, v = fine.velocity()
    assert np.abs(u).max() < 1e-12 and np.abs(v).max() < 1e-12


def test_warm_start_from_another_grid_transfers_linear_fields_exactly():
    flat = lambda dx: uniform_grid(0, 20, 0, 10, dx, bed=0.0, initial_surface=lambda X, Y: 2.0 + 0.01 * X - 0.02 * Y)
    coarse_sim = SWESimulation(flat(1.0))
    X, Y = np.meshgrid(coarse_sim.domain.x, coarse_sim.domain.y)
    coarse_sim.hu[2:-2, 2:-2] = coarse_sim.depth * (0.5 + 0.03 * X)
    coarse_sim.hv[2:-2, 2:-2] = coarse_sim.depth * (-0.2 + 0.01 * Y)
    snap = coarse_sim.snapshot(derived=False)
    fine = SWESimulation(flat(0.5), initial=snap)
    Xf, Yf = np.meshgrid(fine.domain.x, fine.domain.y)
    np.testing.assert_allclose(fine.depth, 2.0 + 0.01 * Xf - 0.02 * Yf, rtol=0, atol=1e-12)
    u, v = fine.velocity()
    np.testing.assert_allclose(u, 0.5 + 0.03 * Xf, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v, -0.2 + 0.01 * Yf, rtol=0, atol=1e-12)


def test_warm_start_from_a_mesh_snapshot_on_another_grid_is_a_clear_error():
    snap = SWESimulation(_sloped_lake(1.0)).snapshot(derived=False).drop_vars("bed_elevation")
    with pytest.raises(InputError, match="bed_elevation"):
        SWESimulation(_sloped_lake(0.5), initial=snap)
