"""The DEM integrator ``adaptive_free_flight``: error-controlled steps in free flight, the contact
integrator's fixed step near contact (docs/theory.md, *DEM contact*, *Fluid forces on a mass*). References are closed forms written out here."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, ParticleState, Plane, integrators
from breachflow.coupling.integrators import AdaptiveFreeFlight
from breachflow.fluid.drag import DRAG_LAWS
from breachflow.fluid.forces import FluidForces

G = 9.80665
RHO_W, STEEL = 1000.0, 7800.0


def test_registered_by_name():
    assert "adaptive_free_flight" in integrators.available()
    sim = DemSimulation(ParticleState.spheres([[0, 0, 0]], 0.1, Material(kn=1e-3)), integrator="adaptive_free_flight")
    assert isinstance(sim.integrator, AdaptiveFreeFlight)


def test_constant_drag_settling_matches_tanh_with_few_steps():
    """v(t) = v_t tanh(g' t / v_t) (constant C_D, added mass), through DemSimulation.run."""
    d, cd, xi, dt = 0.01, 0.4, 0.5, 1e-5
    gp = G * (STEEL - RHO_W) / (STEEL + xi * RHO_W)
    v_t = math.sqrt(4 * G * d * (STEEL - RHO_W) / (3 * RHO_W * cd))
    st = ParticleState.spheres([[0, 0, -10.0]], d / 2, Material(density=STEEL, kn=1e-3))
    integ = AdaptiveFreeFlight(rtol=1e-9, atol=1e-12)
    model = FluidForces(0.0, air=None, xi=xi, drag_law=DRAG_LAWS.create("constant", value=cd), velocity_profile="uniform")
    sim = DemSimulation(st, models=[model], integrator=integ, dt=dt, sleeping=False)
    for t_out in (0.05, 0.2, 1.0):
        sim.run(t_out - sim.t)
        assert sim.t == pytest.approx(t_out, abs=1e-12)
        exact = v_t * math.tanh(gp * t_out / v_t)
        assert -st.vel[0, 2] == pytest.approx(exact, rel=1e-6)
        depth = v_t**2 / gp * math.log(math.cosh(gp * t_out / v_t))
        assert -10.0 - st.pos[0, 2] == pytest.approx(depth, rel=1e-6)
    assert integ.contact_steps == 0
    assert sim.steps < 1e-3 * (1.0 / dt)  # far fewer than the 1e5 fixed steps of dt


def test_bounce_on_a_plane_uses_the_contact_integrator_and_keeps_the_restitution():
    """Dropped 1 m in vacuum onto a spring–dashpot plane: rebound apex e^2 h, e = exp(-zeta pi / sqrt(1 - zeta^2))."""
    r, rho, k, e = 0.05, 2650.0, 1e6, 0.5
    m = rho * 4 / 3 * math.pi * r**3
    zeta = -math.log(e) / math.sqrt(math.pi**2 + math.log(e) ** 2)
    mat = Material(density=rho, kn=k, c_cn=2 * zeta * math.sqrt(k * m))
    h = 1.0
    st = ParticleState.spheres([[0, 0, r + h]], r, mat)
    integ = AdaptiveFreeFlight(rtol=1e-8, atol=1e-10)
    sim = DemSimulation(st, boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], integrator=integ, sleeping=False)
    # the rebound is in flight at 0.7 s (fall 0.45 s, rebound flight 2 sqrt(2 e^2 h / g) = 0.45 s)
    sim.run(0.7)
    assert st.vel[0, 2] != 0.0 and st.pos[0, 2] > r
    apex = st.pos[0, 2] - r + st.vel[0, 2] ** 2 / (2 * G)  # energy is conserved in vacuum flight
    assert apex == pytest.approx(e**2 * h, rel=0.02)
    contact_duration = math.pi / (math.sqrt(k / m) * math.sqrt(1 - zeta**2))
    assert integ.contact_steps >= contact_duration / sim.dt  # the contact itself is stepped with dt
    assert integ.free_steps < 200 and sim.steps < 0.1 * 0.7 / sim.dt
