"""Numba kernels of the fluid–particle forces (docs/theory.md, *Fluid forces on a mass*, report §3.2.3 and Fig 4.3 Steps 7E–7H).

Each physical concept has one function here; :class:`breachflow.fluid.forces.FluidForces` calls the
whole-array kernels once per step.  All quantities SI, ``z`` up, gravity ``-g e_z``.

Crossing the free surface
-------------------------
A sphere of radius ``a`` whose bottom is ``s`` below the free surface (``0 <= s <= 2a``) has the submerged
spherical-cap volume ``V_sub = pi s^2 (3a - s) / 3`` and submerged fraction ``phi = V_sub / V``.  We use
this one number for every fluid term of the straddling sphere:

* buoyancy ``rho_W V_sub g + rho_A (V - V_sub) g`` (exact for hydrostatics; ``V_sub`` counts only the
  part between bed and surface, so a sphere on a dry cell or pressed into the bed is not buoyed there);
* added mass ``xi (rho_W V_sub + rho_A (V - V_sub))``;
* drag: the water acts on the area fraction ``phi A`` with its own relative velocity and Reynolds number,
  the air on ``(1 - phi) A`` with the air's, i.e. ``-1/2 A [phi rho_W C_D,W |r_W| r_W + (1-phi) rho_A C_D,A |r_A| r_A]``.

Weighting drag by the *volume* fraction (rather than, like the report's program, switching between the
wetted disc for downward and the full disc for upward motion) makes every fluid force a continuous
function of the particle's position that does not depend on the direction of motion, so a sphere
crossing the surface down and up again sees the same forces at the same depth and no step in force can
inject or remove energy; it reduces to the exact limits in air and in water.  The projected wetted area
of a vertically moving sphere (``pi (2as - s^2)`` up to the equator) would reach the full area already at
half submergence; the difference matters only during the ``~D / v`` crossing time.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .drag import cd_re


@numba.njit(cache=True, inline="always")
def submerged_height(z, radius, surface):
    """Depth ``s`` of the sphere's lowest point below the free surface, clipped to ``[0, 2a]``."""
    s = surface - (z - radius)
    if s <= 0.0:
        return 0.0
    if s >= 2.0 * radius:
        return 2.0 * radius
    return s


@numba.njit(cache=True, inline="always")
def cap_volume(s, radius):
    """Spherical-cap volume ``pi s^2 (3a - s) / 3`` of height ``s`` (0 <= s <= 2a) of a sphere of radius ``a``."""
    return math.pi * s * s * (3.0 * radius - s) / 3.0


@numba.njit(cache=True, inline="always")
def submerged_fraction(z, radius, surface, bed=-math.inf):
    """``V_sub / V`` of a sphere centred at height *z* in the water column between *bed* and *surface*.

    ``V_sub = cap(surface) - cap(bed)``: the part of a sphere pressed into the bed (contact overlap) or
    standing on a dry cell (``surface == bed``) is not in water.
    """
    wet = cap_volume(submerged_height(z, radius, surface), radius)
    if bed > -math.inf:
        wet -= cap_volume(submerged_height(z, radius, bed), radius)
    return max(wet, 0.0) / (4.0 / 3.0 * math.pi * radius**3)


@numba.njit(cache=True, inline="always")
def particle_cd_re(law, params, cd, r):
    """``C_D R`` of a particle at Reynolds number *r*: its own drag coefficient *cd* (a shape's Newton-regime
    value, :class:`~breachflow.dem.state.ParticleState` ``drag_coefficient``) when set (> 0), else the run's
    law *law*/*params* (NaN, unset). ``cd * r`` is the ``constant`` law's arithmetic, so a particle with its
    own ``cd`` feels exactly what the ``constant`` law of that value gives."""
    if cd > 0.0:
        return cd * r
    return cd_re(law, params, r)


@numba.njit(cache=True, inline="always")
def drag_factor(law, params, cd, rho, nu, diameter, speed):
    """``k`` in ``f_D = -k r``: ``k = 1/2 C_D rho A |r| = rho nu A (C_D R) / (2 D)``, ``R = |r| D / nu`` (docs/theory.md, *Fluid forces on a mass*);
    *cd* the particle's own drag coefficient or NaN (:func:`particle_cd_re`)."""
    area = 0.25 * math.pi * diameter * diameter
    return 0.5 * rho * nu * area * particle_cd_re(law, params, cd, speed * diameter / nu) / diameter


@numba.njit(cache=True)
def submerged_fractions(pos, radius, surface, bed, inside, phi):
    """Fill *phi* (N,) with the submerged fraction of each particle; particles outside the field get 0."""
    for i in range(pos.shape[0]):
        if inside[i]:
            phi[i] = submerged_fraction(pos[i, 2], radius[i], surface[i], bed[i])
        else:
            phi[i] = 0.0


