"""Lake at rest over bumps with wet/dry areas, and mass conservation with closed boundaries."""
import numpy as np
import pytest

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid


def bumpy_bed(X, Y):
    return (0.6 * np.exp(-((X - 3) ** 2 + (Y - 2) ** 2))            # submerged bump
            + 1.4 * np.exp(-((X - 7) ** 2 + (Y - 3) ** 2) / 0.5)      # emerged island (dry top)
            + 0.05 * np.sin(3 * X) * np.cos(2 * Y)                    # ripples
            + np.where(X > 9.0, 2.0 * (X - 9.0), 0.0))                # dry beach at the east end


@pytest.mark.parametrize("order, riemann, limiter", [(1, "hll", "minmod"), (2, "hllc", "minmod"), (2, "hll", "mc"), (2, "hllc", "vanleer")])
def test_lake_at_rest_stays_at_rest_over_wet_and_dry_bumps(order, riemann, limiter):
    level = 1.0
    obstacle = lambda X, Y: (np.abs(X - 5.0) < 0.3) & (np.abs(Y - 1.0) < 0.6)
    dom = uniform_grid(0, 10, 0, 5, 0.1, bed=bumpy_bed, initial_surface=level, obstacle=obstacle,
                       boundaries={"west": [BC.water_level(level)], "south": [BC.outflow()],
                                   "north": [BC.wall()], "east": [BC.wall()]})
    dry0 = dom.bed >= level
    assert dry0.any() and (~dry0).any()
    sim = SWESimulation(dom, SWEOptions(order=order, riemann=riemann, limiter=limiter))
    sim.advance_to(5.0)
    u, v = sim.velocity()
    assert np.abs(u).max() < 1e-12 and np.abs(v).max() < 1e-12
    wet = ~dry0 & ~dom.obstacle
    np.testing.assert_allclose((sim.depth + dom.bed)[wet], level, atol=1e-12, rtol=0)
    assert np.all(sim.depth[dry0] == 0.0)
    assert sim.steps > 50


def test_mass_is_conserved_to_round_off_with_closed_boundaries():
    rng = np.random.default_rng(7)
    bed = lambda X, Y: bumpy_bed(X, Y) + 0.02 * rng.standard_normal(X.shape)
    surface = lambda X, Y: np.where(X < 4.0, 1.5, 0.7)              # dam break over wet and dry ground
    obstacle = lambda X, Y: (np.abs(X - 6.0) < 0.25) & (Y < 3.0)
    dom = uniform_grid(0, 10, 0, 5, 0.1, bed=bed, initial_surface=surface, obstacle=obstacle, manning=0.03)
    for order in (1, 2):
        sim = SWESimulation(dom, SWEOptions(order=order))
        v0 = sim.volume()
        sim.advance_to(4.0)
        assert sim.steps > 100
        assert abs(sim.volume() - v0) / v0 < 1e-13
        assert sim.stats[0] == 0.0  # no depth was clipped
        assert sim.depth.min() >= 0.0
        u, v = sim.velocity()
        assert np.abs(u).max() > 0.1  # the flow really moved
