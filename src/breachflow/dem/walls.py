"""Contacts of particles with boundaries (SPEC §5): fixed or moving planes and the terrain as a height
field (split out of :mod:`.contacts`, which re-exports these names).

:func:`plane_candidates` lists, per fixed plane, the particles that can touch it before the next
neighbour-list rebuild, so that the many-steps loop (:mod:`.steploop_fluid`) runs the plane loop over those
only (issue 16).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .contact_law import HOOKE_HISTORY, WINDOW_AVERAGED, contact_law, hooke_history, rolling_law

@numba.njit(cache=True, inline="always", error_model="numpy")
def wall_contact(i, nx, ny, nz, overlap, wvel, hist, rhist, pos, vel, omega, vel_h, omega_h, radius, mass, inertia,
                 props, wprops, dt, lo, hi, force, torque, out, mr, law=0):
    """Contact of particle i with a boundary (n from the centre towards the boundary), averaged over the
    force window ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`); returns the window fraction in contact.
    Inlined into the plane and height-field loops (plane kernel 8-10 % faster on the 1000-sphere bed,
    ``python3 tasks.py bench dem_kernel --old <main's src>``).

    hist / rhist: the boundary's (N, 3) per-particle shear / rolling-moment histories."""
    ri = radius[i]
    wx = ri * omega[i, 0]
    wy = ri * omega[i, 1]
    wz = ri * omega[i, 2]
    vx = wvel[0] - vel[i, 0] - (wy * nz - wz * ny)
    vy = wvel[1] - vel[i, 1] - (wz * nx - wx * nz)
    vz = wvel[2] - vel[i, 2] - (wx * ny - wy * nx)
    wx = ri * omega_h[i, 0]
    wy = ri * omega_h[i, 1]
    wz = ri * omega_h[i, 2]
    gx = wvel[0] - vel_h[i, 0] - (wy * nz - wz * ny)
    gy = wvel[1] - vel_h[i, 1] - (wz * nx - wx * nz)
    gz = wvel[2] - vel_h[i, 2] - (wx * ny - wy * nx)
    if law == HOOKE_HISTORY:
        phi, fx, fy, fz, ftx, fty, ftz, fn = hooke_history(
            nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i, min(props[i, 2], wprops[2]),
            min(props[i, 3], wprops[3]), min(props[i, 4], wprops[4]), min(props[i, 5], wprops[5]),
            min(props[i, 0], wprops[0]), min(props[i, 1], wprops[1]), dt)
    else:
        phi, fx, fy, fz, ftx, fty, ftz, fn = contact_law(
            nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i, min(props[i, 2], wprops[2]),
            min(props[i, 3], wprops[3]), min(props[i, 4], wprops[4]), min(props[i, 5], wprops[5]),
            min(props[i, 6], wprops[6]), min(props[i, 0], wprops[0]), min(props[i, 1], wprops[1]), dt, lo, hi)
    out[0] = fx
    out[1] = fy
    out[2] = fz
    if overlap <= 0.0:
        rhist[i, 0] = 0.0
        rhist[i, 1] = 0.0
        rhist[i, 2] = 0.0
        if phi <= 0.0:
            return phi
    force[i, 0] += fx
    force[i, 1] += fy
    force[i, 2] += fz
    torque[i, 0] += ri * (ny * ftz - nz * fty)
    torque[i, 1] += ri * (nz * ftx - nx * ftz)
    torque[i, 2] += ri * (nx * fty - ny * ftx)
    mu_r = min(props[i, 7], wprops[7])
    if mu_r > 0.0 and overlap > 0.0:
        rolling_law(nx, ny, nz, omega[i, 0], omega[i, 1], omega[i, 2], fn, ri, mu_r,
                    min(props[i, 2], wprops[2]), inertia[i] + mass[i] * ri * ri, rhist, i, dt, mr)
        torque[i, 0] += mr[0]
        torque[i, 1] += mr[1]
        torque[i, 2] += mr[2]
    return phi


@numba.njit(cache=True, error_model="numpy")
def plane_forces(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props,
                 dt, force, torque, reaction, lo, hi, vel_h, omega_h, law=0):
    """Contacts of particles *idx* with the plane through *point* with unit *normal* (into the domain).

    Adds the force on the plane (minus the sum of particle forces) to *reaction*; returns #contacts
    (overlapping now). Forces are averaged over the force window ``[lo, hi]``
    (:func:`~breachflow.dem.contact_law.contact_law`). The plane's point, normal and velocity are held in
    locals (otherwise reloaded for every particle: the stores into the histories may alias them), 10 % faster
    on the 1000-sphere bed (``python3 tasks.py bench dem_kernel --old <src>``). The loop is compiled once
    per contact law (*law* a constant in each copy), as the pair loop: with both laws in one loop, the
    window law's code slowed the loop by 12 % for either law.
    """
    if law == HOOKE_HISTORY:
        return _plane_loop(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia,
                           props, dt, force, torque, reaction, lo, hi, vel_h, omega_h, HOOKE_HISTORY)
    return _plane_loop(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props,
                       dt, force, torque, reaction, lo, hi, vel_h, omega_h, WINDOW_AVERAGED)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _plane_loop(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props,
                dt, force, torque, reaction, lo, hi, vel_h, omega_h, law):
    """The loop of :func:`plane_forces` (arguments there)."""
    out = np.empty(7)
    mr = np.empty(3)
    n = 0
    reach_t = max(-lo, hi) if law == WINDOW_AVERAGED else 0.0  # hooke_history: point values
    px, py, pz = point[0], point[1], point[2]
    qx, qy, qz = normal[0], normal[1], normal[2]
    ux, uy, uz = wvel[0], wvel[1], wvel[2]
    for k in range(idx.shape[0]):
        i = np.uint64(idx[k])
        dist = ((pos[i, 0] - px) * qx + (pos[i, 1] - py) * qy
                + (pos[i, 2] - pz) * qz)
        overlap = radius[i] - dist
        if overlap <= 0.0 and (law == HOOKE_HISTORY or overlap + reach_t * abs(
                (vel[i, 0] - ux) * qx + (vel[i, 1] - uy) * qy + (vel[i, 2] - uz) * qz) <= 0.0):
            hist[i, 0] = 0.0
            hist[i, 1] = 0.0
            hist[i, 2] = 0.0
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            continue
        if overlap > 0.0:
            n += 1
        if wall_contact(i, -normal[0], -normal[1], -normal[2], overlap, wvel, hist, rhist, pos, vel, omega, vel_h,
                        omega_h, radius, mass, inertia, props, wprops, dt, lo, hi, force, torque, out, mr, law) <= 0.0:
            continue
        reaction[0] -= out[0]
        reaction[1] -= out[1]
        reaction[2] -= out[2]
    return n


@numba.njit(cache=True, inline="always", error_model="numpy")
def _bilinear(x0, y0, hx, hy, bed, px, py):
    """Bed elevation and gradient of the bilinear surface through cell-centre values."""
    ny, nx = bed.shape
    fx = (px - x0) / hx
    fy = (py - y0) / hy
    ix = min(max(int(math.floor(fx)), 0), nx - 2)
    iy = min(max(int(math.floor(fy)), 0), ny - 2)
    tx = fx - ix
    ty = fy - iy
    z00 = bed[iy, ix]
    z10 = bed[iy, ix + 1]
    z01 = bed[iy + 1, ix]
    z11 = bed[iy + 1, ix + 1]
    z = (z00 * (1 - tx) * (1 - ty) + z10 * tx * (1 - ty) + z01 * (1 - tx) * ty + z11 * tx * ty)
    gx = ((z10 - z00) * (1 - ty) + (z11 - z01) * ty) / hx
    gy = ((z01 - z00) * (1 - tx) + (z11 - z10) * tx) / hy
    return z, gx, gy


@numba.njit(cache=True, error_model="numpy")
def heightfield_forces(idx, x0, y0, hx, hy, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia,
                       props, dt, force, torque, lo, hi, vel_h, omega_h, law=0):
    """Contacts with the terrain ``z = bed(x, y)`` (bilinear through the grid's cell centres).

    The contact point is the foot of the perpendicular from the centre on the local tangent plane,
    refined by three fixed-point iterations (exact on planar patches). Outside the grid: no contact.
    Forces are averaged over the force window ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`).
    """
    out = np.empty(7)
    mr = np.empty(3)
    wvel = np.zeros(3)
    reach_t = max(-lo, hi) if law == WINDOW_AVERAGED else 0.0  # hooke_history: point values
    ny, nx = bed.shape
    xmax = x0 + (nx - 1) * hx
    ymax = y0 + (ny - 1) * hy
    n = 0
    for k in range(idx.shape[0]):
        i = idx[k]
        px = pos[i, 0]
        py = pos[i, 1]
        pz = pos[i, 2]
        if px < x0 or px > xmax or py < y0 or py > ymax:
            hist[i, 0] = 0.0
            hist[i, 1] = 0.0
            hist[i, 2] = 0.0
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            continue
        qx = px
        qy = py
        dist = 0.0
        nux = 0.0
        nuy = 0.0
        nuz = 1.0
        for it in range(3):
            z, gx, gy = _bilinear(x0, y0, hx, hy, bed, min(max(qx, x0), xmax), min(max(qy, y0), ymax))
            norm = math.sqrt(gx * gx + gy * gy + 1.0)
            nux = -gx / norm
            nuy = -gy / norm
            nuz = 1.0 / norm
            dist = (px - qx) * nux + (py - qy) * nuy + (pz - z) * nuz
            qx = px - dist * nux
            qy = py - dist * nuy
        overlap = radius[i] - dist
        if overlap <= 0.0 and overlap + reach_t * abs(vel[i, 0] * nux + vel[i, 1] * nuy + vel[i, 2] * nuz) <= 0.0:
            hist[i, 0] = 0.0
            hist[i, 1] = 0.0
            hist[i, 2] = 0.0
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            continue
        if overlap > 0.0:
            n += 1
        wall_contact(i, -nux, -nuy, -nuz, overlap, wvel, hist, rhist, pos, vel, omega, vel_h, omega_h, radius, mass,
                     inertia, props, wprops, dt, lo, hi, force, torque, out, mr, law)
    return n


#: the guard of the candidate lists (:func:`candidates_hold`) keeps this fraction of the margin in reserve,
#: far above the rounding of the gap, displacement and speed arithmetic (relative 1e-15 of the coordinates)
CANDIDATE_RESERVE = 0.125


@numba.njit(cache=True, error_model="numpy")
def plane_candidates(idx, pos_ref, radius, point, normal, margin, hist, rhist, out):
    """The particles of *idx* (in its order, into *out*; returns their count) that the plane loop must visit
    while :func:`candidates_hold`: those whose gap to the plane through *point* with unit *normal* at the
    reference positions *pos_ref* (the neighbour list's build positions), ``(x - point) . normal - r``, is
    below *margin* (or not a number), and those whose shear or rolling history row is not +0.0 in every bit
    (a contact the loop has not cleared yet: a far particle's rows are +0.0, as the plane loop leaves them).
    The others have rows of +0.0 and are far from the plane until they moved ``margin`` from *pos_ref*."""
    px, py, pz = point[0], point[1], point[2]
    qx, qy, qz = normal[0], normal[1], normal[2]
    m = 0
    for k in range(idx.shape[0]):
        i = idx[k]
        gap = (pos_ref[i, 0] - px) * qx + (pos_ref[i, 1] - py) * qy + (pos_ref[i, 2] - pz) * qz - radius[i]
        keep = not gap >= margin
        if not keep:
            for d in range(3):
                if (hist[i, d] != 0.0 or rhist[i, d] != 0.0 or math.copysign(1.0, hist[i, d]) < 0.0
                        or math.copysign(1.0, rhist[i, d]) < 0.0):
                    keep = True
        if keep:
            out[m] = i
            m += 1
    return m


@numba.njit(cache=True, inline="always", error_model="numpy")
def candidates_hold(moved, reach, margin):
    """Whether every particle left out of the :func:`plane_candidates` lists built with *margin* is far from
    its plane now: each moved at most *moved* from its reference position and reaches at most *reach* further
    within the force window (``max(-lo, hi) |v . n|``, the window-averaged law's test in :func:`plane_forces`;
    0 for point values), so its gap is at least ``margin - moved - reach`` > 0 with
    :data:`CANDIDATE_RESERVE` of the margin to spare."""
    return moved + reach <= (1.0 - CANDIDATE_RESERVE) * margin


@numba.njit(cache=True, error_model="numpy")
def max_speed(idx, vel):
    """max ``|v_i|`` over *idx*."""
    m = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        s = vel[i, 0] * vel[i, 0] + vel[i, 1] * vel[i, 1] + vel[i, 2] * vel[i, 2]
        if s > m:
            m = s
    return math.sqrt(m)