@numba.njit(cache=True)
def added_masses(radius, phi, rho_w, rho_a, xi, out):
    """Added (apparent) mass ``xi (rho_W V_sub + rho_A (V - V_sub))`` per particle (docs/theory.md, *Fluid forces on a mass*);
    *xi* (N,): each particle's apparent-mass coefficient."""
    for i in range(radius.shape[0]):
        vol = 4.0 / 3.0 * math.pi * radius[i] ** 3
        out[i] = xi[i] * vol * (phi[i] * rho_w + (1.0 - phi[i]) * rho_a)


@numba.njit(cache=True)
def buoyancy_and_drag(pos, vel, radius, phi, u, v, wind, rho_w, nu_w, rho_a, nu_a, g,
                      law, params, cds, with_air, force):
    """Add buoyancy and drag to *force* (N,3).

    Buoyancy ``+(rho_W V_sub + rho_A (V - V_sub)) g e_z``; drag with water velocity ``(u, v, 0)`` on the
    submerged fraction and still air (or *wind*) on the rest, see the module docstring.  ``with_air``
    False drops the air terms (vacuum above the water). *cds* (N,): each particle's own drag coefficient
    (NaN: the law *law*/*params*), :func:`particle_cd_re`.
    """
    for i in range(pos.shape[0]):
        a = radius[i]
        d = 2.0 * a
        vol = 4.0 / 3.0 * math.pi * a**3
        f = phi[i]
        rho_air = rho_a if with_air else 0.0
        force[i, 2] += (f * rho_w + (1.0 - f) * rho_air) * vol * g
        if f > 0.0:
            rx = vel[i, 0] - u[i]
            ry = vel[i, 1] - v[i]
            rz = vel[i, 2]
            sp = math.sqrt(rx * rx + ry * ry + rz * rz)
            k = f * drag_factor(law, params, cds[i], rho_w, nu_w, d, sp)
            force[i, 0] -= k * rx
            force[i, 1] -= k * ry
            force[i, 2] -= k * rz
        if with_air and f < 1.0:
            rx = vel[i, 0] - wind[0]
            ry = vel[i, 1] - wind[1]
            rz = vel[i, 2] - wind[2]
            sp = math.sqrt(rx * rx + ry * ry + rz * rz)
            k = (1.0 - f) * drag_factor(law, params, cds[i], rho_a, nu_a, d, sp)
            force[i, 0] -= k * rx
            force[i, 1] -= k * ry
            force[i, 2] -= k * rz


@numba.njit(cache=True)
def convective_added_mass(radius, phi, u0, v0, u1, v1, horizon, rho_w, xi, force):
    """Convective part of the apparent-mass force, ``+xi rho_W V_sub (u(x_pred) - u(x)) / dt`` (Fig 4.3 Step 7H).

    With ``r = v - u`` the apparent-mass force ``-xi rho_W V_sub Dr/Dt`` splits into ``-xi rho_W V_sub dv/dt``
    (carried by the effective mass ``m + xi rho_W V_sub`` on the left-hand side) and
    ``+xi rho_W V_sub du/dt`` along the particle path; with the field frozen within a cycle the latter is
    ``(v . grad) u``, taken as the difference of the fluid velocity at the predicted position
    ``x_pred = x + v dt`` and at ``x``.  The water has no vertical velocity in the depth-averaged field.
    *xi* (N,): each particle's apparent-mass coefficient.
    """
    for i in range(radius.shape[0]):
        if phi[i] > 0.0:
            mass_f = xi[i] * rho_w * phi[i] * 4.0 / 3.0 * math.pi * radius[i] ** 3
            force[i, 0] += mass_f * (u1[i] - u0[i]) / horizon
            force[i, 1] += mass_f * (v1[i] - v0[i]) / horizon


@numba.njit(cache=True, inline="always")
def _point_torque(vel, omega, i, ox, oy, ax, ay, uy, vy, pre, law, params, cd, d, nu):
    """Torque ``a x f_y`` of the drag ``f_y = -pre C_D(R_y) R_y q_y`` at arm ``o = (ox, oy, 0)``, lever ``a``."""
    qx = vel[i, 0] - omega[i, 2] * oy - uy
    qy = vel[i, 1] + omega[i, 2] * ox - vy
    qz = vel[i, 2] + omega[i, 0] * oy - omega[i, 1] * ox
    sp = math.sqrt(qx * qx + qy * qy + qz * qz)
    kf = pre * particle_cd_re(law, params, cd, sp * d / nu)
    return -kf * (ay * qz), kf * (ax * qz), -kf * (ax * qy - ay * qx)


