"""Time integrators of the DEM, chosen by name from the registry ``breachflow.integrators``.

Each integrator is a class with one method ``step(sim, dt)`` that advances the awake particles
``sim.idx`` by one step. It obtains forces only through the simulation's force assembly
(:meth:`~breachflow.dem.simulation.DemSimulation.contact_forces`, :meth:`~breachflow.dem.simulation.DemSimulation.body_forces`,
:meth:`~breachflow.dem.simulation.DemSimulation.global_damping`, :meth:`~breachflow.dem.simulation.DemSimulation.inverse_mass`) and never knows which
force models (fluid, ...) exist: ``a = (F_contacts + F_gravity + sum(models) + F_damping) / (m + m_added)``.
An integrator with a memory between steps saves it through ``state_arrays`` / ``restore_state``
(:mod:`.memory`).

* ``"report"`` — the report's predictor–refinement scheme (Fig 4.3 Steps 7F–7J, SPEC §5);
* ``"velocity_verlet"`` — kick–drift–kick velocity Verlet as in LAMMPS ``fix nve/sphere``: the
  velocity-dependent forces (dashpots, history increments) use the half-step velocity;
* ``"predicted_verlet"`` — velocity Verlet whose velocity-dependent forces use the predicted
  full-step velocity ``v(t+1) ~ v(t+1/2) + dt/2 [a(t) + 3/4 (a(t) - a(t-1))]``. With a dashpot the
  half-step velocity lags by ``a dt/2``, a first-order error in the dissipated energy; the prediction
  removes it, so the restitution coefficient converges at second order (measured on errors averaged
  over 8 onset and 4 release phases, tests/dem/test_impact_phases.py: 0.42 / 0.067 / 0.019 % at ~10 /
  20 / 40 steps per contact, zeta 0.3; velocity_verlet 4.1 / 2.4 / 1.3 %, first order).

Both Verlet integrators average contact forces over their force window ``[t - dt/2, t + dt/2]``
(:func:`.contact_law.contact_law`), so an impact does not depend on where in a step the contact begins
or ends; ``report`` evaluates contacts at points (as the report does).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..registry import Registry
from . import memory
from .walls import max_speed

integrators: Registry = Registry("DEM integrator", "breachflow.integrators")


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
    averaged over that window (``force_window``, :func:`.contact_law.contact_law`), so an impact's outcome
    does not depend on where in a step the contact begins or ends.
    """

    predict_velocity = False
    force_window = (-0.5, 0.5)
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
        # the rebuild check with the window's reach at the velocities the law uses (as the compiled loop)
        reach_t = sim.window_reach(self.force_window)
        sim.relist_after_drift(0.0 if reach_t == 0.0 else reach_t * (
            max_speed(sim.idx, vel) if self.predict_velocity else disp[0] / dt))
        sim.contact_forces(s.pos, vel, omega, sim.force, sim.torque, self.force_window, s.vel, s.omega)
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
    """The report's predictor–refinement scheme (Fig 4.3 Steps 7F–7J, SPEC §5).

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


@integrators.register("adaptive_free_flight")
class AdaptiveFreeFlight:
    """Error-controlled steps for particles in free flight; a fixed-step contact integrator otherwise.

    While every awake particle is clear of all other particles and boundaries, the awake set moves by
    one step of an embedded Runge–Kutta pair (``method``: ``dopri5`` or ``bs32``, see
    :mod:`breachflow.fluid.freeflight`) of ``dx/dt = v``, ``(m + m_A(x)) dv/dt = F_G + sum(models) + d_GN``,
    ``I dw/dt = sum(torques) + d_GW`` (SPEC §5, §6), with the step size set by ``rtol``/``atol`` and
    bounded so no particle can close its clearance within the step (checked again after the step;
    a step that would end in contact is retried shorter).  When a particle comes within ``margin``
    (default half the neighbour-list skin) of a partner, the simulation steps the fixed ``dt`` of the
    ``contact`` integrator (``predicted_verlet`` by default) until it is clear again.

    The DEM driver asks :meth:`advance` for the step it took (``variable_step``).  Clearance is computed
    for planes (signed distance), height fields (bed maximum under the particle) and other particles
    (all active ones, brute force over the awake set); other boundary types always use the contact
    integrator.  The step-size estimate, the work counters and the contact integrator's memory are part of
    ``save_state`` (:meth:`state_arrays`, :mod:`.memory`).
    """

    variable_step = True

    def __init__(self, method: str = "dopri5", rtol: float = 1e-6, atol: float = 1e-9,
                 contact: str = "predicted_verlet", margin: float | None = None, max_step: float = math.inf):
        from ..errors import InputError
        from ..fluid.freeflight import TABLEAUX

        if method not in TABLEAUX or TABLEAUX[method].b_err is None:
            raise InputError(f"adaptive_free_flight: method must be an embedded pair (dopri5, bs32), got {method!r}")
        if not (rtol > 0 and atol > 0 and max_step > 0):
            raise InputError("adaptive_free_flight: rtol, atol and max_step must be > 0")
        self.tableau = TABLEAUX[method]
        self.method, self.rtol, self.atol = method, float(rtol), float(atol)
        self.contact = integrators.get(contact)() if isinstance(contact, str) else contact
        self.margin = margin
        self.max_step = float(max_step)
        self.h = None  # next free-flight step (s)
        #: work counters: accepted / rejected free-flight steps, fixed steps of the contact integrator
        self.free_steps = self.rejected = self.contact_steps = 0

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The controller's memory (:mod:`.memory`): next step ``h`` (NaN: none yet) and the work counters."""
        out = {"h": np.array(math.nan if self.h is None else self.h),
               "counters": np.array([self.free_steps, self.rejected, self.contact_steps], np.int64)}
        memory.save(self.contact, "contact.", out)
        return out

    def restore_state(self, arrays) -> None:
        """Take back :meth:`state_arrays`."""
        h = float(arrays["h"][()])
        self.h = None if math.isnan(h) else h
        self.free_steps, self.rejected, self.contact_steps = (int(c) for c in arrays["counters"])
        memory.restore(self.contact, "contact.", arrays, "contact integrator")

    def step(self, sim, dt: float):
        """One fixed step of the contact integrator (the protocol of the fixed-step integrators)."""
        self.contact_steps += 1
        return self.contact.step(sim, dt)

    def advance(self, sim, dt: float, t_limit: float = math.inf):
        """Advance the awake particles by one free-flight step (at most to *t_limit*) or, near contact,
        one contact step of *dt*; returns ``((max, sum) displacement, step taken)``."""
        margin = 0.5 * sim.skin if self.margin is None else float(self.margin)
        clear = clearance(sim)
        if not clear > margin:
            self.h = None
            return self.step(sim, dt), dt
        from ..fluid.freeflight import FreeFlight, attempt_step, next_step_size

        s, idx = sim.state, sim.idx
        mass_of = FreeFlight(s, sim.models).effective_mass
        n = s.n

        def rhs(t, y):
            pos, vel, om = (np.ascontiguousarray(y[:, k:k + 3]) for k in (0, 3, 6))
            f = np.zeros((n, 3))
            tq = np.zeros((n, 3))
            sim.body_forces(pos, vel, om, t, f, tq)
            sim.global_damping(vel, om, f, tq, 1.0)
            dy = np.zeros((n, 9))
            dy[idx, 0:3] = vel[idx]
            dy[idx, 3:6] = f[idx] / mass_of(pos)[idx, None] * sim.lmask
            dy[idx, 6:9] = tq[idx] * sim._inv_i[idx, None] * sim.rmask
            return dy

        tab = self.tableau
        y = np.hstack([s.pos, s.vel, s.omega])
        stages = np.empty((tab.b.size,) + y.shape)
        # two particles approach at up to twice the largest speed; a moving boundary adds its own
        closing = 2.0 * float(np.max(np.linalg.norm(s.vel[idx], axis=1))) + moving_boundary_speed(sim)
        floor = min(dt, t_limit - sim.t)  # never below the contact step, except to land on t_limit
        h = self.h if self.h is not None else 10.0 * dt
        while True:
            hh = min(h, self.max_step, t_limit - sim.t)
            if closing > 0:
                hh = min(hh, (clear - margin) / closing)
            hh = max(hh, floor)
            y_new, err = attempt_step(rhs, tab, sim.t, y, hh, stages, None, self.rtol, self.atol, True)
            if err > 1.0 and hh > floor:
                self.rejected += 1
                h = next_step_size(hh, err, tab.order, grow=1.0)
                continue
            s.pos[idx], s.vel[idx], s.omega[idx] = y_new[idx, 0:3], y_new[idx, 3:6], y_new[idx, 6:9]
            if hh > floor and not clearance(sim) > 0.0:  # the step would end in contact: retry shorter
                s.pos[idx], s.vel[idx], s.omega[idx] = y[idx, 0:3], y[idx, 3:6], y[idx, 6:9]
                self.rejected += 1
                h = 0.5 * hh
                continue
            break
        if hh > floor or self.h is None:
            self.h = next_step_size(hh, err, tab.order)
        self.free_steps += 1
        s.vel_prev[idx], s.omega_prev[idx] = s.vel[idx], s.omega[idx]
        sim.forces_stale = True  # the contact integrator's F(t) is not the free-flight one
        step = np.linalg.norm(y_new[idx, 0:3] - y[idx, 0:3], axis=1)
        sim.after_drift()
        return (float(step.max()), float(step.sum())), hh


