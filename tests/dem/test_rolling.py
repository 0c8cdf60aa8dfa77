"""Rolling resistance (elastic–plastic spring–dashpot, Ai et al. 2011 "type C") against the rigid-body
results for a sphere (I = 2/5 m R^2) rolling without slip with a limit moment M_m = mu_r R F_N:

* free rolling on a plane: ``m a = F_t``, ``I a / R = -R F_t - mu_r R m g``  =>  ``a = -(5/7) mu_r g``;
* incline (angle t, gravity tilted): rest iff ``tan t <= mu_r``; otherwise
  ``a = (5/7) g (sin t - mu_r cos t)``;
* horizontal force F at the centre: rest iff ``F <= mu_r m g``; otherwise ``a = (5/7) (F/m - mu_r g)``;
* at rest the two springs carry the load: ``x = F_t / k_S + R^2 F_t / k_r``, ``k_r = 2.25 k_N mu_r^2 R^2``.
"""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, sphere_mass
from breachflow.dem.pair_contacts import ROLLING_STIFFNESS

G = 9.80665
R = 0.5
KN = 1e7
M = float(sphere_mass(R, 2650.0))
MU_R = 0.2


def rock(mu_r=MU_R, friction=1.0):
    return Material(kn=KN, friction=friction, rolling_friction=mu_r, c_cn=2 * 0.3 * math.sqrt(KN * M),
                    c_cs=2 * 0.3 * math.sqrt(KN * M / 3.5))


class Push:
    """A push (N) at the centre of every particle, ramped up linearly over *ramp* s (quasi-static loading:
    no dynamic overshoot, so the rest position is the static one)."""

    def __init__(self, f, ramp=0.0):
        self.f = np.asarray(f, float)
        self.ramp = ramp

    def added_mass(self, state):
        return None

    def accumulate(self, state, pos, vel, omega, t, force, torque):
        force[:] += self.f * (min(t / self.ramp, 1.0) if self.ramp > 0 else 1.0)


def assert_at_rest_at(sim, x_expected):
    """At the elastic rest position, and neither jittering nor creeping."""
    sim.run(4.0)
    x = sim.state.pos[0, 0]
    assert x == pytest.approx(x_expected, rel=1e-6)
    speeds = []
    for _ in range(50):
        sim.step(20)
        speeds.append(np.abs(sim.state.vel[0]).max() + R * np.abs(sim.state.omega[0]).max())
    assert max(speeds) < 1e-8
    assert abs(sim.state.pos[0, 0] - x) < 1e-8


def sphere_on_plane(gravity=(0.0, 0.0, -G), vel=(0.0, 0.0, 0.0), models=(), mu_r=MU_R):
    mat = rock(mu_r)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], gravity=gravity, models=models,
                        sleeping=False)
    fn = -gravity[2] * M
    v = np.asarray(vel, float)
    sim.add_particles([[0.0, 0.0, R - fn / KN]], R, mat, vel=v, omega=(0.0, v[0] / R, 0.0))
    return sim


def velocity_slope(sim, t0, t1):
    sim.run(t0)
    ta, va = sim.t, sim.state.vel[0, 0]
    sim.run(t1 - t0)
    return (sim.state.vel[0, 0] - va) / (sim.t - ta)


def test_rolling_sphere_decelerates_at_five_sevenths_mu_r_g_and_stops():
    v0 = 1.0
    sim = sphere_on_plane(vel=(v0, 0.0, 0.0))
    a = velocity_slope(sim, 0.1, 0.5)
    expected = -5.0 / 7.0 * MU_R * G
    assert a == pytest.approx(expected, rel=5e-4)
    # rolls without slipping, then stops for good at x = v0^2 / (2 |a|) (no reversal, no creep)
    assert sim.state.omega[0, 1] * R == pytest.approx(sim.state.vel[0, 0], rel=1e-3)
    sim.run(3.0)
    x_stop = sim.state.pos[0, 0]
    # rolling stops with the spring at M_m = mu_r R m g; it then unloads, turning the sphere back by
    # M_m / k_r: the rest position is the rigid stopping distance minus that elastic recoil
    recoil = R * MU_R * R * M * G / (ROLLING_STIFFNESS * KN * MU_R**2 * R**2)
    assert x_stop == pytest.approx(v0**2 / (2 * abs(expected)) - recoil, rel=2e-3)
    sim.run(1.0)
    assert abs(sim.state.pos[0, 0] - x_stop) < 1e-8
    assert np.abs(sim.state.vel[0]).max() < 1e-8