@numba.njit(cache=True)
def neighbourhood_torque(pos, vel, omega, radius, phi, x0, y0, dx, dy, ugrid, vgrid, depth,
                         min_radius, rho_w, nu_w, law, params, cds, torque):
    """Fluid torque from the gridpoints ``y`` inside each particle's neighbourhood (docs/theory.md, *Fluid forces on a mass*, Fig 4.4, Step 7E).

    Neighbourhood radius ``max(D/2, min_radius)`` (the report's small-particle rule: ``min_radius`` is the
    largest grid spacing ``s_max``).  At each wet gridpoint ``y`` with arm ``o_y`` from the centre (in the
    horizontal plane through the centre), relative surface velocity ``q_y = v + w x o_y - u_y``, force
    ``f_y = -1/2 C_D(R_y) rho_W phi (A / Y) |q_y| q_y``, torque ``sum_y (o_y - o_mean) x f_y``.  Measuring
    lever arms from the centroid ``o_mean`` of the gridpoints found keeps a uniform stream from exerting a
    spurious torque ``(sum o_y) x f`` when the gridpoints are not centred on the particle.  Adds into
    *torque*; *cds* (N,) each particle's own drag coefficient (NaN: the law).  Grid arrays are (ny, nx) with cell centres ``x0 + j dx``, ``y0 + k dy``; wet = depth > 1e-6.
    """
    ny, nx = ugrid.shape
    for i in range(pos.shape[0]):
        if phi[i] <= 0.0:
            continue
        rad = max(radius[i], min_radius)
        d = 2.0 * radius[i]
        px = pos[i, 0]
        py = pos[i, 1]
        j0 = max(int(math.ceil((px - rad - x0) / dx)), 0)
        j1 = min(int(math.floor((px + rad - x0) / dx)), nx - 1)
        k0 = max(int(math.ceil((py - rad - y0) / dy)), 0)
        k1 = min(int(math.floor((py + rad - y0) / dy)), ny - 1)
        count = 0
        mx = 0.0
        my = 0.0
        for k in range(k0, k1 + 1):
            for j in range(j0, j1 + 1):
                ox = x0 + j * dx - px
                oy = y0 + k * dy - py
                if ox * ox + oy * oy <= rad * rad and depth[k, j] > 1e-6:
                    count += 1
                    mx += ox
                    my += oy
        if count == 0:
            continue
        mx /= count
        my /= count
        pre = 0.5 * phi[i] * rho_w * nu_w * (0.25 * math.pi * d * d / count) / d
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for k in range(k0, k1 + 1):
            for j in range(j0, j1 + 1):
                ox = x0 + j * dx - px
                oy = y0 + k * dy - py
                if ox * ox + oy * oy <= rad * rad and depth[k, j] > 1e-6:
                    a, b, c = _point_torque(vel, omega, i, ox, oy, ox - mx, oy - my, ugrid[k, j], vgrid[k, j],
                                            pre, law, params, cds[i], d, nu_w)
                    tx += a
                    ty += b
                    tz += c
        torque[i, 0] += tx
        torque[i, 1] += ty
        torque[i, 2] += tz


@numba.njit(cache=True)
def uniform_field_torque(vel, omega, radius, phi, u, v, points_per_diameter, rho_w, nu_w, law, params, cds, torque):
    """The torque of :func:`neighbourhood_torque` for a uniform field without a grid (still / uniform water).

    The gridpoints are a virtual square lattice of ``points_per_diameter`` points across the particle,
    centred on it (so the uniform stream itself exerts no torque; only the spin is resisted).
    """
    for i in range(vel.shape[0]):
        if phi[i] <= 0.0:
            continue
        d = 2.0 * radius[i]
        h = d / points_per_diameter
        m = points_per_diameter // 2
        r2 = radius[i] * radius[i] * (1.0 + 1e-12)
        count = 0
        for k in range(-m, m + 1):
            for j in range(-m, m + 1):
                ox = (j + 0.5 * (1 - points_per_diameter % 2)) * h
                oy = (k + 0.5 * (1 - points_per_diameter % 2)) * h
                if ox * ox + oy * oy <= r2:
                    count += 1
        pre = 0.5 * phi[i] * rho_w * nu_w * (0.25 * math.pi * d * d / count) / d
        for k in range(-m, m + 1):
            for j in range(-m, m + 1):
                ox = (j + 0.5 * (1 - points_per_diameter % 2)) * h
                oy = (k + 0.5 * (1 - points_per_diameter % 2)) * h
                if ox * ox + oy * oy <= r2:
                    a, b, c = _point_torque(vel, omega, i, ox, oy, ox, oy, u[i], v[i], pre, law, params, cds[i], d,
                                            nu_w)
                    torque[i, 0] += a
                    torque[i, 1] += b
                    torque[i, 2] += c
