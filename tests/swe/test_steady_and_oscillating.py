"""Steady flows over a bump (subcritical, transcritical), MacDonald-type flow with Manning friction
(SWASHES case 1 2 1 2), and Thacker's planar surface oscillating in a paraboloid (moving shoreline, 2-D)."""
import numpy as np
import pytest

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

from .analytic import G, bernoulli_depth, bump_bed, swashes, swashes_parameters, thacker_period, thacker_planar
from ._util import channel, observed_orders


def bump_case(kind, n):
    """SWASHES 1D bump cases (L = 25 m): subcritical q = 4.42 m²/s, h_out = 2 m;
    transcritical q = 1.53 m²/s, h_out = 0.66 m (imposed while the outflow is subcritical)."""
    q, h_out = (4.42, 2.0) if kind == "subcritical" else (1.53, 0.66)
    dom = channel(n, 25.0, h_out, bed=lambda X, Y: bump_bed(X), west=BC.inflow(q), east=BC.water_level(h_out))
    sim = SWESimulation(dom)
    hist = sim.run_to_steady(tolerance=1e-9, t_max=3000.0)
    x = dom.x
    z = bump_bed(x)
    if kind == "subcritical":
        ref = bernoulli_depth(z, q, h_out + q * q / (2 * G * h_out * h_out), "sub")
    else:  # critical depth at the crest fixes the head
        hc = (q * q / G) ** (1 / 3)
        head = 0.2 + hc + q * q / (2 * G * hc * hc)
        ref = np.where(x < 10.0, bernoulli_depth(z, q, head, "sub"), bernoulli_depth(z, q, head, "super"))
    return sim, hist, q, ref


@pytest.mark.parametrize("kind, choice", [("subcritical", 1), ("transcritical", 2)])
def test_steady_flow_over_a_bump(kind, choice):
    errs = []
    for n in (100, 200):
        sim, hist, q, ref = bump_case(kind, n)
        assert hist.converged
        qx = sim.discharge[0][0]
        # discharge uniform at steady state
        assert np.abs(qx - q).max() < 0.01 * q
        err = np.abs(sim.depth[0] - ref)
        assert err.mean() < 0.002 * ref.mean()
        errs.append(err.mean())
        # the SWASHES program gives the same reference
        table = swashes(1, 1, 1, choice, n)
        np.testing.assert_allclose(table[:, 1], ref, rtol=1e-5)
    assert errs[1] < errs[0]
    # convergence history is recorded and decreasing overall
    assert hist.depth_rate[-1] < hist.depth_rate[0]


def test_macdonald_manning_steady_flow_against_swashes():
    n = 200
    text = swashes_parameters(1, 2, 1, 2, n)
    assert "Manning's friction coefficient: 0.033" in text and "Imposed discharge on the left boundary: 2 m^2/s" in text
    h_right = float(text.split("Imposed water height on the right boundary:")[1].split()[0])
    table = swashes(1, 2, 1, 2, n)
    x, h_ref, z = table[:, 0], table[:, 1], table[:, 3]
    dom = uniform_grid(0, 1000, 0, 1, 1000 / n, dy=1.0, bed=z[None, :], manning=0.033, initial_surface=z[None, :],
                       boundaries={"west": [BC.inflow(2.0)], "east": [BC.water_level(h_right + z[-1])]})
    np.testing.assert_allclose(dom.x, x)
    sim = SWESimulation(dom)
    hist = sim.run_to_steady(tolerance=1e-9, t_max=10000.0)
    assert hist.converged
    q = sim.discharge[0][0]
    # the inlet cell carries the boundary layer of the imposed discharge; the rest is uniform
    assert np.abs(q[1:] - 2.0).max() < 0.005 * 2.0
    assert np.abs(sim.depth[0] - h_ref).mean() < 0.005 * h_ref.mean()
    assert np.abs(sim.depth[0, 1:] - h_ref[1:]).max() < 0.05 * h_ref.min()


def thacker_run(n, periods=1.0, order=2):
    L = 4.0
    dom = uniform_grid(0, L, 0, L, L / n, bed=lambda X, Y: thacker_planar(X, Y, 0.0)[3])
    X, Y = np.meshgrid(dom.x, dom.y)
    h0, u0, v0, _ = thacker_planar(X, Y, 0.0)
    sim = SWESimulation(dom, SWEOptions(order=order), initial=(h0, h0 * u0, h0 * v0))
    v_start = sim.volume()
    T = periods * thacker_period()
    sim.advance_to(T)
    h_ref = thacker_planar(X, Y, T)[0]
    err = float(np.abs(sim.depth - h_ref).sum() * dom.dx * dom.dy)
    return err, err / float(h_ref.sum() * dom.dx * dom.dy), sim, v_start


def test_thacker_planar_parabolic_bowl_over_one_period():
    # the formula used here reproduces the SWASHES 2-D solution (case 2 1 1 2, t = 3 periods)
    table = swashes(2, 1, 1, 2, 40, 40)
    h_sw = thacker_planar(table[:, 0], table[:, 1], 3 * thacker_period())[0]
    np.testing.assert_allclose(table[:, 2], h_sw, atol=1e-6)
    errs = []
    for n in (40, 80):
        err, rel, sim, v0 = thacker_run(n)
        errs.append(err)
        assert abs(sim.volume() - v0) < 1e-13 * v0
        assert sim.depth.min() >= 0
    print(f"\nThacker L1 after one period: N=40: {errs[0]:.3e}, N=80: {errs[1]:.3e} m³, order {observed_orders(errs)[0]:.2f}")
    assert rel < 0.05
    assert observed_orders(errs)[0] > 1.0


@pytest.mark.slow
def test_thacker_refinement_and_three_periods():
    errs = [thacker_run(n, periods=3.0)[0] for n in (50, 100, 200)]
    print("\nThacker, 3 periods:", errs, observed_orders(errs))
    assert np.all(observed_orders(errs) > 1.0)
