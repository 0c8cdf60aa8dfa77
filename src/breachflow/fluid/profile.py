"""The velocity a mass feels: vertical profiles of the depth-averaged flow, averaged over the mass's height.

The hydrodynamic field is depth averaged (SPEC §4): one velocity ``U`` per gridpoint. A mass resting
near the bed sees much less than ``U``; one near the surface a little more. This module holds the ONE
definition of that vertical profile, ``u(z) = U * profile_factor(code, z, h, k_s)``, and of the velocity
the drag of a whole mass sees, ``U * drag_factor(...)`` (:func:`drag_factor`, :func:`wetted_factor`: the
signed root of the mean of ``f|f|`` over the wetted projected area of the sphere, SPEC §6 drag with
``u_fluid`` varying over the height), used by :class:`~breachflow.fluid.forces.FluidForces` and the fused
kernels of :mod:`breachflow.fluid.compiled` (call them from numba).

Profiles (by name, :data:`PROFILES`):

``uniform`` (code 0)
    ``u(z)/U = 1`` at every height: the report's (and breachflow's earlier) behaviour.
``log`` (code 1)
    Rough-wall log law ``u(z) = (u*/kappa) ln(z/z0)``, ``z0 = k_s/30`` (Nikuradse), depth-averaged
    over ``z0 .. h`` to ``U = (u*/kappa) (ln(h/z0) - 1)``, hence
    ``u(z)/U = ln(30 z/k_s) / (ln(30 h/k_s) - 1)``. The factor is 0 at ``z <= z0`` and is held at its
    surface value above ``h``. Where the flow is so shallow or rough that ``ln(30 h/k_s) <= 2``
    (``h <= e^2 k_s/30 ~ 0.25 k_s``, a log layer does not exist), the profile is uniform.
``power`` (code 2)
    One-seventh power law ``u(z) = u_s (z/h)^(1/7)``, depth average ``7/8 u_s``, hence
    ``u(z)/U = (8/7) (z/h)^(1/7)``, held at ``8/7`` above the surface.

The roughness height ``k_s`` comes from Manning's n through the Manning–Strickler relation in Parker's
form ``U/u* = 8.1 (h/k_s)^(1/6)``, which with Manning ``U = h^(2/3) S^(1/2)/n`` and ``u* = sqrt(g h S)``
gives ``n = k_s^(1/6) / (8.1 sqrt(g))`` (Parker 1991; Garcia (ed.) 2008, ASCE Manual 110, ch. 2):
:func:`roughness_from_manning`. For n = 0.025 this gives k_s = 0.066 m.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import InputError

#: profile names and the integer codes :func:`profile_factor` takes
PROFILES = {"uniform": 0, "log": 1, "power": 2}

#: Manning–Strickler coefficient (Parker 1991): ``U/u* = 8.1 (h/k_s)^(1/6)``
STRICKLER_A = 8.1


def profile_code(name: str) -> int:
    """The integer code of a profile name (``uniform``, ``log``, ``power``); InputError otherwise."""
    try:
        return PROFILES[name]
    except (KeyError, TypeError):
        raise InputError(f"velocity profile {name!r} unknown; use one of {sorted(PROFILES)}") from None


def roughness_from_manning(n, gravity: float = 9.80665):
    """Nikuradse roughness height ``k_s = (8.1 sqrt(g) n)^6`` (m) from Manning's n (s m^-1/3)."""
    n = np.asarray(n, dtype=float)
    if np.any(~np.isfinite(n)) or np.any(n < 0):
        raise InputError(f"Manning's n must be finite and >= 0, got {n!r}")
    return (STRICKLER_A * math.sqrt(gravity) * n) ** 6


@numba.njit(cache=True, nogil=True)
def profile_factor(code, z_above_bed, depth, k_s):
    """``u(z)/U`` at height *z_above_bed* (m) above the bed in water *depth* (m) over roughness *k_s* (m).

    *code*: 0 uniform, 1 log law, 2 power law 1/7 (see the module docstring for the formulas).
    Returns 1 for a dry cell (``depth <= 0``) or an unknown code.
    """
    if code == 0 or depth <= 0.0:
        return 1.0
    z = min(z_above_bed, depth)
    if code == 1:
        if k_s <= 0.0:
            return 1.0
        denom = math.log(30.0 * depth / k_s) - 1.0
        if denom <= 1.0:
            return 1.0
        arg = 30.0 * z / k_s
        if arg <= 1.0:
            return 0.0
        return math.log(arg) / denom
    if code == 2:
        if z <= 0.0:
            return 0.0
        return (8.0 / 7.0) * (z / depth) ** (1.0 / 7.0)
    return 1.0


