"""Time integrators of the DEM, chosen by name from the registry ``breachflow.integrators``.

Each integrator is a class with one method ``step(sim, dt)`` that advances the awake particles
``sim.idx`` by one step. It obtains forces only through the simulation's force assembly
(:meth:`~breachflow.dem.simulation.DemSimulation.contact_forces`, :meth:`~breachflow.dem.simulation.DemSimulation.body_forces`,
:meth:`~breachflow.dem.simulation.DemSimulation.global_damping`, :meth:`~breachflow.dem.simulation.DemSimulation.inverse_mass`) and never knows which
force models (fluid, ...) exist: ``a = (F_contacts + F_gravity + sum(models) + F_damping) / (m + m_added)``.
An integrator with a memory between steps saves it through ``state_arrays`` / ``restore_state``
(:mod:`.memory`).

* ``"report"`` — the report's predictor–refinement scheme (Fig 4.3 Steps 7F–7J, docs/theory.md, *DEM contact*);
* ``"velocity_verlet"`` — kick–drift–kick velocity Verlet as in LAMMPS ``fix nve/sphere``: the
  velocity-dependent forces (dashpots, history increments) use the half-step velocity;
* ``"predicted_verlet"`` — velocity Verlet whose velocity-dependent forces use the predicted
  full-step velocity ``v(t+1) ~ v(t+1/2) + dt/2 [a(t) + 3/4 (a(t) - a(t-1))]``. With a dashpot the
  half-step velocity lags by ``a dt/2``, a first-order error in the dissipated energy; the prediction
  removes it, so the restitution coefficient converges at second order (measured on errors averaged
  over 8 onset and 4 release phases, tests/dem/test_impact_phases.py: 0.42 / 0.067 / 0.019 % at ~10 /
  20 / 40 steps per contact, zeta 0.3; velocity_verlet 4.1 / 2.4 / 1.3 %, first order).

Both Verlet integrators average contact forces over their force interval ``[t - dt/2, t + dt/2]``
(:func:`.contact_law.contact_law`), so an impact does not depend on where in a step the contact begins
or ends; ``report`` evaluates contacts at points (as the report does).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..registry import Registry
from . import memory
from .wall_contacts import max_speed

integrators: Registry = Registry("DEM integrator", "breachflow.integrators", default="predicted_verlet")


@numba.njit(cache=True, error_model="numpy")
def kick(idx, vel, omega, force, torque, inv_m, inv_i, h, lmask, rmask):
    """v += h F/m, w += h T/I (per-axis masks select the 2-D plane motion)."""
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            vel[i, d] += h * force[i, d] * inv_m[i] * lmask[d]
            omega[i, d] += h * torque[i, d] * inv_i[i] * rmask[d]


@numba.njit(cache=True, error_model="numpy")
def drift(idx, pos, vel, dt):
    """x += v dt; returns (max, sum) of the step displacement ``|v dt|`` (report Step 11)."""
    mx = 0.0
    sm = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        s = 0.0
        for d in range(3):
            pos[i, d] += vel[i, d] * dt
            s += vel[i, d] * vel[i, d]
        s = np.sqrt(s) * dt
        sm += s
        if s > mx:
            mx = s
    return mx, sm


@numba.njit(cache=True, error_model="numpy")
def predict(idx, vel, omega, force, torque, inv_m, inv_i, h, lmask, rmask, vout, wout):
    """vout = v + h F/m (and the same for rotation) without touching v."""
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            vout[i, d] = vel[i, d] + h * force[i, d] * inv_m[i] * lmask[d]
            wout[i, d] = omega[i, d] + h * torque[i, d] * inv_i[i] * rmask[d]


@numba.njit(cache=True, error_model="numpy")
def predict_extrapolated(idx, vel, omega, force, torque, force_prev, torque_prev, inv_m, inv_i, h, c, lmask, rmask,
                         vout, wout):
    """vout = v + h (F + c (F - F_prev))/m (same for rotation), then F_prev = F; v untouched."""
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            f = force[i, d]
            t = torque[i, d]
            vout[i, d] = vel[i, d] + h * (f + c * (f - force_prev[i, d])) * inv_m[i] * lmask[d]
            wout[i, d] = omega[i, d] + h * (t + c * (t - torque_prev[i, d])) * inv_i[i] * rmask[d]
            force_prev[i, d] = f
            torque_prev[i, d] = t


@numba.njit(cache=True, error_model="numpy")
def report_half(idx, v_prev, v, w_prev, w, force, torque, inv_m, inv_i, dt, lmask, rmask, vh, wh):
    """Report Step 7G/7I: ``v(t+1/2) = (v(t-1) + v(t))/2 + a dt`` (same for rotation)."""
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            vh[i, d] = 0.5 * (v_prev[i, d] + v[i, d]) + dt * force[i, d] * inv_m[i] * lmask[d]
            wh[i, d] = 0.5 * (w_prev[i, d] + w[i, d]) + dt * torque[i, d] * inv_i[i] * rmask[d]


@numba.njit(cache=True, error_model="numpy")
def add_rows(idx, a, b, out_a, out_b):
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            out_a[i, d] = a[i, d]
            out_b[i, d] = b[i, d]


@numba.njit(cache=True, error_model="numpy")
def report_finish(idx, pos, vel, omega, v_prev, w_prev, vh, force, torque, inv_m, inv_i, dt, lmask, rmask):
    """Step 7J: x(t+1) = x + v(t+1/2) dt; v(t+1) = v + a dt; returns (max, sum) displacement."""
    mx = 0.0
    sm = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        s = 0.0
        for d in range(3):
            step = vh[i, d] * dt
            pos[i, d] += step
            s += step * step
            v_prev[i, d] = vel[i, d]
            w_prev[i, d] = omega[i, d]
            vel[i, d] += dt * force[i, d] * inv_m[i] * lmask[d]
            omega[i, d] += dt * torque[i, d] * inv_i[i] * rmask[d]
        s = np.sqrt(s)
        sm += s
        if s > mx:
            mx = s
    return mx, sm


@integrators.register("velocity_verlet")
class VelocityVerlet:
    """Kick–drift–kick velocity Verlet (second order for position-dependent forces).

    The force at ``t`` acts over ``[t - dt/2, t + dt/2]`` (half kicks on either side): contact forces are
    averaged over that interval (``force_interval``, :func:`.contact_law.contact_law`), so an impact's outcome
    does not depend on where in a step the contact begins or ends.
    """

    predict_velocity = False
    force_interval = (-0.5, 0.5)
    #: predicted_verlet: weight of the force trend in the velocity predictor (0.75: see the class)
    extrapolate = 0.0

    def step(self, sim, dt: float):
        s, w, idx = sim.state, sim.work, sim.idx
        if sim.forces_stale:  # particles were inserted or woken: F(t) is needed for the first kick
            sim.refresh_forces()
            add_rows(idx, sim.force, sim.torque, w["fp"], w["tp"])  # no force trend known yet
        inv_m, inv_i = sim.inverse_mass()
        kick(idx, s.vel, s.omega, sim.force, sim.torque, inv_m, inv_i, 0.5 * dt, sim.lmask, sim.rmask)
        disp = drift(idx, s.pos, s.vel, dt)
        sim.after_drift(relist=False)
        if self.predict_velocity:
            predict_extrapolated(idx, s.vel, s.omega, sim.force, sim.torque, w["fp"], w["tp"], inv_m, inv_i, 0.5 * dt,
                                 self.extrapolate, sim.lmask, sim.rmask, w["v"], w["w"])
            vel, omega = w["v"], w["w"]
        else:
            vel, omega = s.vel, s.omega
        # the rebuild check with the interval's reach at the velocities the law uses (as steploop_fluid)
        reach_t = sim.interval_reach(self.force_interval)
        sim.pairs.relist_after_drift(0.0 if reach_t == 0.0 else reach_t * (
            max_speed(sim.idx, vel) if self.predict_velocity else disp[0] / dt))
        sim.contact_forces(s.pos, vel, omega, sim.force, sim.torque, self.force_interval, s.vel, s.omega)
        sim.body_forces(s.pos, vel, omega, sim.t + dt, sim.force, sim.torque)
        sim.global_damping(vel, omega, sim.force, sim.torque, 1.0)
        kick(idx, s.vel, s.omega, sim.force, sim.torque, inv_m, inv_i, 0.5 * dt, sim.lmask, sim.rmask)
        return disp


@integrators.register("predicted_verlet")
class PredictedVelocityVerlet(VelocityVerlet):
    """Velocity Verlet with velocity-dependent forces at the predicted full-step velocity
    ``v(t+1) ~ v(t+1/2) + dt/2 [a(t) + 3/4 (a(t) - a(t-1))]``: the half kick of the acceleration at
    ``t + 3/4 dt``, extrapolated from the last two steps (the force trend is kept between steps,
    ``work["fp"]``/``work["tp"]``). Without the trend term (``v(t+1/2) + a(t) dt/2``) the prediction lags
    by ``O(dt^2)`` and a dashpot dissipates too much: restitution -2.4 % at zeta 0.3 and 15 steps per
    contact; with it -0.2 % (tests/dem/test_impact_phases.py). The shear springs still advance with the
    half-step velocity that moves the positions."""

    predict_velocity = True
    extrapolate = 0.75


@integrators.register("report")
class ReportScheme:
    """The report's predictor–refinement scheme (Fig 4.3 Steps 7F–7J, docs/theory.md, *DEM contact*).

    7F: contacts + body forces at ``x(t), v(t)``, acceleration without damping or added mass;
    7G: ``v(t+1/2) = (v(t-1) + v(t))/2 + a dt``;
    7H/7I (``refinements`` times): body forces at the predicted ``x(t) + v(t+1/2) dt, v(t+1/2)``, plus
    half the global damping at ``v(t+1/2)``, divided by ``m + m_added``; recompute ``v(t+1/2)``;
    7J: ``x(t+1) = x(t) + v(t+1/2) dt``, ``v(t+1) = v(t) + a dt``.
    """

    def __init__(self, refinements: int = 1):
        self.refinements = int(refinements)

    def step(self, sim, dt: float):
        s, w, idx = sim.state, sim.work, sim.idx
        fc, tc, f, t = w["fc"], w["tc"], sim.force, sim.torque
        sim.contact_forces(s.pos, s.vel, s.omega, fc, tc)
        add_rows(idx, fc, tc, f, t)
        sim.body_forces(s.pos, s.vel, s.omega, sim.t, f, t)
        inv_m0, inv_i = sim.inverse_mass(added=False)
        report_half(idx, s.vel_prev, s.vel, s.omega_prev, s.omega, f, t, inv_m0, inv_i, dt, sim.lmask,
                    sim.rmask, w["v"], w["w"])
        inv_m, _ = sim.inverse_mass()
        xp = w["x"]
        for _ in range(self.refinements):
            add_rows(idx, s.pos, s.pos, xp, xp)
            drift(idx, xp, w["v"], dt)
            add_rows(idx, fc, tc, f, t)
            sim.body_forces(xp, w["v"], w["w"], sim.t + dt, f, t)
            sim.global_damping(w["v"], w["w"], f, t, 0.5)
            report_half(idx, s.vel_prev, s.vel, s.omega_prev, s.omega, f, t, inv_m, inv_i, dt, sim.lmask,
                        sim.rmask, w["v"], w["w"])
        disp = report_finish(idx, s.pos, s.vel, s.omega, s.vel_prev, s.omega_prev, w["v"], f, t, inv_m, inv_i,
                             dt, sim.lmask, sim.rmask)
        sim.after_drift()
        return disp
