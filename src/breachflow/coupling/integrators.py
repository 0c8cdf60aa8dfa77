"""The ``adaptive_free_flight`` DEM integrator: error-controlled Runge–Kutta steps of the particles in free
flight through the fluid (:mod:`breachflow.fluid.freeflight`), the fixed-step contact integrator of
:mod:`breachflow.dem.integrators` near contact. Registered in the DEM's integrator registry
``breachflow.integrators`` (entry point), as a third-party integrator would be."""
from __future__ import annotations

import math

import numpy as np

from ..dem import memory
from ..dem.integrators import integrators


@integrators.register("adaptive_free_flight")
class AdaptiveFreeFlight:
    """Error-controlled steps for particles in free flight; a fixed-step contact integrator otherwise.

    While every awake particle is clear of all other particles and boundaries, the awake set moves by
    one step of an embedded Runge–Kutta pair (``method``: ``dopri5`` or ``bs32``, see
    :mod:`breachflow.fluid.freeflight`) of ``dx/dt = v``, ``(m + m_A(x)) dv/dt = F_G + sum(models) + d_GN``,
    ``I dw/dt = sum(torques) + d_GW`` (docs/theory.md, *DEM contact*, *Fluid forces on a mass*), with the step size set by ``rtol``/``atol`` and
    bounded so no particle can close its clearance within the step (checked again after the step;
    a step that would end in contact is retried shorter).  When a particle comes within ``margin``
    (default half the neighbour-list skin) of a partner, the simulation steps the fixed ``dt`` of the
    ``contact`` integrator (``predicted_verlet`` by default) until it is clear again.

    The DEM driver asks :meth:`advance` for the step it took (``variable_step``).  Clearance is computed
    for planes (signed distance), height fields (bed maximum under the particle) and other particles
    (all active ones, brute force over the awake set); other boundary types always use the contact
    integrator.  The step-size estimate, the work counters and the contact integrator's memory are part of
    ``save_state`` (:meth:`state_arrays`, :mod:`breachflow.dem.memory`).
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
        self.contact = integrators.create(contact)
        self.margin = margin
        self.max_step = float(max_step)
        self.h = None  # next free-flight step (s)
        #: work counters: accepted / rejected free-flight steps, fixed steps of the contact integrator
        self.free_steps = self.rejected = self.contact_steps = 0

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The controller's memory (:mod:`breachflow.dem.memory`): next step ``h`` (NaN: none yet) and the work counters."""
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
    from ..dem.boundaries import HeightField, Plane

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
