"""DemSimulation.sleep(ids): sleeping particles are not integrated, keep being contact partners, and wake
when a particle lands on them or when the force models' force on them changes."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, sphere_mass
from breachflow.errors import InputError

G = 9.80665
R = 0.5
KN = 1e7
M = float(sphere_mass(R, 2650.0))
MAT = Material(kn=KN, friction=0.5, c_cn=2 * 0.4 * math.sqrt(KN * M / 2), c_gn=200.0, c_gw=50.0)


class Flow:
    """A drag-like model: ``f = push - c v`` per particle (settable push, N)."""

    def __init__(self, push=(0.0, 0.0, 0.0), c=500.0):
        self.push = np.asarray(push, float)
        self.c = c

    def added_mass(self, state):
        return None

    def accumulate(self, state, pos, vel, omega, t, force, torque):
        force[:] += self.push - self.c * vel


def resting_sphere(models=()):
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), MAT)], models=models)
    sim.add_particles([[0.0, 0.0, R - M * G / KN]], R, MAT)
    return sim


def test_sleeping_particles_are_not_integrated():
    undamped = Material(kn=KN, friction=0.5)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), undamped)])
    sim.add_particles([[0.0, 0.0, 3.0], [5.0, 0.0, 3.0]], R, undamped, vel=[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert list(sim.sleep([0])) == [0]
    assert not sim.state.awake[0] and sim.n_awake == 1
    assert np.all(sim.state.vel[0] == 0.0) and np.all(sim.state.omega[0] == 0.0)
    sim.step(200)
    # the sleeper hangs in the air where it was put to sleep; the other one falls
    np.testing.assert_array_equal(sim.state.pos[0], [0.0, 0.0, 3.0])
    t = sim.steps * sim.dt
    assert sim.state.pos[1, 2] == pytest.approx(3.0 - 0.5 * G * t**2, rel=1e-9)  # Verlet: exact free fall
    assert sim.state.pos[1, 0] == pytest.approx(5.0 + t, rel=1e-12)
    assert sim.particle_steps == 200


def test_sleep_rejects_bad_ids_and_ignores_fixed_ones():
    sim = resting_sphere()
    sim.add_particles([[3.0, 0.0, R]], R, MAT)
    sim.fix_particles([1])
    with pytest.raises(InputError, match="sleep"):
        sim.sleep([5])
    assert sim.sleep([1]).size == 0


def test_a_particle_landing_on_a_sleeper_wakes_it():
    sim = resting_sphere()
    sim.sleep([0])
    sim.step(50)
    assert not sim.state.awake[0]
    sim.add_particles([[0.0, 0.0, 2.0]], R, MAT)
    woke = False
    for _ in range(400):
        sim.step(5)
        woke |= bool(sim.state.awake[0])
    assert woke
    res = sim.run_to_equilibrium(1e-6)
    assert res.converged
    # the stack carries the weights: upper sphere at 1.5 m minus the floor and pair overlaps
    assert sim.state.pos[1, 2] == pytest.approx(1.5 - 3 * M * G / KN, abs=2e-4)


def test_a_sleeper_stays_asleep_while_the_force_model_is_unchanged_and_wakes_when_it_changes():
    flow = Flow(push=(0.05 * M * G, 0.0, 0.0))
    sim = resting_sphere(models=[flow])
    # moving when put to sleep: the reference is recorded at rest, so the drag -c v must not wake it
    sim.state.vel[0] = (0.5, 0.0, 0.0)
    sim.sleep([0])
    sim.step(500)  # the only particle and asleep: the wake check still runs every step
    assert not sim.state.awake[0]
    flow.push = flow.push + (0.02 * M * G, 0.0, 0.0)  # below wake_force_fraction = 5 % of the weight
    sim.step(100)
    assert not sim.state.awake[0]
    flow.push = flow.push + (0.06 * M * G, 0.0, 0.0)  # total change 8 % of the weight
    sim.step(1)
    assert sim.state.awake[0]


def test_a_sleeper_among_moving_particles_wakes_on_a_changed_force():
    flow = Flow()
    sim = resting_sphere(models=[flow])
    sim.add_particles([[10.0, 0.0, 3.0]], R, MAT)  # keeps falling / bouncing meanwhile
    sim.sleep([0])
    sim.step(100)
    assert not sim.state.awake[0] and sim.state.awake[1]
    flow.push = np.array([0.0, 0.2 * M * G, 0.0])
    sim.step(1)
    assert sim.state.awake[0]
