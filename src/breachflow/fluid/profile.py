"""The velocity a mass feels at its centre height: vertical profiles of the depth-averaged flow.

The hydrodynamic field is depth averaged (docs/theory.md, *Shallow-water equations*): one velocity ``U`` per gridpoint. A mass resting
near the bed sees much less than ``U``; one near the surface a little more. This module holds the ONE
definition of that vertical profile, ``u(z) = U * profile_factor(code, z, h, k_s)``, used by
:class:`~breachflow.fluid.forces.FluidForces` (and by any fused force kernel: call
:func:`profile_factor` from numba).

Profiles (by name, :data:`velocity_profiles`):

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
from typing import Protocol

import numba
import numpy as np

from ..errors import InputError
from ..registry import Registry

#: the velocity profiles, by name (entry-point group ``breachflow.velocity_profiles``); a profile is a class
#: whose ``code`` is the integer :func:`profile_factor` takes (a plug-in cannot add a profile without a kernel)
velocity_profiles: Registry = Registry("velocity profile", "breachflow.velocity_profiles", default="log")
#: the profile used unless another is named (``FluidForces``, ``[fluid] velocity_profile``): the registry's default
DEFAULT_PROFILE = velocity_profiles.default


class VelocityProfile(Protocol):
    """A vertical velocity profile: its kernel code (the numba kernels select the formula by it)."""

    code: int


@velocity_profiles.register("uniform")
class Uniform:
    """``u(z)/U = 1``: the report's setting."""

    code = 0


@velocity_profiles.register("log")
class Log:
    """The rough-wall log law over the roughness height ``k_s``."""

    code = 1


@velocity_profiles.register("power")
class Power:
    """The one-seventh power law."""

    code = 2


#: profile names and the integer codes :func:`profile_factor` takes
PROFILES = {name: velocity_profiles.get(name).code for name in ("uniform", "log", "power")}

#: Manning–Strickler coefficient (Parker 1991): ``U/u* = 8.1 (h/k_s)^(1/6)``
STRICKLER_A = 8.1


def profile_code(name: str) -> int:
    """The integer code of a profile name (``uniform``, ``log``, ``power``); InputError otherwise."""
    if not isinstance(name, str):
        raise InputError(f"velocity profile {name!r} unknown; use one of {velocity_profiles.available()}")
    return velocity_profiles.get(name).code


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
