"""Near-bed flow forces on a mass resting on (or moving over) the bed: the flow over its exposed height,
lift, and the turbulent velocity peaks. User documentation: ``docs/bed-and-forces.md``.

The depth-averaged field gives ``U`` (vector) per point; :mod:`breachflow.fluid.profile` the vertical
profile ``u(z) = |U| f(z)`` (``f`` the profile factor, ``z`` above the bed). With the near-bed terms on,
a sphere of radius ``a`` centred ``z_c`` above the bed feels, instead of ``U f(z_c)``:

Exposed height (Wiberg & Smith 1987)
    the drag of the mean ``u|u|`` over its projected disc: ``F = sqrt(<f^2>_disc)`` (the profile is 0 below
    the log law's ``z0 = k_s/30`` and below the bed), evaluated by a 16-point midpoint rule in the angle
    ``z = z_c - a cos(t)`` (``dA = 2 a^2 sin(t)^2 dt``); ``F = 1`` for the uniform profile.
Turbulent velocity peaks (term ``turbulence``)
    a sweep raises the local velocity by ``k_p sigma_u``, ``sigma_u = D_u u* exp(-C_k z_c / h)`` (Nezu &
    Nakagawa 1993, *Turbulence in open-channel flows*, IAHR Monograph: ``D_u = 2.30``,
    ``C_k = 1``), ``u* / |U| = kappa / (ln(30 h / k_s) - 1)`` (the depth-averaged log law; Manning–Strickler
    ``1 / (8.1 (h/k_s)^(1/6))`` where no log layer exists); the velocity a mass feels is
    ``U (F + P)``, ``P = k_p D_u exp(-C_k z_c/h) u*/|U|``: the whole local profile is scaled by
    ``1 + P/F`` during the peak. The peak factor ``k_p`` is the one calibrated constant (against Shields'
    ``theta_c = 0.047``, docs).
Lift (term ``lift``)
    ``F_L = 1/2 rho C_L A phi (u_T^2 - u_B^2)`` upward, ``u_T``, ``u_B`` the flow at the top and the bottom of
    the sphere (Wiberg & Smith 1987, with ``C_L = 0.2``, their value; Einstein & El-Samni 1949 measured the lift
    on hemispheres of a rough bed, a coefficient of about 0.18 as usually quoted):
    relative to the mass, ``F_L = 1/2 rho C_L A phi |U_eff - v_h|^2 Lambda``, ``Lambda = (f_T^2 - f_B^2)/F^2``
    (0 in a uniform profile: no shear, no lift; small far from the bed).

The kernel :func:`near_bed` returns the drag-velocity factor ``F + P`` and ``Lambda``; the fused force
kernel (:mod:`breachflow.fluid.compiled`) and ``FluidForces`` apply them where they use the profile.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..errors import InputError
from ..registry import Registry
from .profile import profile_factor

#: slots of the parameter vector ``bedp`` the kernels read
ON, LIFT, PEAK, D_U, C_K, KAPPA, NQUAD = range(7)
N_PARAMS = 7
#: von Kármán's constant (as the log profile)
KAPPA_VK = 0.41
#: Nezu & Nakagawa (1993): ``u'/u* = 2.30 exp(-z/h)``
NEZU_DU, NEZU_CK = 2.30, 1.0
#: lift coefficient (Wiberg & Smith 1987; Einstein & El-Samni 1949 measured about 0.18 on a rough bed)
LIFT_COEFFICIENT = 0.2
#: peak factor calibrated against Shields' theta_c = 0.047 (docs/bed-and-forces.md, tests/fluid/test_nearbed.py)
PEAK_FACTOR = 0.93

#: the registry of near-bed force terms; each fills its slots of the parameter vector
NEAR_BED_TERMS: Registry = Registry("near-bed force term", "breachflow.near_bed_terms")


def off() -> np.ndarray:
    """The parameter vector with every near-bed term off (the earlier behaviour, bit for bit)."""
    return np.zeros(N_PARAMS)


@NEAR_BED_TERMS.register("lift")
class Lift:
    """Lift ``1/2 rho C_L A (u_T^2 - u_B^2)`` (module docstring); parameter ``coefficient`` C_L."""

    def __init__(self, coefficient: float = LIFT_COEFFICIENT):
        self.coefficient = _nonneg("lift coefficient", coefficient)

    def fill(self, p):
        p[LIFT] = self.coefficient


@NEAR_BED_TERMS.register("turbulence")
class TurbulentPeaks:
    """Velocity peaks ``k_p sigma_u``, ``sigma_u = D_u u* exp(-C_k z/h)`` (module docstring); parameters
    ``peak_factor`` k_p, ``intensity`` D_u, ``decay`` C_k."""

    def __init__(self, peak_factor: float = PEAK_FACTOR, intensity: float = NEZU_DU, decay: float = NEZU_CK):
        self.peak_factor = _nonneg("turbulence peak factor", peak_factor)
        self.intensity = _nonneg("turbulence intensity", intensity)
        self.decay = _nonneg("turbulence decay", decay)

    def fill(self, p):
        p[PEAK] = self.peak_factor
        p[D_U] = self.intensity
        p[C_K] = self.decay


def _nonneg(name, v):
    v = float(v)
    if not (math.isfinite(v) and v >= 0):
        raise InputError(f"{name} must be finite and >= 0, got {v!r}")
    return v


def parameters(terms=("lift", "turbulence"), **params) -> np.ndarray:
    """The parameter vector of the near-bed model with *terms* (registry names or instances; the exposed-height
    drag is always on when the model is) and keyword parameters ``lift={...}``, ``turbulence={...}``."""
    p = off()
    p[ON] = 1.0
    p[KAPPA] = KAPPA_VK
    p[NQUAD] = 16
    for t in terms:
        obj = t if hasattr(t, "fill") else NEAR_BED_TERMS.get(t)(**params.get(t, {}))
        obj.fill(p)
    return p


@numba.njit(cache=True, inline="always")
def shear_velocity_ratio(depth, k_s, kappa):
    """``u*/U`` of a depth-averaged log-law flow of *depth* over roughness *k_s*; Manning–Strickler where no log
    layer exists (``ln(30 h/k_s) - 1 <= 1``)."""
    denom = math.log(30.0 * depth / k_s) - 1.0
    if denom > 1.0:
        return kappa / denom
    return 1.0 / (8.1 * (depth / k_s) ** (1.0 / 6.0))


@numba.njit(cache=True)
def near_bed(code, k_s, zc, depth, a, bedp):
    """``(g, lam)`` of a sphere of radius *a* centred *zc* above the bed in water *depth* (profile *code*,
    roughness *k_s*, parameters *bedp*): the velocity it feels is ``U g``, its lift ``1/2 rho C_L A phi lam
    |U g - v_h|^2`` (module docstring). ``g`` is the profile factor at *zc* when ``bedp[ON] == 0``."""
    if bedp[ON] == 0.0:
        return profile_factor(code, zc, depth, k_s), 0.0
    if depth <= 0.0:
        return 1.0, 0.0
    n = int(bedp[NQUAD])
    s2 = 0.0
    for j in range(n):
        t = (j + 0.5) * math.pi / n
        st = math.sin(t)
        z = zc - a * math.cos(t)
        f = profile_factor(code, z, depth, k_s) if z > 0.0 or code == 0 else 0.0
        s2 += st * st * f * f
    big_f = math.sqrt(2.0 * s2 / n)
    peak = 0.0
    if bedp[PEAK] > 0.0 and k_s > 0.0:
        zz = min(max(zc, 0.0), depth)
        peak = bedp[PEAK] * bedp[D_U] * math.exp(-bedp[C_K] * zz / depth) * shear_velocity_ratio(depth, k_s,
                                                                                                   bedp[KAPPA])
    lam = 0.0
    if bedp[LIFT] > 0.0 and big_f > 0.0:
        zt = zc + a
        zb = zc - a
        ft = profile_factor(code, zt, depth, k_s)
        fb = profile_factor(code, zb, depth, k_s) if zb > 0.0 or code == 0 else 0.0
        lam = max(ft * ft - fb * fb, 0.0) / (big_f * big_f)
    return big_f + peak, lam


@numba.njit(cache=True)
def near_bed_array(code, k_s, zc, depth, a, bedp, g, lam):
    """:func:`near_bed` over arrays (*zc*, *depth*, *a*) into *g*, *lam*."""
    for i in range(zc.shape[0]):
        g[i], lam[i] = near_bed(code, k_s, zc[i], depth[i], a[i], bedp)


def factors(code, k_s, zc, depth, a, bedp):
    """Numpy front end of :func:`near_bed`: ``(g, lam)`` arrays (arguments broadcast)."""
    z, h, r = np.broadcast_arrays(np.asarray(zc, float), np.asarray(depth, float), np.asarray(a, float))
    g = np.empty(z.size)
    lam = np.empty(z.size)
    near_bed_array(int(code), float(k_s), np.ascontiguousarray(z.ravel()), np.ascontiguousarray(h.ravel()),
                   np.ascontiguousarray(r.ravel()), np.asarray(bedp, float), g, lam)
    return g.reshape(z.shape), lam.reshape(z.shape)


@numba.njit(cache=True, inline="always")
def lift_force(bedp, lam, rho_w, a, phi, rx, ry, cl=math.nan):
    """Upward lift ``1/2 rho C_L (pi a^2) phi lam (rx^2 + ry^2)`` of a sphere with horizontal velocity *rx*, *ry*
    relative to the water it feels; ``C_L`` the lift term's ``bedp[LIFT]``, or where that term is on
    (> 0) the particle's own coefficient *cl* when set (>= 0; NaN: unset)."""
    if lam <= 0.0 or phi <= 0.0:
        return 0.0
    c = bedp[LIFT]
    if c > 0.0 and cl >= 0.0:
        c = cl
    return 0.5 * rho_w * c * math.pi * a * a * phi * lam * (rx * rx + ry * ry)
