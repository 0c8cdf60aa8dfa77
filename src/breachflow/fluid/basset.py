"""Basset history force (docs/theory.md, *Fluid forces on a mass*, report eq 3.13) with an O(1)-memory-per-particle history quadrature.

    f_H(t) = -phi 6 a^2 sqrt(pi rho_W mu_W) H(t),   H(t) = int_0^t r'(tau) / sqrt(t - tau) dtau

(``a`` radius, ``r = v - u`` the velocity relative to the water, ``phi`` the submerged fraction).

Quadrature.  ``r`` is taken piecewise linear between the committed states ``(t_k, r_k)`` of the
integrator (one per accepted step), so ``r'`` is constant on each step.  The near history, the last two
intervals, is integrated exactly: from the last committed state ``(t_n, r_n)`` to the evaluated
``(t, r)``, ``2 (r - r_n) / sqrt(t - t_n)``, and the last committed step,
``2 (r_n - r_(n-1)) / (sqrt(t - t_(n-1)) + sqrt(t - t_n))``.  Older history (ages >= one step) uses the kernel as a sum of exponentials,
``1/sqrt(s) ~ sum_i w_i exp(-lambda_i s)``, the trapezoidal rule in ``x = ln lambda`` of
``1/sqrt(s) = pi^(-1/2) int exp(-s e^x) e^(x/2) dx`` (Beylkin & Monzón 2005; the same idea as the
exponential tail of van Hinsberg et al. 2011 without storing the near history's samples), relative error below ~3e-7 for
``s`` in ``[s_min, s_max]`` (defaults 1e-8 s and 1e5 s, 112 terms).  Each term's history
``Z_i(t_(n-1)) = int_0^t_(n-1) r' exp(-lambda_i (t_(n-1) - tau)) dtau`` is advanced exactly when an
interval leaves the near history, ``Z_i <- exp(-lambda_i dt) Z_i + r'_k (1 - exp(-lambda_i dt)) / lambda_i``, so a
particle stores ``Z`` (M, 3) and two states however long it has been moving, and
``H(t) = sum_i w_i exp(-lambda_i (t - t_(n-1))) Z_i + (the two exact near-history terms)``.  Steps shorter than
``s_min`` would leave the kernel's accurate range.

The history starts when the particle is first seen (release), with no initial-slip term.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import InputError

#: spacing of the trapezoidal rule in ``ln lambda`` and the extra range beyond ``[1/s_max, 1/s_min]``
STEP, EXTRA_LOW, EXTRA_HIGH = 0.6, 32.0, 5.0


def kernel_exponentials(s_min: float = 1e-8, s_max: float = 1e5) -> tuple[np.ndarray, np.ndarray]:
    """Rates ``lambda_i`` (1/s) and weights ``w_i`` (1/sqrt(s)) with ``sum w_i exp(-lambda_i s) ~ 1/sqrt(s)``."""
    if not (0 < s_min < s_max < math.inf):
        raise InputError(f"Basset kernel: need 0 < s_min < s_max, got {s_min!r}, {s_max!r}")
    x = np.arange(-math.log(s_max) - EXTRA_LOW, -math.log(s_min) + EXTRA_HIGH + 1e-12, STEP)
    return np.exp(x), STEP * np.exp(0.5 * x) / math.sqrt(math.pi)


@numba.njit(cache=True)
def history_integral(r, t, t_hist, r_hist, z, lam, w, out):
    """``out[i] = H_i(t)`` (N,3) for particles with relative velocity *r* (N,3) at time *t* (module docstring).

    ``t_hist`` (N,2) and ``r_hist`` (N,2,3) hold the last two committed states ``n-1``, ``n``; ``z`` (N,M,3)
    the exponential histories at ``t_(n-1)``.
    """
    for i in range(r.shape[0]):
        s1 = max(t - t_hist[i, 1], 0.0)
        s0 = max(t - t_hist[i, 0], 0.0)
        e_last = 2.0 / math.sqrt(s1) if s1 > 0.0 else 0.0
        e_prev = 2.0 / (math.sqrt(s0) + math.sqrt(s1)) if s0 > 0.0 else 0.0
        for d in range(3):
            out[i, d] = e_last * (r[i, d] - r_hist[i, 1, d]) + e_prev * (r_hist[i, 1, d] - r_hist[i, 0, d])
        for m in range(lam.shape[0]):
            wm = w[m] * math.exp(-lam[m] * s0)
            for d in range(3):
                out[i, d] += wm * z[i, m, d]


@numba.njit(cache=True)
def commit_history(r, t, t_hist, r_hist, z, lam):
    """Record the accepted state ``(t, r)``: the interval ``[t_(n-1), t_n]`` leaves the exactly integrated
    near history and enters the exponential histories (exact update for ``r`` linear on it), then the near
    history moves on by one step."""
    for i in range(r.shape[0]):
        if not t > t_hist[i, 1]:
            continue
        dt = t_hist[i, 1] - t_hist[i, 0]
        if dt > 0.0:
            for m in range(lam.shape[0]):
                decay = math.exp(-lam[m] * dt)
                gain = -math.expm1(-lam[m] * dt) / (lam[m] * dt)
                for d in range(3):
                    z[i, m, d] = decay * z[i, m, d] + (r_hist[i, 1, d] - r_hist[i, 0, d]) * gain
        t_hist[i, 0] = t_hist[i, 1]
        t_hist[i, 1] = t
        for d in range(3):
            r_hist[i, 0, d] = r_hist[i, 1, d]
            r_hist[i, 1, d] = r[i, d]


class BassetHistory:
    """Per-particle history of the relative velocity and the history integral ``H`` (module docstring).

    :meth:`integral` evaluates ``H`` at any trial state (integrator stages); :meth:`commit` records an
    accepted state.  Particles are rows of the DEM state; new rows start their history at their first commit.
    """

    def __init__(self, s_min: float = 1e-8, s_max: float = 1e5):
        self.lam, self.w = kernel_exponentials(s_min, s_max)
        self.t_hist = np.zeros((0, 2))
        self.r_hist = np.zeros((0, 2, 3))
        self.z = np.zeros((0, self.lam.size, 3))
        self.known = np.zeros(0, bool)

    def _grow(self, n):
        if n > self.known.size:
            k = self.known.size
            self.t_hist = np.concatenate([self.t_hist, np.zeros((n - k, 2))])
            self.r_hist = np.concatenate([self.r_hist, np.zeros((n - k, 2, 3))])
            self.z = np.concatenate([self.z, np.zeros((n - k, self.lam.size, 3))])
            self.known = np.concatenate([self.known, np.zeros(n - k, bool)])

    _MEMORY = ("t_hist", "r_hist", "z", "known")

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The history (near-history states, exponential sums, which rows started), copied."""
        return {name: getattr(self, name).copy() for name in self._MEMORY}

    def restore_state(self, arrays) -> None:
        """Take back :meth:`state_arrays` (the kernel, i.e. ``s_min``/``s_max``, must be the same)."""
        if arrays["z"].shape[1:] != (self.lam.size, 3):
            raise InputError(f"Basset history saved with {arrays['z'].shape[1]} kernel terms, this one has "
                             f"{self.lam.size} (a different basset_range)")
        for name in self._MEMORY:
            setattr(self, name, np.array(arrays[name], copy=True))

    def integral(self, idx, r, t) -> np.ndarray:
        """``H`` (len(idx), 3) of particles *idx* at relative velocities *r* at time *t* (unseen: 0)."""
        self._grow(int(idx.max()) + 1 if idx.size else 0)
        out = np.zeros((idx.size, 3))
        seen = self.known[idx]
        if seen.all():
            history_integral(r, t, self.t_hist[idx], self.r_hist[idx], self.z[idx], self.lam, self.w, out)
        elif seen.any():
            sub = np.empty((int(seen.sum()), 3))
            i = idx[seen]
            history_integral(np.ascontiguousarray(r[seen]), t, self.t_hist[i], self.r_hist[i], self.z[i],
                             self.lam, self.w, sub)
            out[seen] = sub
        return out

    def commit(self, idx, r, t) -> None:
        """Record the accepted relative velocities *r* of particles *idx* at time *t*."""
        self._grow(int(idx.max()) + 1 if idx.size else 0)
        new = ~self.known[idx]
        if new.any():  # history starts now
            i = idx[new]
            self.t_hist[i] = t
            self.r_hist[i] = r[new][:, None, :]
            self.z[i] = 0.0
            self.known[i] = True
        t_hist, r_hist, z = self.t_hist[idx], self.r_hist[idx], self.z[idx]
        commit_history(np.ascontiguousarray(r), float(t), t_hist, r_hist, z, self.lam)
        self.t_hist[idx], self.r_hist[idx], self.z[idx] = t_hist, r_hist, z


def basset_coefficient(radius, rho, mu):
    """``6 a^2 sqrt(pi rho mu)`` (kg s^-1/2) per particle: ``f_H = -coef phi H`` (docs/theory.md, *Fluid forces on a mass*, eq 3.13)."""
    return 6.0 * np.asarray(radius) ** 2 * math.sqrt(math.pi * rho * mu)
