"""Basset history force (docs/theory.md, *Fluid forces on a mass*, report eq 3.13): the history quadrature and the Stokes settling with
added mass and Basset force, against closed forms derived here."""
import math

import numpy as np
import pytest
from scipy.special import wofz

from breachflow.dem import DemSimulation, Material, ParticleState
from breachflow.fluid.basset import BassetHistory
from breachflow.fluid.forces import FluidForces
from breachflow.fluid.freeflight import integrate
from breachflow.dem.forces import Gravity

G = 9.80665
RHO_W, MU_W = 1000.0, 1.0e-3


def history(times, r_of_t, t_eval=None):
    """H(t) of the package's quadrature after committing r at *times* (and evaluating at t_eval)."""
    h = BassetHistory()
    idx = np.array([0])
    for t in times:
        h.commit(idx, np.array([[r_of_t(t), 0.0, 0.0]]), t)
    t = times[-1] if t_eval is None else t_eval
    return h.integral(idx, np.array([[r_of_t(t), 0.0, 0.0]]), t)[0, 0]


def test_history_of_a_linear_relative_velocity_is_2a_sqrt_t():
    """r = a t: int_0^t a / sqrt(t - tau) dtau = 2 a sqrt(t), at committed and at trial times, uneven steps."""
    rng = np.random.default_rng(1)
    a = 3.7
    times = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-5, 2e-2, 400))])
    r = lambda t: a * t  # noqa: E731
    for k in (1, 10, 100, 400):
        assert history(times[:k + 1], r) == pytest.approx(2 * a * math.sqrt(times[k]), rel=1e-6)
    t_trial = times[-1] + 3e-3
    assert history(times, r, t_trial) == pytest.approx(2 * a * math.sqrt(t_trial), rel=1e-6)
    # long histories: the exponential tail keeps its accuracy over many decades of age
    times = np.concatenate([[0.0], np.geomspace(1e-6, 1e3, 300)])
    assert history(times, r) == pytest.approx(2 * a * math.sqrt(1e3), rel=1e-6)


def test_history_of_a_quadratic_converges_with_the_step():
    """r = t^2: H(t) = (8/3) t^(3/2); piecewise-linear r in the quadrature: error ~ h^1.5 or better."""
    errors = []
    for n in (25, 50, 100, 200):
        times = np.linspace(0.0, 1.0, n + 1)
        errors.append(abs(history(times, lambda t: t * t) - 8 / 3))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.4), orders
    assert errors[-1] < 1e-3 * 8 / 3


def stokes_basset_velocity(t, d, rho_s, xi):
    """Settling speed from rest, Stokes drag + added mass + Basset force, by Laplace transform.

    M v' = (rho_s - rho_f) V g - 6 pi mu a v - 6 a^2 sqrt(pi rho_f mu) int_0^t v'/sqrt(t - tau) dtau,
    M = (rho_s + xi rho_f) V.  With alpha = 6 pi mu a / M, b = 6 a^2 sqrt(pi rho mu) sqrt(pi) / M,
    gamma = (rho_s - rho_f) V g / M: V(s) = gamma / (s (s + b sqrt(s) + alpha)).  With p1, p2 the roots
    of p^2 + b p + alpha, 1/((sqrt(s)-p1)(sqrt(s)-p2)) = (1/(p1-p2)) (1/(sqrt(s)-p1) - 1/(sqrt(s)-p2)) and
    L^-1[1/(s (sqrt(s) - c))] = (exp(c^2 t) erfc(-c sqrt(t)) - 1) / c, exp(x^2) erfc(x) = w(i x) (Faddeeva).
    """
    a = d / 2
    vol = math.pi * d**3 / 6
    m_tot = (rho_s + xi * RHO_W) * vol
    alpha = 6 * math.pi * MU_W * a / m_tot
    b = 6 * a * a * math.sqrt(math.pi * RHO_W * MU_W) * math.sqrt(math.pi) / m_tot
    gamma = (rho_s - RHO_W) * vol * G / m_tot
    p1, p2 = np.roots([1.0, b, alpha]).astype(complex)
    t = np.asarray(t, float)

    def part(c):
        return (wofz(-1j * c * np.sqrt(t)) - 1.0) / c

    return (gamma / (p1 - p2) * (part(p1) - part(p2))).real, gamma / alpha


def simulate(integrator, times, steps_per_output, d, rho_s, xi):
    state = ParticleState.spheres([[0.0, 0.0, -1.0]], d / 2, Material(density=rho_s, kn=1e-3))
    model = FluidForces(0.0, air=None, xi=xi, basset=True, velocity_profile="uniform")
    h = (times[1] - times[0]) / steps_per_output
    if integrator == "rk4":
        return -integrate(state, [Gravity(), model], times, method="rk4", dt=h).vel[:, 0, 2]
    sim = DemSimulation(state, models=[model], integrator=integrator, dt=h, sleeping=False)
    got = [0.0]
    for _ in times[1:]:
        sim.step(steps_per_output)
        got.append(-state.vel[0, 2])
    return np.array(got)


D, RHO_S, XI = 1e-4, 2500.0, 0.5
TAU = (RHO_S + XI * RHO_W) * D * D / (18 * MU_W)


def test_closed_form_of_the_basset_settling():
    times = np.array([0.0, 10 * TAU, 1e3 * TAU, 1e5 * TAU])
    exact, v_t = stokes_basset_velocity(times, D, RHO_S, XI)
    assert exact[0] == pytest.approx(0.0, abs=1e-12 * v_t)
    # the history force slows the approach to v_t to ~ t^(-1/2): 100x the time, 10x closer
    gap = 1 - exact[2:] / v_t
    assert gap[0] / gap[1] == pytest.approx(10.0, rel=0.02)
    no_basset = v_t * (1 - math.exp(-10))
    assert exact[1] < 0.85 * no_basset  # the history force matters here


@pytest.mark.parametrize("integrator", ["predicted_verlet", "rk4"])
def test_stokes_settling_with_added_mass_and_basset_force(integrator):
    """Second-order schemes evaluated at the full-step velocity converge about as dt^1.5."""
    times = np.linspace(0.0, 10 * TAU, 51)
    exact, v_t = stokes_basset_velocity(times, D, RHO_S, XI)
    errors = [np.max(np.abs(simulate(integrator, times, n, D, RHO_S, XI) - exact)) / v_t for n in (4, 16)]
    assert errors[1] < 1e-3
    assert errors[0] / errors[1] > 4**1.3


@pytest.mark.parametrize("integrator", ["report", "velocity_verlet"])
def test_basset_with_half_step_velocity_schemes_converges_as_sqrt_dt(integrator):
    """The report's scheme and plain velocity Verlet evaluate the force at a half-step velocity paired with
    the end of the step; the last-step history term 2 (r - r_n)/sqrt(dt) turns that O(a dt) lag into an
    O(sqrt(dt)) error (documented: use predicted_verlet or free flight with the Basset force)."""
    times = np.linspace(0.0, 10 * TAU, 51)
    exact, v_t = stokes_basset_velocity(times, D, RHO_S, XI)
    errors = [np.max(np.abs(simulate(integrator, times, n, D, RHO_S, XI) - exact)) / v_t for n in (20, 320)]
    assert errors[1] < 5e-3
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.3)  # 16x the steps, sqrt: 4x the accuracy