@numba.njit(cache=True, nogil=True)
def profile_factors(code, z_above_bed, depth, k_s, out):
    """Vectorised :func:`profile_factor` over arrays (``k_s`` an array of the same length)."""
    for i in range(out.shape[0]):
        out[i] = profile_factor(code, z_above_bed[i], depth[i], k_s[i])


def factors(name_or_code, z_above_bed, depth, k_s) -> np.ndarray:
    """Numpy front end of :func:`profile_factor` (broadcasts its arguments)."""
    code = profile_code(name_or_code) if isinstance(name_or_code, str) else int(name_or_code)
    z, h, k = np.broadcast_arrays(np.asarray(z_above_bed, float), np.asarray(depth, float), np.asarray(k_s, float))
    shape = z.shape
    out = np.empty(z.size)
    profile_factors(code, np.ascontiguousarray(z.ravel()), np.ascontiguousarray(h.ravel()),
                    np.ascontiguousarray(k.ravel()), out)
    return out.reshape(shape)


# -- the profile averaged over a mass's wetted height ---------------------------------------------------
#: Gauss–Legendre points of :func:`drag_factor`'s rule. Against ``scipy.integrate.quad`` over 400 random
#: cases (centre on / pressed into the bed, across the surface, inside the water, anywhere; h 0.3–10 m,
#: r 0.05–3 m, k_s 0.005–0.5 m, 0.066 m and 2r) the largest relative error of the factor is
#: 1.8e-3 / 1.0e-3 / 3.7e-4 / 1.4e-4 (log) and 2.5e-3 / 1.6e-3 / 8.1e-4 / 4.7e-4 (power) for 5 / 6 / 8 / 10
#: points, the median 5e-10 (log) and 3e-9 (power) at 8 (``benchmarks/bench_drag_points.py``; the test
#: ``tests/fluid/test_wetted_drag.py`` holds 1e-3): 8 keeps the drag (the factor squared) within 0.16 %,
#: far below the drag law's own uncertainty (SPEC §6), at 130 ns per call (the point value: 9 ns). The
#: error is largest where the log law's ``z0`` cut or the power law's ``z^(1/7)`` meets the bottom of a
#: mass resting on the bed (an algebraic end behaviour the rule does not resolve).
DRAG_POINTS = 8
_GL_T, _GL_W = np.polynomial.legendre.leggauss(DRAG_POINTS)


@numba.njit(cache=True, nogil=True)
def _cubic_t(x):
    """The ``t`` in ``[-1, 1]`` with ``x = (3t - t^3)/2`` (``x`` clipped to ``[-1, 1]``)."""
    if x <= -1.0:
        return -1.0
    if x >= 1.0:
        return 1.0
    return 2.0 * math.sin(math.asin(x) / 3.0)


@numba.njit(cache=True, nogil=True)
def _segment(x):
    """``int_{-1}^{x} 2 sqrt(1 - s^2) ds - pi/2``: the unit disc's area below height *x* (up to a constant)."""
    if x <= -1.0:
        return -0.5 * math.pi
    if x >= 1.0:
        return 0.5 * math.pi
    return math.asin(x) + x * math.sqrt(1.0 - x * x)


@numba.njit(cache=True, nogil=True)
def _node(t_k, w_k, t_lo, t_hi):
    """Node and weight of the Gauss–Legendre point ``(t_k, w_k)`` of ``[-1, 1]`` mapped as :func:`chord_node`."""
    half = 0.5 * (t_hi - t_lo)
    t = 0.5 * (t_hi + t_lo) + half * t_k
    q = 1.0 - t * t
    return 0.5 * t * (3.0 - t * t), 1.5 * half * w_k * q * q * math.sqrt(4.0 - t * t)


@numba.njit(cache=True, nogil=True)
def chord_node(k, t_lo, t_hi):
    """Node ``x_k`` and weight ``W_k`` of ``int_{x_lo}^{x_hi} g(x) 2 sqrt(1 - x^2) dx ~ sum_k W_k g(x_k)``.

    The chord width of the unit disc, ``2 sqrt(1 - x^2)``, has square-root ends at ``x = +-1``; the map
    ``x = (3t - t^3)/2`` turns ``2 sqrt(1 - x^2) dx`` into ``1.5 (1 - t^2)^2 sqrt(4 - t^2) dt`` (smooth), and
    :data:`DRAG_POINTS`-point Gauss–Legendre in ``t`` over ``[t_lo, t_hi]`` (``x(t_lo) = x_lo``) does the rest.
    """
    return _node(_GL_T[k], _GL_W[k], t_lo, t_hi)


