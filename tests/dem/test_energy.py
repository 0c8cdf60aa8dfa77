"""Energy: elastic collisions conserve it (bounded drift over 1e5 steps); damped systems never gain it."""
import math

import numpy as np

from breachflow.dem import DemSimulation, Material, Plane, sphere_mass

K = 1e7


def elastic_energy(sim, walls):
    """Kinetic + normal-spring (1/2 k u_N^2) + shear-spring (1/2 k_S u_S^2) energy, computed here."""
    s = sim.state
    e = s.kinetic_energy()
    n = s.n
    for i in range(n):
        for j in range(i + 1, n):
            d = np.linalg.norm(s.pos[j] - s.pos[i])
            ov = s.radius[i] + s.radius[j] - d
            if ov > 0:
                e += 0.5 * min(s.kn[i], s.kn[j]) * ov**2
        for p in walls:
            ov = s.radius[i] - (s.pos[i] - p.point) @ p.normal
            if ov > 0:
                e += 0.5 * min(s.kn[i], p.material.kn) * ov**2
    e += 0.5 * np.sum(np.minimum.outer(s.ks, s.ks)[sim.pairs.pa, sim.pairs.pb] * np.sum(sim.pairs.hist**2, axis=1)) if len(sim.pairs.pa) else 0
    for p in walls:
        e += 0.5 * np.sum(np.minimum(s.ks, p.material.kn) * np.sum(p.hist[: n] ** 2, axis=1))
    return e


def box(mat, L):
    return [Plane((0, 0, 0), (0, 0, 1), mat), Plane((0, 0, L), (0, 0, -1), mat),
            Plane((0, 0, 0), (1, 0, 0), mat), Plane((L, 0, 0), (-1, 0, 0), mat),
            Plane((0, 0, 0), (0, 1, 0), mat), Plane((0, L, 0), (0, -1, 0), mat)]


def test_undamped_elastic_gas_conserves_energy_over_1e5_steps():
    mat = Material(kn=K, friction=0.0)
    L = 4.0
    walls = box(mat, L)
    rng = np.random.default_rng(3)
    pos = np.array([[x, y, z] for x in (1.0, 3.0) for y in (1.0, 3.0) for z in (1.0, 3.0)])
    # Verlet's energy error comes from the kinks of the force at contact onset/exit, O((omega dt)^2) per
    # collision and of random sign; at a quarter of the recommended step it stays well below 0.2 %
    m = sphere_mass(0.4, 2650.0)
    dt = 0.25 * 0.2 * 2 / math.sqrt(7 * K / m)
    sim = DemSimulation(boundaries=walls, gravity=(0, 0, 0), sleeping=False, integrator="velocity_verlet", dt=dt)
    sim.add_particles(pos, 0.4, mat, vel=rng.normal(0, 2.0, (8, 3)))
    e0 = elastic_energy(sim, walls)
    worst = 0.0
    for _ in range(100):
        sim.step(1000)
        worst = max(worst, abs(elastic_energy(sim, walls) - e0) / e0)
    assert sim.steps == 100_000
    assert worst < 2e-3


def test_damped_frictional_settling_never_gains_energy():
    mat = Material(kn=K, friction=0.4, c_cn=2 * 0.2 * math.sqrt(K * sphere_mass(0.4, 2650.0)), c_cs=500.0,
                   c_cf=500.0, c_gn=10.0, c_gw=1.0)
    L = 3.0
    walls = box(mat, L)
    rng = np.random.default_rng(4)
    pos = np.array([[x, y, z] for x in (0.8, 2.2) for y in (0.8, 2.2) for z in (0.8, 1.8, 2.6)])
    pos += rng.uniform(-0.05, 0.05, pos.shape)
    sim = DemSimulation(boundaries=walls, sleeping=False, dt=2e-4)
    sim.add_particles(pos, 0.35, mat, vel=rng.normal(0, 1.0, pos.shape))
    g = 9.80665

    def total():
        return elastic_energy(sim, walls) + float(np.sum(sim.state.mass * g * sim.state.pos[:, 2]))

    e_prev = total()
    e0 = e_prev
    for _ in range(300):
        sim.step(10)
        e = total()
        assert e <= e_prev + 1e-6 * abs(e0)
        e_prev = e
    assert e < e0
