"""Analytic validations of the fluid forces with the DEM and the free-flight integrators (docs/theory.md, *Fluid forces on a mass*; docs/validation.md, *Settling spheres*).

References are computed here, independently of the package: closed forms, or the force balance / the
equation of motion written out in this file and solved with scipy.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from breachflow.dem import DemSimulation, Gravity, Material, ParticleState, Plane
from breachflow.fluid.drag import DRAG_LAWS
from breachflow.fluid.field import UniformWater
from breachflow.fluid.forces import FluidForces
from breachflow.fluid.freeflight import integrate
from breachflow.field.sampling import uniform_snapshot

G = 9.80665
RHO_W, NU_W = 1000.0, 1.0e-6
RHO_A, NU_A = 1.23, 1.46e-5
STEEL = 7800.0


def clift_gauvin(re):
    """Clift & Gauvin (1970) standard curve, written out independently of breachflow."""
    return 24 / re * (1 + 0.15 * re**0.687) + 0.42 / (1 + 42500 * re**-1.16)


def terminal_velocity(d, rho_s, rho_f=RHO_W, nu=NU_W):
    """Root of (rho_s - rho_f) V g = 1/2 C_D(R) rho_f A v^2."""
    vol, area = math.pi * d**3 / 6, math.pi * d**2 / 4
    balance = lambda v: (rho_s - rho_f) * vol * G - 0.5 * clift_gauvin(v * d / nu) * rho_f * area * v * v  # noqa: E731
    return brentq(balance, 1e-9, 100.0, xtol=1e-14, rtol=1e-14)


def sphere(d, rho_s, z=-1.0, vel=(0.0, 0.0, 0.0)):
    return ParticleState.spheres([[0.0, 0.0, z]], d / 2, Material(density=rho_s, kn=1e-3), vel=[vel])


def test_stokes_settling_with_added_mass_report_scheme_and_rk4():
    """v(t) = v_t (1 - exp(-t/tau)), tau = (rho_S + xi rho_F) d^2 / (18 mu): glass, d = 0.1 mm, R_t = 0.82."""
    d, rho_s, xi = 1e-4, 2500.0, 0.5
    mu = RHO_W * NU_W
    tau = (rho_s + xi * RHO_W) * d * d / (18 * mu)
    v_t = (rho_s - RHO_W) * G * d * d / (18 * mu)
    assert v_t * d / NU_W < 1.0  # the report law's Stokes branch holds throughout
    # DEM, the report's scheme (first order in dt): documented step tau/2000
    dt = tau / 2000
    sim = DemSimulation(sphere(d, rho_s), models=[FluidForces(0.0, air=None, xi=xi, velocity_profile="uniform")], integrator="report", dt=dt,
                        sleeping=False)
    err = 0.0
    for _ in range(10_000):
        sim.step()
        exact = v_t * (1 - math.exp(-sim.t / tau))
        err = max(err, abs(-sim.state.vel[0, 2] - exact) / v_t)
    assert sim.t == pytest.approx(5 * tau)
    assert err < 1e-4
    # free flight, classical RK4 with step tau/20
    t = np.linspace(0, 5 * tau, 101)
    res = integrate(sphere(d, rho_s), [Gravity(), FluidForces(0.0, air=None, xi=xi, velocity_profile="uniform")], t, method="rk4", dt=tau / 20)
    exact = v_t * (1 - np.exp(-t / tau))
    assert np.max(np.abs(-res.vel[:, 0, 2] - exact)) / v_t < 1e-4
    assert res.evaluations == 4 * 100


@pytest.mark.parametrize("method, dt", [("rk4", 2e-3), ("dopri5", None)])
def test_constant_drag_coefficient_tanh(method, dt):
    """v(t) = v_t tanh(g' t / v_t), g' = g (rho_S - rho_F)/(rho_S + xi rho_F), v_t = sqrt(4 g d (rho_S - rho_F)/(3 rho_F C_D))."""
    d, cd, xi = 0.01, 0.4, 0.5
    gp = G * (STEEL - RHO_W) / (STEEL + xi * RHO_W)
    v_t = math.sqrt(4 * G * d * (STEEL - RHO_W) / (3 * RHO_W * cd))
    t = np.linspace(0.0, 1.0, 201)
    model = FluidForces(0.0, air=None, xi=xi, drag_law=DRAG_LAWS.create("constant", value=cd), velocity_profile="uniform")
    res = integrate(sphere(d, STEEL, z=-10.0), [Gravity(), model], t, method=method, dt=dt, rtol=1e-9, atol=1e-12)
    exact = v_t * np.tanh(gp * t / v_t)
    rel = np.abs(-res.vel[1:, 0, 2] - exact[1:]) / exact[1:]
    assert rel.max() < 1e-4


@pytest.mark.parametrize("d", [0.003, 0.010, 0.020, 0.040])
def test_terminal_velocity_of_steel_spheres(d):
    v_ref = terminal_velocity(d, STEEL)
    res = integrate(sphere(d, STEEL, z=-100.0), [Gravity(), FluidForces(0.0, air=None, drag_law="clift_gauvin", velocity_profile="uniform")],
                    [0.0, 4.0], method="dopri5", rtol=1e-9, atol=1e-12)
    assert -res.vel[-1, 0, 2] == pytest.approx(v_ref, rel=5e-3)
    assert -res.vel[-1, 0, 2] == pytest.approx(v_ref, rel=1e-5)  # in fact far tighter than the 0.5 % asked


def test_water_entry_from_two_metres():
    """Released 2 m above still water: falls at g (less air drag), decelerates on entry, ends at v_t."""
    d = 0.04
    a = d / 2
    z0 = 2.0 + a  # bottom 2 m above the surface at z = 0
    xi = 0.5
    model = FluidForces(UniformWater(surface=0.0), drag_law="clift_gauvin", xi=xi, velocity_profile="uniform")
    t = np.linspace(0.0, 3.0, 3001)
    res = integrate(sphere(d, STEEL, z=z0), [Gravity(), model], t, method="dopri5", rtol=1e-9, atol=1e-12)
    z, w = res.pos[:, 0, 2], -res.vel[:, 0, 2]
    # the air phase, solved independently: (m + xi rho_A V) dv/dt = (rho_S - rho_A) V g - 1/2 C_D rho_A A v^2
    vol, area = math.pi * d**3 / 6, math.pi * d**2 / 4

    def air(tt, y):
        v = y[1]
        drag = 0.5 * clift_gauvin(max(v, 1e-12) * d / NU_A) * RHO_A * area * v * v
        return [v, ((STEEL - RHO_A) * vol * G - drag) / ((STEEL + xi * RHO_A) * vol)]

    hit = lambda tt, y: y[0] - 2.0  # noqa: E731  bottom reaches the surface
    hit.terminal = True
    ref = solve_ivp(air, (0, 2), [0.0, 0.0], events=hit, rtol=1e-11, atol=1e-12, dense_output=True)
    t_entry, v_entry = ref.t_events[0][0], ref.y_events[0][0][1]
    assert v_entry == pytest.approx(math.sqrt(2 * G * 2.0), rel=2e-3)  # nearly free fall
    in_air = t < t_entry
    np.testing.assert_allclose(w[in_air], ref.sol(t[in_air])[1], rtol=1e-6, atol=1e-9)
    # the early acceleration is g (rho_S - rho_A)/(rho_S + xi rho_A)
    assert (w[1] - w[0]) / (t[1] - t[0]) == pytest.approx(G * (STEEL - RHO_A) / (STEEL + xi * RHO_A), rel=1e-3)
    # decelerates on entry: fastest while crossing, then slows down monotonically to the terminal velocity
    k_max = int(np.argmax(w))
    assert -d <= z[k_max] <= a + 1e-3 and w[k_max] > v_entry
    submerged = z < -a
    assert np.all(np.diff(w[submerged]) <= 1e-12)
    v_t = terminal_velocity(d, STEEL)
    assert w[-1] == pytest.approx(v_t, rel=5e-3)
    assert w[k_max] > 2 * v_t


@pytest.mark.parametrize("ratio, moves", [(0.9, False), (1.1, True)])
def test_sphere_on_the_bed_in_a_uniform_current(ratio, moves):
    """Sliding threshold with rotation locked: drag 1/2 C_D rho A U^2 against friction beta (rho_S - rho_F) V g."""
    d, rho_s, beta, cd = 0.1, 2650.0, 0.5, 0.45
    vol, area = math.pi * d**3 / 6, math.pi * d**2 / 4
    u_crit = math.sqrt(2 * beta * (rho_s - RHO_W) * vol * G / (cd * RHO_W * area))  # hand calculation
    snap = uniform_snapshot(1.0, u=ratio * u_crit, extent=(-5, 5, -5, 5), spacing=0.5)
    fluid = FluidForces(snap, drag_law=DRAG_LAWS.create("constant", value=cd), air=None, velocity_profile="uniform")
    mat = Material(density=rho_s, kn=1e6, friction=beta, c_cn=200.0, c_cs=200.0)
    st = ParticleState.spheres([[0.0, 0.0, d / 2]], d / 2, mat)
    sim = DemSimulation(st, boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], models=[fluid], sleeping=False)
    sim.rmask[:] = 0.0  # no rolling: the sphere can only stick or slide
    sim.run(1.0)
    moved = st.pos[0, 0]
    if moves:
        assert moved > 0.05
    else:
        assert abs(moved) < 1e-4
    # the current pushes downstream in both cases and the sphere stays on the bed
    assert moved >= 0 and abs(st.pos[0, 2] - d / 2) < 1e-3


def test_free_sphere_on_the_bed_rolls_without_slipping_below_the_sliding_threshold():
    """With rotation free the same current rolls the sphere: v = w r, a = F / (m + m_A + I/r^2)."""
    d, rho_s, beta, cd, u = 0.1, 2650.0, 0.5, 0.45, 0.3
    snap = uniform_snapshot(1.0, u=u, extent=(-5, 5, -5, 5), spacing=0.5)
    fluid = FluidForces(snap, drag_law=DRAG_LAWS.create("constant", value=cd), air=None, xi=0.5, velocity_profile="uniform")
    mat = Material(density=rho_s, kn=1e6, friction=beta, c_cn=200.0, c_cs=200.0)
    st = ParticleState.spheres([[0.0, 0.0, d / 2]], d / 2, mat)
    sim = DemSimulation(st, boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], models=[fluid], sleeping=False)
    sim.run(0.05)
    v, w = st.vel[0, 0], st.omega[0, 1]
    assert v > 0 and w * d / 2 == pytest.approx(v, rel=0.05)  # rolling, not sliding
    # early acceleration against the hand calculation (drag at the initial relative speed u)
    m = rho_s * math.pi * d**3 / 6
    m_a = 0.5 * RHO_W * math.pi * d**3 / 6
    drag = 0.5 * cd * RHO_W * math.pi * d**2 / 4 * u * u
    a_hand = drag / (m + m_a + 0.4 * m)
    assert v / sim.t == pytest.approx(a_hand, rel=0.05)