@numba.njit(cache=True, nogil=True)
def drag_factor(code, z_lo, z_hi, z_c, r, depth, k_s):
    """The profile factor the drag of a sphere sees: ``sign(m) sqrt(|m|)``, ``m`` the mean of ``f |f|`` over
    its wetted projected area, ``f = profile_factor(code, z, depth, k_s)``.

    ``m = int_{z_lo}^{z_hi} f|f| w dz / int_{z_lo}^{z_hi} w dz`` with the chord width
    ``w(z) = 2 sqrt(r^2 - (z - z_c)^2)`` of the sphere of radius *r* centred *z_c* above the bed, over the
    wetted part ``z_lo .. z_hi`` (heights above the bed, normally ``max(0, z_c - r) .. min(depth, z_c + r)``,
    :func:`wetted_factor`). A mass at rest in the profile then feels ``1/2 rho C_D A_w |U F| U F``, exactly
    the integral ``1/2 rho C_D int u|u| dA`` over its wetted area (for a constant ``C_D``). The log law's
    zero below ``z0`` is integrated exactly (the rule starts at ``z0``); the rule is :func:`chord_node`.
    Returns 1 where :func:`profile_factor` is 1 everywhere (uniform profile, dry cell, no log layer), and the
    point value at ``z_c`` for ``r <= 0`` or an empty wetted part.
    """
    return drag_factor_rule(code, z_lo, z_hi, z_c, r, depth, k_s, _GL_T, _GL_W)


@numba.njit(cache=True, nogil=True)
def drag_factor_rule(code, z_lo, z_hi, z_c, r, depth, k_s, nodes, weights):
    """:func:`drag_factor` with the Gauss–Legendre rule *nodes*, *weights* on ``[-1, 1]`` (any number of
    points; ``benchmarks/bench_drag_points.py`` compares them)."""
    if code == 0 or depth <= 0.0:
        return 1.0
    cut = 0.0
    if code == 1:
        if k_s <= 0.0 or math.log(30.0 * depth / k_s) - 1.0 <= 1.0:
            return 1.0
        cut = k_s / 30.0
    elif code != 2:
        return 1.0
    if r <= 0.0 or z_hi <= z_lo:
        return profile_factor(code, z_c, depth, k_s)
    start = max(z_lo, cut)
    if start >= z_hi:
        return 0.0
    x_hi = (z_hi - z_c) / r
    area = _segment(x_hi) - _segment((z_lo - z_c) / r)
    if area <= 0.0:  # a sliver below round-off: the point value
        return profile_factor(code, min(max(z_c, z_lo), z_hi), depth, k_s)
    t_lo = _cubic_t((start - z_c) / r)
    t_hi = _cubic_t(x_hi)
    s = 0.0
    for k in range(nodes.size):
        x, wk = _node(nodes[k], weights[k], t_lo, t_hi)
        f = profile_factor(code, z_c + r * x, depth, k_s)
        s += wk * f * abs(f)
    m = s / area
    return math.copysign(math.sqrt(abs(m)), m)


@numba.njit(cache=True, nogil=True)
def wetted_factor(code, z_c, r, depth, k_s):
    """:func:`drag_factor` of a sphere of radius *r* centred *z_c* above the bed in water *depth*: wetted part
    ``max(0, z_c - r) .. min(depth, z_c + r)`` (the part in the bed or above the surface is not wetted)."""
    return drag_factor(code, max(0.0, z_c - r), min(depth, z_c + r), z_c, r, depth, k_s)


@numba.njit(cache=True, nogil=True)
def wetted_factors(code, z_c, r, depth, k_s, out):
    """Vectorised :func:`wetted_factor` over arrays (``k_s`` an array of the same length)."""
    for i in range(out.shape[0]):
        out[i] = wetted_factor(code, z_c[i], r[i], depth[i], k_s[i])


def drag_factors(name_or_code, z_c, radius, depth, k_s) -> np.ndarray:
    """Numpy front end of :func:`wetted_factor` (broadcasts its arguments)."""
    code = profile_code(name_or_code) if isinstance(name_or_code, str) else int(name_or_code)
    z, r, h, k = np.broadcast_arrays(*(np.asarray(a, float) for a in (z_c, radius, depth, k_s)))
    out = np.empty(z.size)
    wetted_factors(code, *(np.array(a.ravel()) for a in (z, r, h, k)), out)
    return out.reshape(z.shape)
