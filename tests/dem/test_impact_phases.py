"""Impacts at the default time step must not depend on where in a step the contact begins (issue 12).

Sphere–plane, sphere–sphere and sphere–terrain (height field) impacts at 8 onset phases, damping ratios
0.1 and 0.3, against the analytic linear spring–dashpot restitution and duration (docs/theory.md, *DEM contact*); oblique
impacts of Chung & Ooi (2011) test 4 in the sticking and gross-sliding limits against their closed forms;
convergence orders measured on errors averaged over onset and release phases. Cases: impact_cases.py.
"""
import math

import numpy as np
import pytest

from .impact_cases import (K, M, MU_CO, PHASES, chung_ooi_4, chung_ooi_4_limits, linear_restitution,
                          normal_impact, phase_averaged_error)


@pytest.mark.parametrize("zeta", [0.1, 0.3])
@pytest.mark.parametrize("kind", ["plane", "pair", "terrain"])
def test_restitution_at_the_default_step_for_every_onset_phase(kind, zeta):
    res = np.array([normal_impact(kind, zeta, p) for p in PHASES])
    assert 10 < res[0, 2] < 25  # the default step: 10-25 steps per contact, not a whole number
    assert abs(res[0, 2] - round(res[0, 2])) > 0.05
    assert np.max(np.abs(res[:, 0])) < 0.005, res[:, 0]
    assert np.max(np.abs(res[:, 1])) < 0.005, res[:, 1]


@pytest.mark.parametrize("kind", ["plane", "pair"])
@pytest.mark.parametrize("steps", [11.3, 49.8, 50.6])
def test_restitution_at_non_integer_steps_per_contact(kind, steps):
    zeta = 0.3
    m_eff = M / 2 if kind == "pair" else M
    tc = linear_restitution(zeta)[1] / math.sqrt(K / m_eff)
    errs = [normal_impact(kind, zeta, p, dt=tc / steps)[0] for p in PHASES]
    assert np.max(np.abs(errs)) < 0.005, errs


@pytest.mark.parametrize("theta", [5, 10, 15, 45, 60, 75])
def test_chung_ooi_4_sticking_and_sliding_limits_at_the_default_step(theta):
    """Sticking (tan theta <= 3.5 mu): e_t = 3/7 for k_S/k_N = 2/7; gross sliding (tan theta >= 7 mu):
    e_t = 1 - 2 mu / tan theta; spin and rebound angle likewise (impact_cases.chung_ooi_4_limits)."""
    assert math.tan(math.radians(theta)) <= 3.5 * MU_CO or math.tan(math.radians(theta)) >= 7 * MU_CO
    exact = np.array(chung_ooi_4_limits(theta))
    if theta <= 15:
        assert exact[0] == pytest.approx(3 / 7)
    for p in PHASES:
        got = np.array(chung_ooi_4(theta, p))
        np.testing.assert_allclose(got, exact, rtol=0.01)


def _order(integrator, zeta, levels=(10, 20, 40)):
    e = [phase_averaged_error("plane", zeta, n, integrator) for n in levels]
    return [math.log2(e[k] / e[k + 1]) for k in range(len(e) - 1)], e


def test_predicted_verlet_restitution_converges_at_second_order_phase_averaged():
    orders, errs = _order("predicted_verlet", 0.3)
    assert min(orders) > 1.8, (orders, errs)
    assert errs[0] < 0.005  # ~10 steps per contact already within 0.5 %


def test_velocity_verlet_restitution_converges_at_first_order_phase_averaged():
    """The half-step velocity in the dashpot lags by a dt/2: first order (the onset fix does not change that)."""
    orders, errs = _order("velocity_verlet", 0.3)
    assert all(0.7 < o < 1.3 for o in orders), (orders, errs)


@pytest.mark.parametrize("zeta", [0.7, 2.0])
def test_heavily_damped_contacts_stay_stable_at_the_default_step(zeta):
    """The force-trend predictor narrows predicted_verlet's stability range; the default step
    (SAFETY x the stable limit) must stay inside it even for over-critical normal contact damping (the
    one the stable limit accounts for, timestep.stable_dt)."""
    from breachflow.dem import DemSimulation, Material, Plane

    c = 2 * zeta * math.sqrt(K * M / 2)
    mat = Material(density=2650.0, kn=K, ks=K, friction=0.5, c_cn=c)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], sleeping=False)
    sim.add_particles([[0, 0, 0.3], [0.05, 0, 0.85], [0.5, 0, 0.25]], 0.25, mat, vel=[[0, 0, -2], [0, 0, 0], [-1, 0, 0]])
    e0 = sim.state.kinetic_energy()
    sim.run(2.0)
    assert np.all(np.isfinite(sim.state.vel))
    assert np.all(np.abs(sim.state.vel[:, 2]) < 0.05)  # resting on the floor (rolling freely) ...
    assert sim.state.kinetic_energy() < 0.5 * e0  # ... having lost energy instead of blowing up
    assert np.all(sim.state.pos[:, 2] > 0.2) and np.all(sim.state.pos[:, 2] < 0.8)


@pytest.mark.parametrize("zeta", [0.3, 0.7, 1.5])
def test_persistent_damped_contacts_stay_stable_at_the_default_step(zeta):
    """A column of two spheres resting on a floor (contacts that last): the default step settles it."""
    from breachflow.dem import DemSimulation, Material, Plane

    c = 2 * zeta * math.sqrt(K * M / 2)
    mat = Material(density=2650.0, kn=K, ks=0.2 * K, friction=0.5, c_cn=c)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], sleeping=False)
    R = 0.25
    sim.add_particles([[0, 0, R], [0, 0, 3 * R + 0.01]], R, mat)
    sim.run(2.0)
    assert np.all(np.isfinite(sim.state.vel)) and np.max(np.abs(sim.state.vel)) < 1e-3
    # at rest under the weights: floor overlap 2 m g / k, pair overlap m g / k
    g = 9.80665
    assert sim.state.pos[0, 2] == pytest.approx(R - 2 * M * g / K, abs=1e-6)
    assert sim.state.pos[1, 2] - sim.state.pos[0, 2] == pytest.approx(2 * R - M * g / K, abs=1e-6)


