"""Impact-level verification of the contact law (docs/theory.md, *DEM contact*), in the spirit of Chung & Ooi (2011).

All expectations are analytic: the linear spring–dashpot restitution ``e = exp(-zeta pi/sqrt(1-zeta^2))``
and contact duration ``pi / (omega sqrt(1 - zeta^2))``; rigid-body Coulomb impulses for gross sliding;
the tangential spring–mass oscillation for sticking contacts.
"""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, sphere_mass

R, RHO, K = 0.5, 2650.0, 1.0e7
M = float(sphere_mass(R, RHO))


def analytic(zeta, m_eff, k=K):
    w0 = math.sqrt(k / m_eff)
    return math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), math.pi / (w0 * math.sqrt(1 - zeta**2))


def normal_impact(integrator, zeta, steps_per_contact, pair):
    m_eff = M / 2 if pair else M
    mat = Material(density=RHO, kn=K, ks=K, friction=0.5, c_cn=2 * zeta * math.sqrt(K * m_eff))
    e_exact, tc = analytic(zeta, m_eff)
    dt = tc / steps_per_contact
    if pair:
        sim = DemSimulation(gravity=(0, 0, 0), integrator=integrator, dt=dt, sleeping=False)
        sim.add_particles([[0, 0, 0], [2 * R + 1e-3, 0, 0]], R, mat, vel=[[1, 0, 0], [-1, 0, 0]])
        overlap = lambda: 2 * R - (sim.state.pos[1, 0] - sim.state.pos[0, 0])
        approach = lambda: sim.state.vel[0, 0] - sim.state.vel[1, 0]
    else:
        sim = DemSimulation(gravity=(0, 0, 0), integrator=integrator, dt=dt, sleeping=False,
                            boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)])
        sim.add_particles([[0, 0, R + 1e-3]], R, mat, vel=[[0, 0, -1]])
        overlap = lambda: R - sim.state.pos[0, 2]
        approach = lambda: -sim.state.vel[0, 2]
    v_in = approach()
    t0 = t1 = None
    prev, t_prev = overlap(), sim.t
    for _ in range(20 * steps_per_contact):
        sim.step()
        d = overlap()
        if t0 is None and d > 0:
            t0 = t_prev + dt * (-prev) / (d - prev)  # linear interpolation of the sign change
        elif t0 is not None and d <= 0:
            t1 = t_prev + dt * (-prev) / (d - prev)
            break
        prev, t_prev = d, sim.t
    assert t1 is not None, "contact never ended"
    sim.step(3)
    e = -approach() / v_in
    return (e - e_exact) / e_exact, (t1 - t0 - tc) / tc


@pytest.mark.parametrize("pair", [False, True], ids=["wall", "sphere-sphere"])
@pytest.mark.parametrize("zeta", [0.0, 0.1, 0.3])
@pytest.mark.parametrize("integrator,steps", [("predicted_verlet", 50), ("velocity_verlet", 1000)])
def test_normal_restitution_and_duration(integrator, steps, zeta, pair):
    de, dtc = normal_impact(integrator, zeta, steps, pair)
    assert abs(de) < 0.005
    assert abs(dtc) < 0.005


def test_report_scheme_restitution_converges_first_order():
    """The report's scheme (Fig 4.3) integrates v(t+1) = v(t) + a dt explicitly: first order in dt."""
    errs = [normal_impact("report", 0.1, n, False) for n in (100, 200, 400)]
    de = [abs(e[0]) for e in errs]
    assert 1.6 < de[0] / de[1] < 2.4 and 1.6 < de[1] / de[2] < 2.4
    de_fine, dtc_fine = normal_impact("report", 0.1, 2000, False)
    assert abs(de_fine) < 0.005 and abs(dtc_fine) < 0.005


def test_predicted_verlet_beats_velocity_verlet_on_dashpots():
    coarse = 20
    assert abs(normal_impact("predicted_verlet", 0.3, coarse, False)[0]) < 0.5 * abs(
        normal_impact("velocity_verlet", 0.3, coarse, False)[0])


