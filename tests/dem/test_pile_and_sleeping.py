"""Piles: settling to equilibrium, angle of repose vs friction; sleeping vs no sleeping."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, sphere_mass
from breachflow.dem.scenes import drop_batch, repose_angle, rough_base

M = float(sphere_mass(0.5, 2650.0))


def material(mu):
    return Material(kn=1e7, friction=mu, c_cn=2 * 0.4 * math.sqrt(1e7 * M / 2), c_gn=200.0, c_gw=50.0)


def pour(mu, seed, batches=12, per_batch=6):
    mat = material(mu)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], plane_2d=True)
    rng = np.random.default_rng(seed)
    rough_base(sim, 15, 1.0, mat, rng=rng, spread=0.3)
    moving = []
    converged = []
    for _ in range(batches):
        moving += list(drop_batch(sim, per_batch, 1.0, mat, rng=rng, size_spread=0.2))
        converged.append(sim.run_to_equilibrium(1e-5, max_steps=100_000).converged)
    return sim, np.array(moving), all(converged)


def test_angle_of_repose_grows_with_friction():
    """72 polydisperse spheres poured in a vertical plane on an irregular rough base: frictionless
    spheres only interlock geometrically (a low heap), frictional ones stand steeper."""
    angles = {}
    for mu in (0.0, 0.5):
        sim, moving, converged = pour(mu, seed=1)
        assert converged
        angles[mu] = repose_angle(sim, moving, 1.0, base_top=1.0)
    assert angles[0.5] > angles[0.0] + 5.0
    assert 5.0 < angles[0.0] < angles[0.5] < 60.0


def pocket_deposition(sleeping, e_tol, mu):
    """Spheres dropped one per cycle into the pockets of a fixed row, then a second layer into the
    pockets of the first: each lands in a unique pocket, so the end state is not chaotic."""
    mat = material(mu)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], plane_2d=True, sleeping=sleeping,
                        sleep_velocity=100 * e_tol)
    xb = np.arange(-6, 7) * 1.3
    sim.fix_particles(sim.add_particles(np.column_stack([xb, 0 * xb, 0 * xb + 0.5]), 0.5, mat))
    ok = []
    for x in (0.5 * (xb[:-1] + xb[1:]))[2:-2]:
        sim.add_particles([[x, 0, 2.5]], 0.5, mat)
        ok.append(sim.run_to_equilibrium(e_tol).converged)
    layer1 = np.sort(sim.state.pos[xb.size:, 0])
    for x in (0.5 * (layer1[:-1] + layer1[1:]))[1:-1]:
        sim.add_particles([[x, 0, 3.5]], 0.5, mat)
        ok.append(sim.run_to_equilibrium(e_tol).converged)
    assert all(ok)
    return sim


def test_sleeping_changes_no_result_beyond_the_equilibrium_tolerance():
    """Frictionless deposition (a unique equilibrium): final positions with and without sleeping agree
    to within 20 E_TOL, and the difference vanishes with E_TOL; sleeping integrates fewer particle-steps."""
    diffs = []
    for e_tol in (1e-5, 1e-6, 1e-7):
        a = pocket_deposition(True, e_tol, 0.0)
        b = pocket_deposition(False, e_tol, 0.0)
        d = float(np.max(np.linalg.norm(a.state.pos - b.state.pos, axis=1)))
        assert d < 20 * e_tol
        assert a.particle_steps < 0.6 * b.particle_steps
        diffs.append(d)
    assert diffs[2] < 0.1 * diffs[0]


def test_sleeping_particles_are_still_contact_partners():
    """A sphere landing on a sleeping sphere is stopped by it (and wakes it)."""
    mat = material(0.5)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)])
    sim.add_particles([[0, 0, 0.5]], 0.5, mat)
    sim.run_to_equilibrium(1e-6)
    sim.run(0.5)
    assert not sim.state.awake[0]
    sim.add_particles([[0, 0, 2.0]], 0.5, mat)
    res = sim.run_to_equilibrium(1e-6)
    assert res.converged
    weight = M * 9.80665
    assert sim.state.pos[1, 2] == pytest.approx(1.5 - 3 * weight / 1e7, abs=2e-4)
