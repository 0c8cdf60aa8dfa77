"""The fluid forces of :class:`~breachflow.fluid.forces.FluidForces` on a grid snapshot as ONE compiled call.

:class:`~breachflow.fluid.forces.FluidForces` evaluates its terms as a sequence of whole-array steps
(sample the field, submerged fractions, buoyancy + drag, a second sample ahead of each particle for the
convective apparent-mass term, the gridpoint torque), each a numpy or numba call. Per DEM step with a few
moving masses, the Python and numpy overhead of that sequence costs far more than the arithmetic.

:func:`grid_fluid_forces` does the same per particle inside one numba kernel: the field is read directly
from the grid arrays (:func:`~breachflow.field.sampling.grid_bilinear_point` or
:func:`~breachflow.field.sampling.grid_neighbourhood_point`, the sampler's own point kernels), and
buoyancy, drag, the convective apparent-mass force (Fig 4.3 Step 7H) and the gridpoint torque (Step 7E)
use the per-term kernels of :mod:`breachflow.fluid.kernels`, and the water velocity a particle feels is
the sampled depth-averaged one times :func:`~breachflow.fluid.profile.profile_factor` at its centre
height (the vertical profile, ``uniform`` | ``log`` | ``power``) — the physics stays in one place, only
the loop is fused. :func:`grid_added_masses` is the same for the apparent mass. Both reproduce the
step-by-step path to round-off (``tests/fluid/test_compiled_forces.py``).

Used by ``FluidForces`` automatically for grid snapshots without the Basset term and with a non-uniform
field, for every velocity profile (a uniform field, a mesh or ``basset=True`` take the step-by-step path).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..field.sampling import grid_bilinear_point, grid_neighbourhood_point
from . import kernels as K
from .nearbed import ON, lift_force, near_bed
from .profile import profile_factor

BILINEAR, NEIGHBOURHOOD = 0, 1


@numba.njit(cache=True, inline="always")
def _sample(method, bed, depth, u, v, x0, y0, dx, dy, smax, x, y, radius):
    """``(inside, bed, depth, u, v)`` at one point, as the ``FieldSampler`` methods compute it."""
    if method == BILINEAR:
        return grid_bilinear_point(bed, depth, u, v, x0, y0, dx, dy, x, y)
    ins, b, h, uu, vv, n = grid_neighbourhood_point(bed, depth, u, v, x0, y0, dx, dy, x, y, max(radius, smax))
    return ins, b, h, uu, vv


@numba.njit(cache=True, inline="always")
def _profiled(code, k_s, z, b, h, uu, vv):
    """``(u, v)`` times the vertical profile factor at height ``z - b`` in water ``h`` (as ``FluidForces._profiled``)."""
    if code == 0:
        return uu, vv
    f = profile_factor(code, z - b, (b + h) - b, k_s)
    return uu * f, vv * f


@numba.njit(cache=True, inline="always")
def _felt(code, k_s, bedp, z, b, h, a, uu, vv):
    """``(u, v, lam)``: the velocity a sphere of radius *a* at height *z* feels and its lift factor: the profile
    at its centre (:func:`_profiled`, lam 0) or, with the near-bed terms on (``bedp[ON]``), the near-bed
    velocity of :func:`~breachflow.fluid.nearbed.near_bed`."""
    if bedp[ON] == 0.0:
        su, sv = _profiled(code, k_s, z, b, h, uu, vv)
        return su, sv, 0.0
    g, lam = near_bed(code, k_s, z - b, h, a, bedp)
    return uu * g, vv * g, lam


@numba.njit(cache=True, inline="always")
def apparent_mass(xi, a, phi, rho_w, rho_a):
    """``xi (rho_W V_sub + rho_A (V - V_sub))`` (kg) of a sphere of radius *a* with submerged fraction *phi*."""
    vol = 4.0 / 3.0 * math.pi * a ** 3
    return xi * vol * (phi * rho_w + (1.0 - phi) * rho_a)


@numba.njit(cache=True)
def grid_added_masses(rows, pos, radius, method, bed, depth, u, v, x0, y0, dx, dy, smax, outside_air,
                      profile, k_s, bedp, rho_w, rho_a, xi, out):
    """Apparent mass ``xi (rho_W V_sub + rho_A (V - V_sub))`` of particles *rows* at *pos* into ``out[k]``; *xi*
    (N,) each particle's apparent-mass coefficient.

    Returns -1, or (``outside_air`` False) the position ``k`` in *rows* of the first particle outside the
    field (nothing is meaningful in *out* then). *profile*, *k_s*, *bedp* are not used (the apparent mass does not
    depend on the velocity); they are taken so that both kernels share the field arguments.
    """
    for k in range(rows.size):
        i = rows[k]
        ins, b, h, uu, vv = _sample(method, bed, depth, u, v, x0, y0, dx, dy, smax, pos[i, 0], pos[i, 1], radius[i])
        if ins:
            phi = K.submerged_fraction(pos[i, 2], radius[i], b + h, b)
        else:
            if not outside_air:
                return k
            phi = 0.0
        out[k] = apparent_mass(xi[i], radius[i], phi, rho_w, rho_a)
    return -1


@numba.njit(cache=True)
def grid_fluid_forces(idx, pos, vel, omega, state_pos, awake, radius, method, bed, depth, u, v, x0, y0, dx, dy,
                      smax, outside_air, profile, k_s, bedp, wind, rho_w, nu_w, rho_a, nu_a, with_air, g, law, params,
                      cds, cls, xi, time_step, do_torque, force, torque):
    """Add buoyancy, drag, convective apparent mass and gridpoint torque on particles *idx* to *force*/*torque*.

    The kinematics are rows of *pos*/*vel*/*omega*; a sleeping particle (``awake`` False) is taken at rest
    at ``state_pos`` (as ``FluidForces._kinematics``). Same terms and arithmetic as
    ``FluidForces.accumulate`` with ``basset=False`` on a non-uniform grid field: outside the field a
    particle sees air (``outside_air``) or the call returns the position in *idx* of the first one outside
    before anything is added. The water velocity is the depth-averaged one times the vertical profile
    factor (*profile* code of :data:`~breachflow.fluid.profile.PROFILES`, roughness *k_s*) at the
    particle's centre height, here and at the predicted position of the convective term (the gridpoint
    torque uses the depth-averaged gridpoint velocities, as the step path); with the near-bed terms on
    (*bedp*, :mod:`~breachflow.fluid.nearbed`) the near-bed velocity and the lift instead. ``time_step`` 0 means the
    default horizon of the convective term, ``0.125 max(s_max, 1e-3) / max |v_h|``. *cds*, *cls* (N,): each
    particle's own drag and lift coefficients (NaN: the law *law*/*params*, the lift term's;
    :class:`~breachflow.dem.state.ParticleState`); *xi* (N,) each particle's apparent-mass coefficient. Returns
    -1 on success.
    """
    return grid_fluid_forces_phi(idx, pos, vel, omega, state_pos, awake, radius, method, bed, depth, u, v, x0, y0,
                                 dx, dy, smax, outside_air, profile, k_s, bedp, wind, rho_w, nu_w, rho_a, nu_a, with_air,
                                 g, law, params, cds, cls, xi, time_step, do_torque, force, torque, np.empty(idx.size))


@numba.njit(cache=True)
def grid_fluid_forces_phi(idx, pos, vel, omega, state_pos, awake, radius, method, bed, depth, u, v, x0, y0, dx, dy,
                          smax, outside_air, profile, k_s, bedp, wind, rho_w, nu_w, rho_a, nu_a, with_air, g, law,
                          params, cds, cls, xi, time_step, do_torque, force, torque, phi):
    """:func:`grid_fluid_forces`, leaving the submerged fraction of particle ``idx[k]`` in ``phi[k]`` (0 outside
    the field or in the air): with :func:`apparent_mass` the next step's apparent mass at the same positions
    without sampling the field again (the DEM's compiled step loop, :mod:`breachflow.coupling.steploop`)."""
    n = idx.size
    px = np.empty((n, 3))
    pv = np.empty((n, 3))
    po = np.empty((n, 3))
    su = np.empty(n)
    sv = np.empty(n)
    lam = np.zeros(n)
    ins_ = np.empty(n, np.bool_)
    vmax = 0.0
    any_wet = False
    any_xi = False
    for k in range(n):
        i = idx[k]
        if awake[i]:
            for c in range(3):
                px[k, c] = pos[i, c]
                pv[k, c] = vel[i, c]
                po[k, c] = omega[i, c]
        else:
            for c in range(3):
                px[k, c] = state_pos[i, c]
                pv[k, c] = 0.0
                po[k, c] = 0.0
        ins, b, h, uu, vv = _sample(method, bed, depth, u, v, x0, y0, dx, dy, smax, px[k, 0], px[k, 1], radius[i])
        ins_[k] = ins
        if ins:
            phi[k] = K.submerged_fraction(px[k, 2], radius[i], b + h, b)
            su[k], sv[k], lam[k] = _felt(profile, k_s, bedp, px[k, 2], b, h, radius[i], uu, vv)
        else:
            if not outside_air:
                return k
            phi[k] = 0.0
            su[k] = 0.0
            sv[k] = 0.0
        if phi[k] > 0.0:
            any_wet = True
            if xi[i] > 0.0:
                any_xi = True
        sp = math.hypot(pv[k, 0], pv[k, 1])
        if sp > vmax:
            vmax = sp
    horizon = 0.0
    if any_wet and any_xi and vmax > 0.0:
        horizon = time_step if time_step > 0.0 else 0.125 * max(smax, 1e-3) / vmax
    rho_air = rho_a if with_air else 0.0
    for k in range(n):
        i = idx[k]
        a = radius[i]
        d = 2.0 * a
        vol = 4.0 / 3.0 * math.pi * a ** 3
        f = phi[k]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        fz += (f * rho_w + (1.0 - f) * rho_air) * vol * g
        if f > 0.0:
            rx = pv[k, 0] - su[k]
            ry = pv[k, 1] - sv[k]
            rz = pv[k, 2]
            s = math.sqrt(rx * rx + ry * ry + rz * rz)
            kk = f * K.drag_factor(law, params, cds[i], rho_w, nu_w, d, s)
            fx -= kk * rx
            fy -= kk * ry
            fz -= kk * rz
            if lam[k] > 0.0:
                fz += lift_force(bedp, lam[k], rho_w, a, f, rx, ry, cls[i])
        if with_air and f < 1.0:
            rx = pv[k, 0] - wind[0]
            ry = pv[k, 1] - wind[1]
            rz = pv[k, 2] - wind[2]
            s = math.sqrt(rx * rx + ry * ry + rz * rz)
            kk = (1.0 - f) * K.drag_factor(law, params, cds[i], rho_a, nu_a, d, s)
            fx -= kk * rx
            fy -= kk * ry
            fz -= kk * rz
        if horizon > 0.0 and f > 0.0:
            # convective apparent mass: fluid velocity at the predicted position x + v dt (Step 7H)
            ax = px[k, 0] + pv[k, 0] * horizon
            ay = px[k, 1] + pv[k, 1] * horizon
            ins1, b1, h1, u1, v1 = _sample(method, bed, depth, u, v, x0, y0, dx, dy, smax, ax, ay, a)
            if ins1:
                u1, v1, _ = _felt(profile, k_s, bedp, px[k, 2] + pv[k, 2] * horizon, b1, h1, a, u1, v1)
            if not (ins1 and ins_[k]):
                u1 = su[k]
                v1 = sv[k]
            mass_f = xi[i] * rho_w * f * 4.0 / 3.0 * math.pi * a ** 3
            fx += mass_f * (u1 - su[k]) / horizon
            fy += mass_f * (v1 - sv[k]) / horizon
        force[i, 0] += fx
        force[i, 1] += fy
        force[i, 2] += fz
    if do_torque and any_wet:
        _torque_rows(idx, px, pv, po, radius, phi, x0, y0, dx, dy, u, v, depth, smax, rho_w, nu_w, law, params,
                     cds, torque)
    return -1


@numba.njit(cache=True)
def _torque_rows(idx, px, pv, po, radius, phi, x0, y0, dx, dy, u, v, depth, smax, rho_w, nu_w, law, params, cds,
                 torque):
    """:func:`~breachflow.fluid.kernels.neighbourhood_torque` of the gathered rows, added to ``torque[idx]``."""
    n = idx.size
    rad = np.empty(n)
    cd = np.empty(n)
    for k in range(n):
        rad[k] = radius[idx[k]]
        cd[k] = cds[idx[k]]
    tq = np.zeros((n, 3))
    K.neighbourhood_torque(px, pv, po, rad, phi, x0, y0, dx, dy, u, v, depth, smax, rho_w, nu_w, law, params, cd, tq)
    for k in range(n):
        i = idx[k]
        torque[i, 0] += tq[k, 0]
        torque[i, 1] += tq[k, 1]
        torque[i, 2] += tq[k, 2]
