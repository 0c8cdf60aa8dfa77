"""static_models: frozen force models are evaluated for awake particles only, and a restored
simulation compares the (new) models with the sleepers' reference once, on its first step."""
import numpy as np

from breachflow.dem import DemSimulation, Material, Plane


class Push:
    """A constant horizontal force F on every particle; records how many particles each call evaluated."""

    def __init__(self, F):
        self.F = float(F)
        self.sizes = []

    def added_mass(self, state):
        return None

    def accumulate(self, state, pos, vel, omega, t, force, torque, idx=None):
        idx = np.flatnonzero(state.active) if idx is None else idx
        self.sizes.append(idx.size)
        force[idx, 0] += self.F


def _bed(model, static):
    mat = Material(kn=1e6, friction=0.5, rolling_friction=0.5).with_restitution(0.3, 4.0)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], models=[model], static_models=static)
    xs = np.arange(20) * 1.0
    sim.add_particles(np.column_stack([xs, np.zeros(20), np.full(20, 0.5)]), 0.4, mat)
    return sim


def test_static_models_evaluate_only_awake_particles_after_the_first_step():
    model = Push(0.0)
    sim = _bed(model, static=True)
    sim.sleep(np.arange(19))  # one particle stays awake
    model.sizes.clear()
    sim.step(50)
    assert model.sizes[0] == 20  # the first step checks every sleeper once
    assert max(model.sizes[1:]) == 1  # then only the awake particle
    dyn = Push(0.0)
    sim2 = _bed(dyn, static=False)
    sim2.sleep(np.arange(19))
    dyn.sizes.clear()
    sim2.step(50)
    assert min(dyn.sizes) == 20  # without static models every step evaluates all particles


def test_restored_simulation_with_a_new_field_wakes_the_sleepers_it_moves():
    weak = Push(0.0)
    sim = _bed(weak, static=True)
    sim.sleep(np.arange(20))
    sim.step(5)
    state = sim.save_state()
    m = sim.state.mass[0]
    # same field again: nobody wakes
    same = DemSimulation.from_state(state, boundaries=sim.boundaries, models=[Push(0.0)], static_models=True)
    same.step(5)
    assert same.n_awake == 0
    # a push of 20 % of the weight (above the 5 % wake threshold): every sleeper wakes on the first step
    strong = DemSimulation.from_state(state, boundaries=sim.boundaries, models=[Push(0.2 * m * 9.80665)],
                                      static_models=True)
    strong.step(1)
    assert strong.n_awake == 20
