"""The force-assembly interface (the ForceModel protocol of breachflow.dem.forces): plug-in ForceModels, added mass, integrator registry."""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, ForceModel, G, Material, integrators, recommended_dt, sphere_mass
from breachflow.errors import InputError

M = float(sphere_mass(0.5, 2650.0))


class ConstantForce:
    """Adds a fixed force per particle and an optional added mass (like a fluid model would)."""

    def __init__(self, force, added=None):
        self.f = np.asarray(force, float)
        self.added = added
        self.calls = 0

    def added_mass(self, state):
        return None if self.added is None else np.full(state.n, self.added)

    def accumulate(self, state, pos, vel, omega, t, force, torque):
        self.calls += 1
        force += self.f


def test_registry_lists_the_integrators_and_refuses_unknown_names():
    assert {"report", "velocity_verlet", "predicted_verlet"} <= set(integrators.available())
    with pytest.raises(InputError, match="available"):
        DemSimulation(integrator="euler-ish")


@pytest.mark.parametrize("name", ["report", "velocity_verlet", "predicted_verlet"])
def test_a_model_that_cancels_gravity_leaves_the_particle_at_rest(name):
    model = ConstantForce([0.0, 0.0, M * G])
    assert isinstance(model, ForceModel)
    sim = DemSimulation(models=[model], integrator=name, sleeping=False)
    sim.add_particles([[0, 0, 5.0]], 0.5)
    sim.step(100)
    assert sim.state.pos[0, 2] == pytest.approx(5.0, abs=1e-12)
    assert model.calls >= 100


@pytest.mark.parametrize("name", ["report", "velocity_verlet", "predicted_verlet"])
def test_added_mass_divides_the_total_force(name):
    """Free fall with added mass m_a: a = m g / (m + m_a); all schemes are exact for constant a."""
    m_a = 0.5 * M
    sim = DemSimulation(models=[ConstantForce([0, 0, 0], added=m_a)], integrator=name, sleeping=False, dt=1e-3)
    sim.add_particles([[0, 0, 100.0]], 0.5)
    a = M * G / (M + m_a)
    sim.step(1000)
    t = sim.t
    assert sim.state.vel[0, 2] == pytest.approx(-a * t, rel=1e-9)
    assert 100.0 - sim.state.pos[0, 2] == pytest.approx(0.5 * a * t * t, rel=1e-3)


def test_default_time_step_is_the_documented_fraction_of_the_limit():
    sim = DemSimulation()
    sim.add_particles([[0, 0, 0]], 0.5, Material(kn=1e7))
    assert sim.dt == pytest.approx(recommended_dt([M], [1e7], [1e7]))
    assert sim.dt < sim.dt_limit


def test_equilibrium_sum_criterion_and_bad_arguments():
    mat = Material(kn=1e7, friction=0.5, c_cn=4e4)
    from breachflow.dem import Plane

    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)])
    sim.add_particles([[0, 0, 1.0], [3, 0, 1.5]], 0.5, mat)
    res = sim.run_to_equilibrium(1e-6, criterion="sum")
    assert res.converged and res.displacement < 1e-6
    assert sim.state.pos[:, 2] == pytest.approx(0.5 - M * G / 1e7, abs=1e-5)
    with pytest.raises(InputError, match="criterion"):
        sim.run_to_equilibrium(1e-6, criterion="mean")
    with pytest.raises(InputError, match="E_TOL"):
        sim.run_to_equilibrium(0.0)