def oblique_wall_impact(vn, vt, friction, adhesion, ks=K, steps_per_contact=400):
    mat = Material(density=RHO, kn=K, ks=ks, friction=friction, adhesion=adhesion)
    tc = math.pi * math.sqrt(M / K)
    sim = DemSimulation(gravity=(0, 0, 0), dt=tc / steps_per_contact, sleeping=False,
                        boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)])
    sim.add_particles([[0, 0, R + 1e-9]], R, mat, vel=[[vt, 0, -vn]])
    for _ in range(4 * steps_per_contact):
        sim.step()
        if sim.state.pos[0, 2] > R + 1e-6 and sim.state.vel[0, 2] > 0:
            break
    return sim.state.vel[0].copy(), sim.state.omega[0].copy()


def test_oblique_gross_sliding_matches_coulomb_impulse():
    """Sliding throughout the contact (v_t >= (7 + k_N/k_S) mu v_n): elastic normal impulse 2 m v_n,
    tangential impulse mu * 2 m v_n, so v_t' = v_t - 2 mu v_n and w' = 5 mu v_n / r (about +y)."""
    vn, vt, mu = 1.0, 3.0, 0.2
    assert vt >= (7 + 1) * mu * vn
    v, w = oblique_wall_impact(vn, vt, mu, 0.0)
    assert v[2] == pytest.approx(vn, rel=2e-3)
    assert v[0] == pytest.approx(vt - 2 * mu * vn, rel=2e-3)
    assert w[1] == pytest.approx(5 * mu * vn / R, rel=2e-3)
    assert abs(v[1]) < 1e-12 and abs(w[0]) < 1e-12 and abs(w[2]) < 1e-12


def test_oblique_sticking_is_a_tangential_oscillator():
    """Contact held in stick (large adhesion, mu = 0): the contact-point slip velocity oscillates with
    omega_t = sqrt(k_S (1/m + r^2/I)) during the normal contact time T = pi sqrt(m/k_N), so
    J_t = m_t v_s0 (1 - cos omega_t T) with m_t = 1/(1/m + r^2/I) = 2m/7."""
    vn, vt = 1.0, 0.3
    ks = 0.5 * K
    v, w = oblique_wall_impact(vn, vt, 0.0, adhesion=1e9, ks=ks)
    m_t = 2 * M / 7
    omega_t = math.sqrt(ks / m_t)
    T = math.pi * math.sqrt(M / K)
    J = m_t * vt * (1 - math.cos(omega_t * T))
    assert v[0] == pytest.approx(vt - J / M, rel=2e-3)
    assert w[1] == pytest.approx(R * J / (0.4 * M * R * R), rel=2e-3)
    slip = v[0] - w[1] * R
    assert slip == pytest.approx(vt * math.cos(omega_t * T), rel=5e-3)


def test_oblique_impulse_ratio_never_exceeds_friction():
    """Across incidence angles the tangential impulse never exceeds mu times the normal impulse
    (Coulomb), and equals it in the gross-sliding regime."""
    mu, vn = 0.3, 1.0
    ratios = []
    for vt in (0.05, 0.2, 0.5, 1.0, 2.0, 4.0):
        v, w = oblique_wall_impact(vn, vt, mu, 0.0, steps_per_contact=200)
        ratios.append((vt - v[0]) / (v[2] + vn))
    assert max(ratios) <= mu * (1 + 1e-3)
    assert ratios[-1] == pytest.approx(mu, rel=3e-3)
    assert ratios[0] < mu  # small angles: not sliding throughout


def test_rolling_sphere_keeps_rolling_without_loss():
    """A sphere rolling without slip (w r = v) on a frictional plane under gravity feels no tangential
    force: velocity and spin stay constant."""
    mat = Material(density=RHO, kn=K, friction=0.5, c_cn=2 * 0.3 * math.sqrt(K * M))
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], sleeping=False)
    z0 = R - M * 9.80665 / K
    sim.add_particles([[0, 0, z0]], R, mat, vel=[[1.0, 0, 0]], omega=[[0, 1.0 / R, 0]])
    sim.run(1.0)
    assert sim.state.vel[0, 0] == pytest.approx(1.0, rel=1e-6)
    assert sim.state.omega[0, 1] * R == pytest.approx(1.0, rel=1e-6)
    assert sim.state.pos[0, 0] == pytest.approx(sim.t, rel=1e-3)