def test_free_rolling_without_rolling_friction_keeps_its_speed():
    sim = sphere_on_plane(vel=(1.0, 0.0, 0.0), mu_r=0.0)
    sim.run(1.0)
    assert sim.state.vel[0, 0] == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("ratio", [0.5, 0.9])
def test_sphere_on_gentle_incline_stays_at_the_elastic_rest_position(ratio):
    """tan t = ratio mu_r: the sphere stays; its centre only moves by the elastic deflection of the
    shear and rolling springs, and it does not jitter."""
    theta = math.atan(ratio * MU_R)
    ft = M * G * math.sin(theta)
    # the slope's downhill gravity component is ramped in over 1 s (quasi-static tilting)
    sim = sphere_on_plane(gravity=(0.0, 0.0, -G * math.cos(theta)), models=[Push((ft, 0.0, 0.0), ramp=1.0)])
    kr = ROLLING_STIFFNESS * KN * MU_R**2 * R**2
    assert_at_rest_at(sim, ft / KN + R**2 * ft / kr)


def test_sphere_on_steep_incline_rolls_with_the_predicted_acceleration():
    theta = math.atan(2.0 * MU_R)
    sim = sphere_on_plane(gravity=(G * math.sin(theta), 0.0, -G * math.cos(theta)))
    a = velocity_slope(sim, 0.1, 0.6)
    assert a == pytest.approx(5.0 / 7.0 * G * (math.sin(theta) - MU_R * math.cos(theta)), rel=5e-4)
    assert sim.state.omega[0, 1] * R == pytest.approx(sim.state.vel[0, 0], rel=1e-3)


def test_horizontal_push_below_the_rolling_threshold_is_held_above_it_rolls():
    threshold = MU_R * M * G
    kr = ROLLING_STIFFNESS * KN * MU_R**2 * R**2
    f = 0.7 * threshold
    low = sphere_on_plane(models=[Push((f, 0.0, 0.0), ramp=1.0)])
    assert_at_rest_at(low, f / KN + R**2 * f / kr)
    f = 1.5 * threshold
    high = sphere_on_plane(models=[Push((f, 0.0, 0.0))])
    a = velocity_slope(high, 0.1, 0.6)
    assert a == pytest.approx(5.0 / 7.0 * (f / M - MU_R * G), rel=5e-4)


def test_rolling_friction_on_a_height_field_matches_the_plane():
    from breachflow.dem import HeightField

    x = np.linspace(-5, 5, 11)
    y = np.linspace(-5, 5, 11)
    mat = rock()
    sim = DemSimulation(boundaries=[HeightField(x, y, np.zeros((11, 11)), mat)], sleeping=False)
    sim.add_particles([[-2.0, 0.0, R - M * G / KN]], R, mat, vel=(1.0, 0, 0), omega=(0, 1.0 / R, 0))
    a = velocity_slope(sim, 0.1, 0.5)
    assert a == pytest.approx(-5.0 / 7.0 * MU_R * G, rel=5e-4)