def moving_boundary_speed(sim) -> float:
    """Largest boundary speed (m/s): moving planes close a particle's clearance too."""
    return max((float(np.linalg.norm(b.velocity)) for b in sim.boundaries if getattr(b, "moving", False)),
               default=0.0)


def clearance(sim) -> float:
    """Smallest gap (m) between an awake particle and any other active particle or boundary (inf if none);
    ``-inf`` when a boundary type has no gap rule (so free flight is never assumed)."""
    from .boundaries import HeightField, Plane

    s, idx = sim.state, sim.idx
    if idx.size == 0:
        return math.inf
    p, r = s.pos[idx], s.radius[idx]
    gap = math.inf
    act = np.flatnonzero(s.active)
    if act.size > 1:
        for k0 in range(0, idx.size, 256):
            d = np.linalg.norm(p[k0:k0 + 256, None, :] - s.pos[None, act, :], axis=2)
            d -= r[k0:k0 + 256, None] + s.radius[None, act]
            d[idx[k0:k0 + 256, None] == act[None, :]] = math.inf
            gap = min(gap, float(d.min()))
    for b in sim.boundaries:
        if isinstance(b, Plane):
            gap = min(gap, float(np.min((p - b.point) @ b.normal - r)))
        elif isinstance(b, HeightField):
            for (x, y, z), a in zip(p, r):
                ny, nx = b.bed.shape  # outside the grid the bed's edge values continue (clamped)
                j0 = min(max(int(math.floor((x - a - b.x0) / b.hx)), 0), nx - 1)
                k0 = min(max(int(math.floor((y - a - b.y0) / b.hy)), 0), ny - 1)
                j1 = min(max(int(math.ceil((x + a - b.x0) / b.hx)), j0), nx - 1)
                k1 = min(max(int(math.ceil((y + a - b.y0) / b.hy)), k0), ny - 1)
                top = float(b.bed[k0:k1 + 1, j0:j1 + 1].max())
                gap = min(gap, z - a - top)
        else:
            return -math.inf
    return gap
