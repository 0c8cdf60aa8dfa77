"""Stress cases: extreme stiffness ratios, 10:1 sizes, overlapping spawns, particles leaving the domain,
bad input, time-step refusal, terrain height field, moving boundaries, 2-D mode."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, HeightField, Material, Plane, sphere_mass, stable_dt
from breachflow.errors import InputError

G = 9.80665


def test_user_dt_above_the_stable_limit_is_refused_with_the_limit():
    mat = Material(kn=1e9)
    limit = stable_dt([sphere_mass(0.1, 2650.0)], [1e9])
    with pytest.raises(InputError, match=f"{limit:.6g}"):
        DemSimulation(dt=1.01 * limit).add_particles([[0, 0, 1]], 0.1, mat)
    DemSimulation(dt=0.99 * limit).add_particles([[0, 0, 1]], 0.1, mat)  # accepted


def test_stable_limit_is_the_linear_oscillator_bound():
    m, k = 3.0, 1200.0
    # two lightest particles in contact: m_eff = m/2, omega = sqrt(2k/m); shear: m_eff = m/7
    assert stable_dt([m], [k], ks=[k]) == pytest.approx(min(2 / math.sqrt(2 * k / m), 2 / math.sqrt(7 * k / m)))


def test_extreme_stiffness_ratio_and_size_ratio_stay_finite_and_settle():
    """A stiff small sphere (k 1e10, r 0.1) on a soft big one (k 1e7, r 1.0) on a stiff floor: the
    contacts use the softer partner, so the overlaps are the carried weights over k_soft."""
    k_soft = 1e7
    m_big, m_small = sphere_mass(1.0, 2650.0), sphere_mass(0.1, 2650.0)
    soft = Material(kn=k_soft, friction=0.5, c_cn=2 * 0.7 * math.sqrt(k_soft * m_big), c_gn=0.5 * m_big)
    stiff = Material(kn=1e10, friction=0.5, c_cn=2 * 0.7 * math.sqrt(k_soft * m_small), c_gn=5 * m_small)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), Material(kn=1e10, c_cn=1e7))],
                        sleeping=False, plane_2d=True)
    sim.add_particles([[0, 0, 1.0]], 1.0, soft)
    sim.add_particles([[0.0, 0, 2.12]], 0.1, stiff)
    res = sim.run_to_equilibrium(1e-9, max_steps=300_000)
    assert res.converged
    assert np.all(np.isfinite(sim.state.pos))
    big_overlap = 1.0 - sim.state.pos[0, 2]
    pair_overlap = 1.1 - (sim.state.pos[1, 2] - sim.state.pos[0, 2])
    assert big_overlap == pytest.approx((m_big + m_small) * G / k_soft, rel=1e-3)
    assert pair_overlap == pytest.approx(m_small * G / k_soft, rel=1e-3)


def test_spawned_overlapping_particles_separate_without_gaining_energy():
    mat = Material(kn=1e6, friction=0.3)
    sim = DemSimulation(gravity=(0, 0, 0), sleeping=False)
    d0 = 0.5  # centres 0.5 m apart, radii 0.5: overlap 0.5 m
    sim.add_particles([[0, 0, 0], [d0, 0, 0]], 0.5, mat)
    sim.run(1.0)
    s = sim.state
    assert np.all(np.isfinite(s.pos)) and np.all(np.isfinite(s.vel))
    assert s.pos[1, 0] - s.pos[0, 0] > 1.0  # separated
    stored = 0.5 * 1e6 * (1.0 - d0) ** 2
    # elastic: all of it comes back, up to Verlet's O((omega dt)^2) error of a harmonic oscillator
    omega_dt = math.sqrt(1e6 / (s.mass[0] / 2)) * sim.dt
    assert abs(s.kinetic_energy() / stored - 1) < omega_dt**2 / 4


def test_coincident_centres_do_not_produce_nan():
    sim = DemSimulation(gravity=(0, 0, 0), sleeping=False)
    sim.add_particles([[0, 0, 0], [0, 0, 0]], 0.5, Material(kn=1e5))
    sim.run(0.5)
    assert np.all(np.isfinite(sim.state.pos)) and np.linalg.norm(sim.state.pos[0] - sim.state.pos[1]) > 1.0


def test_particles_leaving_the_domain_are_retired_cleanly():
    sim = DemSimulation(domain=(-5, 5, -5, 5, -5, 50), sleeping=False)
    sim.add_particles([[0, 0, 0.0], [20, 20, 20]][:1], 0.5)
    sim.add_particles([[0, 0, 10.0]], 0.5, vel=[[30.0, 0, 0]])
    sim.run(1.5)
    assert sim.left_domain == [0, 1] or sorted(sim.left_domain) == [0, 1]
    assert not sim.state.active.any()
    assert np.all(np.isfinite(sim.state.pos))
    sim.run(0.1)  # nothing left to move: still fine


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nonfinite_input_is_refused(bad):
    with pytest.raises(InputError, match="position"):
        DemSimulation().add_particles([[0, 0, bad]], 0.5)
    with pytest.raises(InputError, match="radius"):
        DemSimulation().add_particles([[0, 0, 0]], -1.0)


def inclined_terrain(theta, mat):
    x = np.linspace(-10, 10, 41)
    y = np.linspace(-5, 5, 21)
    bed = np.broadcast_to(-math.tan(theta) * x, (y.size, x.size))
    return HeightField(x, y, bed, mat)


@pytest.mark.parametrize("mu,rolls", [(0.5, True), (0.02, False)])
def test_sphere_on_terrain_slope_accelerates_as_coulomb_predicts(mu, rolls):
    """Down a plane of slope theta: rolling without slip a = 5/7 g sin(theta) when mu >= 2/7 tan(theta),
    otherwise sliding with a = g (sin(theta) - mu cos(theta))."""
    theta = math.radians(20)
    mat = Material(kn=1e7, friction=mu, c_cn=2 * 0.5 * math.sqrt(1e7 * sphere_mass(0.5, 2650.0)))
    terrain = inclined_terrain(theta, mat)
    assert (mu >= 2 / 7 * math.tan(theta)) == rolls
    sim = DemSimulation(boundaries=[terrain], sleeping=False)
    n = np.array([math.sin(theta), 0, math.cos(theta)])
    sim.add_particles([[-5 * math.cos(theta) + 0.5 * n[0], 0, 5 * math.sin(theta) + 0.5 * n[2] - 1e-4]], 0.5, mat)
    sim.run(0.2)
    v1, t1 = sim.state.vel[0].copy(), sim.t
    sim.run(1.0)
    v2, t2 = sim.state.vel[0].copy(), sim.t
    down = np.array([math.cos(theta), 0, -math.sin(theta)])
    a = (v2 - v1) @ down / (t2 - t1)
    expected = 5 / 7 * G * math.sin(theta) if rolls else G * (math.sin(theta) - mu * math.cos(theta))
    assert a == pytest.approx(expected, rel=5e-3)


def test_terrain_from_snapshot_grid_and_elevation():
    from breachflow.field.snapshot import grid_snapshot

    x = np.linspace(0, 10, 11)
    y = np.linspace(0, 4, 5)
    bed = np.add.outer(0.1 * y, 0.2 * x)
    z = np.zeros_like(bed)
    snap = grid_snapshot(x, y, bed, z, z, z)
    hf = HeightField.from_snapshot(snap)
    assert hf.elevation([2.5], [1.5])[0] == pytest.approx(0.2 * 2.5 + 0.1 * 1.5)


def test_velocity_controlled_wall_pushes_a_particle_along():
    mat = Material(kn=1e6, friction=0.0, c_cn=2000.0)
    piston = Plane((0, 0, 0), (1, 0, 0), mat, control="velocity", velocity=(0.5, 0, 0))
    sim = DemSimulation(boundaries=[piston], gravity=(0, 0, 0))
    sim.add_particles([[1.0, 0, 0]], 0.5, mat)
    sim.state.awake[:] = False  # asleep: the moving wall must wake it
    sim._refresh_idx()
    sim.run(4.0)
    # it was asleep when the wall arrived (t = 1 s); the nearly elastic push leaves it faster than the wall
    assert sim.state.pos[0, 0] > piston.point[0] + 0.5
    assert sim.state.vel[0, 0] > 0.5
    assert piston.point[0] == pytest.approx(0.5 * sim.t, rel=1e-9)


def test_force_controlled_plate_settles_to_its_load():
    """A plate pressed with F on a sphere lying on the floor: both contacts carry F; overlaps F/k each."""
    F, k = 2e4, 1e7
    mat = Material(kn=k, friction=0.3, c_cn=2e4, c_gn=100.0)
    plate = Plane((0, 0, 1.05), (0, 0, -1), mat, control="force", applied_force=(0, 0, -F), mass=100.0)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat), plate], gravity=(0, 0, 0), sleeping=False)
    sim.add_particles([[0, 0, 0.5]], 0.5, mat)
    sim.run(3.0)
    assert sim.state.pos[0, 2] == pytest.approx(0.5 - F / k, rel=1e-4)
    assert 1.0 - plate.point[2] == pytest.approx(2 * F / k, rel=2e-3)


def test_plane_2d_mode_keeps_motion_in_the_vertical_plane():
    mat = Material(kn=1e7, friction=0.5, c_cn=1e4)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], plane_2d=True, sleeping=False)
    sim.add_particles([[0, 0, 1.0], [0.6, 0.0, 2.5]], 0.5, mat, vel=[[1, 1, 0], [0, 0, 0]], omega=[[1, 1, 1]] * 2)
    sim.run(1.0)
    s = sim.state
    assert np.all(s.pos[:, 1] == 0.0) and np.all(s.vel[:, 1] == 0.0)
    assert np.all(s.omega[:, 0] == 0.0) and np.all(s.omega[:, 2] == 0.0)
    assert np.any(s.omega[:, 1] != 0.0) and np.any(s.vel[:, 0] != 0.0)