def test_pair_rolling_moment_is_an_elastic_plastic_spring_on_the_relative_spin():
    """Two touching spheres (radii 0.5, 0.3; R_r = r_i r_j / (r_i + r_j)) with relative spin w_i - w_j
    about an axis tangent to the contact (+ a twist about the normal, which must be ignored): the moment
    on i grows by k_r |w_t| dt per step opposite to w_t, j gets the opposite, and it saturates at
    mu_r R_r F_N; reversing the spin unloads it elastically."""
    from breachflow.dem import pair_contacts as contacts

    ri, rj, mu_r, kn, dt = 0.5, 0.3, 0.25, 1e7, 1e-5
    overlap = 1e-3
    pos = np.array([[0.0, 0.0, 0.0], [ri + rj - overlap, 0.0, 0.0]])
    omega = np.array([[0.0, 0.4, 3.0], [0.0, -0.1, 0.0]])  # w_t = (0, 0.5, 3.0) - normal part (x) = (0, .5, 3)
    omega[:, 0] = [7.0, 2.0]  # twist about the normal (x): ignored
    vel = np.zeros((2, 3))
    props = np.tile(np.array([[0.0, 1.0, kn, kn, 0.0, 0.0, 0.0, mu_r]]), (2, 1))
    radius = np.array([ri, rj])
    mass = sphere_mass(radius, 2650.0)
    inertia = 0.4 * mass * radius**2
    hist, rhist = np.zeros((1, 3)), np.zeros((1, 3))
    r_eff = ri * rj / (ri + rj)
    kr = ROLLING_STIFFNESS * kn * mu_r**2 * r_eff**2
    m_max = mu_r * r_eff * kn * overlap
    wt = np.array([0.0, 0.5, 3.0])

    def step(om):
        f, t = np.zeros((2, 3)), np.zeros((2, 3))
        # the driver's kernel with its argument types; the same velocities for dashpots and shear increments
        contacts.pair_forces_interval(np.array([0]), np.array([1]), hist, rhist, np.zeros(1, bool), pos, vel, om,
                                      vel, om, False, radius, mass, inertia, props, np.ones(2, bool),
                                      np.ones(2, bool), np.array([0, 0, 0, 1.0, 1.0, 1.0, 1.0, 1.0]),
                                      np.zeros(2, np.int64), dt, 1e9, f, t, np.zeros(2, bool), np.zeros(2, np.int64),
                                      np.zeros(1, np.int64), 0.0, 0.0, 0)
        return t

    step(omega)
    np.testing.assert_allclose(rhist[0], -kr * wt * dt, rtol=1e-12)
    n_full = int(m_max / (kr * np.linalg.norm(wt) * dt)) + 5
    for _ in range(n_full):
        t = step(omega)
    np.testing.assert_allclose(rhist[0], -m_max * wt / np.linalg.norm(wt), rtol=1e-12)
    # fully mobilised: no dashpot, the moment is the limit moment; the shear torque has no x part and
    # acts in the same sense on both, so the rolling moment is (t_i - t_j) / 2 along the tangent
    shear_i = t[0] - rhist[0]
    shear_j = t[1] + rhist[0]
    np.testing.assert_allclose(shear_i / ri, shear_j / rj, atol=1e-9 * m_max)
    # reversing the relative spin unloads the spring at the elastic rate
    before = rhist[0].copy()
    step(omega[::-1].copy())
    np.testing.assert_allclose(rhist[0], before + kr * wt * dt, rtol=1e-9)


def test_rolling_resistance_never_adds_energy():
    """Spheres with rolling friction dropped with spin onto a plane and each other: kinetic + potential
    + spring energies (normal, shear, rolling ``|M_k|^2 / (2 k_r)``) never increase."""
    mat = rock(0.3, friction=0.5)
    plane = Plane((0, 0, 0), (0, 0, 1), mat)
    sim = DemSimulation(boundaries=[plane], sleeping=False)
    rng = np.random.default_rng(7)
    pos = np.array([[0.0, 0.0, 0.6], [0.3, 0.1, 1.8], [-0.4, -0.2, 3.0], [1.2, 0.0, 0.6]])
    sim.add_particles(pos, R, mat, vel=rng.normal(0, 1.0, (4, 3)), omega=rng.normal(0, 4.0, (4, 3)))
    s = sim.state

    def energy():
        e = s.kinetic_energy() + float(np.sum(s.mass * G * s.pos[:, 2]))
        for i in range(s.n):
            ov = R - s.pos[i, 2]
            if ov > 0:
                e += 0.5 * KN * ov**2
            for j in range(i + 1, s.n):
                ov = 2 * R - np.linalg.norm(s.pos[j] - s.pos[i])
                if ov > 0:
                    e += 0.5 * KN * ov**2
        kr_wall = ROLLING_STIFFNESS * KN * 0.3**2 * R**2
        kr_pair = ROLLING_STIFFNESS * KN * 0.3**2 * (R / 2) ** 2
        e += 0.5 * KN * np.sum(plane.hist[: s.n] ** 2) + np.sum(plane.rhist[: s.n] ** 2) / (2 * kr_wall)
        e += 0.5 * KN * np.sum(sim.pairs.hist**2) + np.sum(sim.pairs.rhist**2) / (2 * kr_pair)
        return e

    e0 = e_prev = energy()
    for _ in range(300):
        sim.step(10)
        e = energy()
        assert e <= e_prev + 1e-6 * abs(e0)
        e_prev = e
    assert e < e0
