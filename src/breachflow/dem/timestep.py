"""Stable time step of the explicit DEM (docs/theory.md, *DEM contact*).

A linear contact of stiffness k between effective mass m_eff oscillates at ``omega = sqrt(k/m_eff)``;
explicit central-difference schemes are stable for ``dt < 2/omega``, reduced by a dashpot of ratio
``zeta = c / (2 sqrt(k m_eff))`` to ``dt < 2 (sqrt(1 + zeta^2) - zeta) / omega``.

The stiffest contact is taken conservatively from the extreme properties present:

* normal: two of the lightest particles, ``m_eff = m_min/2``, stiffness ``max k_N``;
* tangential: the shear spring also turns the spheres (``I = 2/5 m r^2``), so a pair behaves as
  ``m_eff = m_min/7`` (``1/m + r^2/I`` per sphere = 3.5/m) with stiffness ``max k_S``;
* rolling spring (``rolling_friction`` mu_r > 0, :func:`.contact_law.rolling_law`): ``k_r = 2.25 k_N
  mu_r^2 R^2`` against the spin inertia ``2/5 m R^2`` alone (centre held), i.e. a linear mode of
  stiffness ``5.625 mu_r^2 max k_N`` on ``m_min``; it only matters for mu_r > ~0.6.

:func:`stable_dt` is that limit; :func:`recommended_dt` applies the documented safety factor
:data:`SAFETY` = 0.2 (i.e. about 16 steps per normal contact duration ``pi sqrt(m_eff/k)``, the usual
DEM practice of a fraction of the contact duration).

These are bounds of the central-difference scheme on one mode. ``predicted_verlet``'s force-trend
predictor (issue 12) is stable over a smaller range when contacts are damped: a resting column of two
spheres settles at 0.2 of this limit for every damping ratio tried (0.3–1.5) but diverges at 0.3 for
zeta >= 0.7 (tests/dem/impact_cases.py ``column_is_stable``) — keep user steps near the default.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

SAFETY = 0.2


def stable_dt(mass, kn, ks=None, c_cn=None, wall_kn=(), rolling_friction=None) -> float:
    """Critical time step (s) of the stiffest contact, see the module docstring."""
    mass = np.asarray(mass, float)
    if mass.size == 0:
        return math.inf
    m_min = float(mass.min())
    k_n = max([float(np.max(kn))] + [float(k) for k in wall_kn])
    k_s = float(np.max(ks)) if ks is not None else k_n
    c = float(np.max(c_cn)) if c_cn is not None else 0.0
    modes = [(k_n, m_min / 2.0, c), (k_n, m_min, c), (k_s, m_min / 7.0, 0.0)]
    if rolling_friction is not None and np.size(rolling_friction):
        mu_r = float(np.max(rolling_friction))
        modes.append((5.625 * mu_r * mu_r * k_n, m_min, 0.0))
    limits = []
    for k, m_eff, damp in modes:
        if k <= 0:
            continue
        omega = math.sqrt(k / m_eff)
        zeta = damp / (2.0 * math.sqrt(k * m_eff))
        limits.append(2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / omega)
    return min(limits) if limits else math.inf


def recommended_dt(mass, kn, ks=None, c_cn=None, wall_kn=()) -> float:
    """``SAFETY * stable_dt`` (s)."""
    return SAFETY * stable_dt(mass, kn, ks, c_cn, wall_kn)


def check_dt(dt: float, limit: float) -> float:
    """Return *dt* or raise InputError naming the stable limit."""
    if not (dt > 0 and math.isfinite(dt)):
        raise InputError(f"time step dt={dt!r} s must be finite and > 0")
    if dt > limit:
        raise InputError(
            f"time step dt={dt:.6g} s exceeds the stable limit {limit:.6g} s of the stiffest contact "
            f"(2/omega, docs/theory.md, DEM contact); use dt <= {limit:.6g} s (recommended {SAFETY * limit:.6g} s)")
    return dt
