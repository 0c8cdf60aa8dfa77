"""Time integration of particles without contacts (free flight through air and water), fixed or adaptive.

The DEM's integrators step every particle with one small step set by contact stiffness (docs/theory.md, *DEM contact*: a
fraction of ``pi sqrt(m / k_N)``; the report used 1e-5 s).  A particle that touches nothing only feels
gravity and the fluid, whose time scales (``tau ~ v_t / g``, the crossing time ``D / v`` of the free
surface) are many orders longer, so there an error-controlled explicit Runge–Kutta pair takes steps as
large as the accuracy allows.  Equations (docs/theory.md, *Fluid forces on a mass*):

    dx/dt = v,   (m + m_A(x)) dv/dt = F_G + sum(models.accumulate),   I dw/dt = sum(torques)

with ``m_A`` the models' added mass at the stage position.  Fixed-step tableaux (``euler``, ``heun``,
``rk4``) and embedded pairs (``bs32`` Bogacki–Shampine 3(2), ``dopri5`` Dormand–Prince 5(4)) share one
driver.  Step-size control: standard ``h_new = h * clip(0.9 err^(-1/(q+1)), 0.2, 5)`` with the scaled
max-norm ``err = max |e| / (atol + rtol |y|)`` over positions, velocities and spins (Hairer, Nørsett &
Wanner I, §II.4).  Requested output times are hit exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, PhysicsError


@dataclass(frozen=True)
class Tableau:
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    b_err: np.ndarray | None = None  # b - b_hat of an embedded pair
    order: int = 1  # order of the propagated solution
    fsal: bool = False


def _t(a, b, c, b_err=None, order=1, fsal=False):
    return Tableau(np.array(a, float), np.array(b, float), np.array(c, float),
                   None if b_err is None else np.array(b_err, float), order, fsal)


TABLEAUX = {
    "euler": _t([[0.0]], [1.0], [0.0], order=1),
    "heun": _t([[0, 0], [1, 0]], [0.5, 0.5], [0, 1], order=2),
    "rk4": _t([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]], [1 / 6, 1 / 3, 1 / 3, 1 / 6],
              [0, 0.5, 0.5, 1], order=4),
    "bs32": _t([[0, 0, 0, 0], [1 / 2, 0, 0, 0], [0, 3 / 4, 0, 0], [2 / 9, 1 / 3, 4 / 9, 0]],
               [2 / 9, 1 / 3, 4 / 9, 0], [0, 1 / 2, 3 / 4, 1],
               b_err=np.array([2 / 9, 1 / 3, 4 / 9, 0]) - np.array([7 / 24, 1 / 4, 1 / 3, 1 / 8]), order=3, fsal=True),
    "dopri5": _t(
        [[0, 0, 0, 0, 0, 0, 0],
         [1 / 5, 0, 0, 0, 0, 0, 0],
         [3 / 40, 9 / 40, 0, 0, 0, 0, 0],
         [44 / 45, -56 / 15, 32 / 9, 0, 0, 0, 0],
         [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0, 0],
         [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0, 0],
         [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0]],
        [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0],
        [0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1],
        b_err=np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0])
        - np.array([5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]),
        order=5, fsal=True),
}


class FreeFlight:
    """Right-hand side of contact-free particle motion under *models* (each a DEM ``ForceModel``).

    ``state`` is a DEM :class:`~breachflow.dem.state.ParticleState` (only ``radius``, ``mass``,
    ``inertia``, ``active``/``awake`` are read; positions and velocities are passed explicitly).
    """

    def __init__(self, state, models):
        self.state = state
        self.models = list(models)
        self.evaluations = 0

    def effective_mass(self, pos):
        m = self.state.mass.copy()
        for model in self.models:
            try:
                extra = model.added_mass(self.state, pos=pos)
            except TypeError:  # models whose added mass does not depend on position
                extra = model.added_mass(self.state)
            if extra is not None:
                m += extra
        return m

    def commit(self, t, y):
        """Tell models with a memory (the Basset history) the accepted state ``y`` at time *t*."""
        for model in self.models:
            commit = getattr(model, "commit", None)
            if commit is not None:
                commit(self.state, np.ascontiguousarray(y[:, 0:3]), np.ascontiguousarray(y[:, 3:6]), t)

    def __call__(self, t, y):
        """``dy/dt`` for ``y = (pos, vel, omega)`` stacked as an (N, 9) array."""
        self.evaluations += 1
        pos, vel, om = y[:, 0:3], y[:, 3:6], y[:, 6:9]
        force = np.zeros_like(pos)
        torque = np.zeros_like(pos)
        for model in self.models:
            model.accumulate(self.state, pos, vel, om, t, force, torque)
        m = self.effective_mass(pos)
        dy = np.empty_like(y)
        dy[:, 0:3] = vel
        dy[:, 3:6] = force / m[:, None]
        dy[:, 6:9] = torque / self.state.inertia[:, None]
        return dy


@dataclass
class FlightResult:
    """Trajectory at the output times: ``t`` (T,), ``pos``/``vel``/``omega`` (T, N, 3); work counters."""

    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    omega: np.ndarray
    steps: int
    rejected: int
    evaluations: int


def integrate(state, models, t_eval, *, method: str = "dopri5", dt: float | None = None, rtol: float = 1e-6,
              atol: float = 1e-9, first_step: float | None = None, max_step: float = np.inf,
              stop=None) -> FlightResult:
    """Integrate contact-free motion from ``state`` (at ``t_eval[0]``) and return it at the times *t_eval*.

    Fixed-step methods need *dt*; embedded pairs adapt the step to ``rtol``/``atol`` unless *dt* is given.
    ``stop(t, y) -> bool`` ends the run early (e.g. before the first contact); outputs after it are NaN.
    The state is not modified.
    """
    if method not in TABLEAUX:
        raise InputError(f"free-flight method {method!r} unknown; available: {', '.join(TABLEAUX)}")
    tab = TABLEAUX[method]
    adaptive = tab.b_err is not None and dt is None
    if not adaptive and (dt is None or not dt > 0):
        raise InputError(f"free-flight method {method!r} needs a time step dt > 0")
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size < 1 or np.any(np.diff(t_eval) < 0):
        raise InputError("t_eval must be a non-empty increasing 1-D array of times (s)")
    rhs = FreeFlight(state, models)
    y = np.hstack([state.pos, state.vel, state.omega]).astype(float)
    rhs.commit(float(t_eval[0]), y)
    n = y.shape[0]
    out = np.full((t_eval.size, n, 9), np.nan)
    out[0] = y
    t = float(t_eval[0])
    h = dt if not adaptive else (first_step or _initial_step(rhs, t, y, tab.order, rtol, atol))
    steps = rejected = 0
    k_first = None
    stages = np.empty((tab.b.size,) + y.shape)
    for j in range(1, t_eval.size):
        target = float(t_eval[j])
        while t < target - 1e-14 * max(1.0, abs(target)):
            hh = min(h, max_step, target - t)
            # a fixed step that would leave a sliver before the output time is split evenly instead
            if not adaptive and target - t - hh < 1e-9 * hh:
                hh = target - t
            y_new, err = attempt_step(rhs, tab, t, y, hh, stages, k_first, rtol, atol, adaptive)
            if adaptive:
                if err > 1.0:
                    rejected += 1
                    h = next_step_size(hh, err, tab.order, grow=1.0)
                    k_first = stages[0].copy() if tab.fsal else None
                    continue
                h_next = next_step_size(hh, err, tab.order)
                if hh == target - t and h > hh:  # a step shortened to hit an output does not shrink h
                    h_next = max(h_next, h)
                h = h_next
            t += hh
            y = y_new
            steps += 1
            rhs.commit(t, y)
            k_first = stages[-1].copy() if tab.fsal else None  # FSAL: last stage is f(t + h, y_new)
            if stop is not None and stop(t, y):
                out[j] = y
                return _result(t_eval, out, steps, rejected, rhs.evaluations)
        out[j] = y
    return _result(t_eval, out, steps, rejected, rhs.evaluations)


def attempt_step(rhs, tab: Tableau, t: float, y, h: float, stages, k_first=None, rtol: float = 0.0,
                 atol: float = 0.0, with_error: bool = False):
    """One explicit Runge–Kutta step of size *h* from ``(t, y)``: ``y_new = y + h sum_s b_s k_s``.

    *stages* (S, *y.shape*) receives the stage derivatives ``k_s``; *k_first* (FSAL) replaces the first
    evaluation.  With *with_error*, also the scaled error ``max |h sum_s (b - b_hat)_s k_s| / (atol + rtol |y|)``
    (HNW I §II.4), else ``0.0``.  The one RK step of :func:`integrate` and of the DEM's adaptive free flight.
    """
    for s in range(tab.b.size):
        if s == 0 and k_first is not None:
            stages[0] = k_first
            continue
        ys = y + h * np.tensordot(tab.a[s, :s], stages[:s], axes=1) if s else y
        stages[s] = rhs(t + tab.c[s] * h, ys)
    y_new = y + h * np.tensordot(tab.b, stages, axes=1)
    if not np.all(np.isfinite(y_new)):
        raise PhysicsError(f"free flight became non-finite at t={t:.6g} s (step {h:.3g} s too large?)")
    if not with_error:
        return y_new, 0.0
    err_vec = h * np.tensordot(tab.b_err, stages, axes=1)
    scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
    return y_new, float(np.max(np.abs(err_vec) / scale))


def next_step_size(h: float, err: float, order: int, grow: float = 5.0) -> float:
    """``h * clip(0.9 err^(-1/order), 0.2, grow)``: the standard controller of an embedded pair whose error
    estimate is of order ``order - 1`` (HNW I §II.4)."""
    fac = 0.9 * (err if err > 0 else 1e-10) ** (-1.0 / order)
    return h * min(grow, max(0.2, fac))


def _result(t_eval, out, steps, rejected, evaluations):
    return FlightResult(t_eval, out[:, :, 0:3].copy(), out[:, :, 3:6].copy(), out[:, :, 6:9].copy(),
                        steps, rejected, evaluations)


def _initial_step(rhs, t, y, order, rtol, atol):
    """Hairer's starting-step heuristic (HNW I, II.4)."""
    f0 = rhs(t, y)
    scale = atol + rtol * np.abs(y)
    d0 = np.max(np.abs(y) / scale)
    d1 = np.max(np.abs(f0) / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    f1 = rhs(t + h0, y + h0 * f0)
    d2 = np.max(np.abs(f1 - f0) / scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1)
