"""Contacts of particles with boundaries (docs/theory.md, *DEM contact*): fixed or moving planes and the terrain as a height
field (split out of :mod:`.pair_contacts`, which re-exports these names).

:func:`plane_candidates` lists, per fixed plane, the particles that can touch it before the next
neighbour-list rebuild, so that the many-steps loop (:mod:`breachflow.coupling.steploop`) runs the plane loop over those
only (issue 16).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .contact_law import HOOKE_HISTORY, STEP_AVERAGED, contact_law, hooke_history, rolling_law
from .pocket import pocket_tangent


#: the kinds of boundary of ``_wall_loop`` (compile-time constants)
PLANE, HEIGHT_FIELD = 0, 1


@numba.njit(cache=True, error_model="numpy")
def plane_forces(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props,
                 dt, force, torque, reaction, lo, hi, vel_h, omega_h, law=0):
    """Contacts of particles *idx* with the plane through *point* with unit *normal* (into the domain)
    moving at *wvel* (``_wall_loop``).

    Adds the force on the plane (minus the sum of particle forces) to *reaction*; returns #contacts
    (overlapping now). Forces are averaged over the force interval ``[lo, hi]``
    (:func:`~breachflow.dem.contact_law.contact_law`). The loop is compiled once per contact law (*law* a
    constant in each copy), as the pair loop: with both laws in one loop, the interval law's code slowed the
    loop by 12 % for either law.
    """
    geom = (point[0], point[1], point[2], normal[0], normal[1], normal[2], wvel[0], wvel[1], wvel[2])
    if law == HOOKE_HISTORY:
        return _wall_loop(idx, geom, hist, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt,
                          force, torque, reaction, lo, hi, vel_h, omega_h, HOOKE_HISTORY, PLANE)
    return _wall_loop(idx, geom, hist, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force,
                      torque, reaction, lo, hi, vel_h, omega_h, STEP_AVERAGED, PLANE)


@numba.njit(cache=True, error_model="numpy")
def heightfield_forces(idx, x0, y0, hx, hy, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia,
                       props, dt, force, torque, lo, hi, vel_h, omega_h, law=0):
    """Contacts with the terrain ``z = bed(x, y)`` (bilinear through the grid's cell centres; ``_wall_loop``).

    The contact point is the foot of the perpendicular from the centre on the local tangent plane,
    refined by three fixed-point iterations (exact on planar patches). Outside the grid: no contact.
    Forces are averaged over the force interval ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`).
    Returns #contacts (overlapping now).
    """
    geom = (x0, y0, hx, hy, 0.0, 0.0, 0.0, 0.0, 0.0)
    return _wall_loop(idx, geom, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force,
                      torque, np.zeros(3), lo, hi, vel_h, omega_h, law, HEIGHT_FIELD)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _wall_loop(idx, geom, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force, torque,
               reaction, lo, hi, vel_h, omega_h, law, kind):
    """Contacts of particles *idx* with one boundary: a plane (*kind* PLANE, *geom* = point, unit normal into
    the domain, velocity; *bed* unused; the reaction added to *reaction*) or the height field *bed* (*kind*
    HEIGHT_FIELD, *geom* = x0, y0, hx, hy, ...; at rest). Returns #contacts (overlapping now).

    Contact (docs/theory.md, *DEM contact*) with the normal n from the centre towards the boundary, averaged over the force interval
    ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`); *vel*, *omega* at the evaluation time,
    *vel_h*, *omega_h* over the last step; hist / rhist: the boundary's (N, 3) per-particle shear /
    rolling-moment histories; the contact's properties are the minimum of the particle's row of *props* and
    *wprops*.

    Written as one loop with the contact law called in it, and no helper between them: a helper inlined with
    array arguments (as ``wall_contact`` was, with 17) costs an ``NRT_incref`` / ``NRT_decref`` call pair
    (atomic) per array and contact that numba's reference-count pruning leaves in place; those calls were
    most of a plane contact's cost (about 100 against 20 ns on the 1000-sphere settled bed, ``python3 tasks.py
    bench dem_plane --old <src>``), with the same results bit for bit. Rows are indexed unsigned and 2-D: flat
    views (as in the pair loop) cost about 120 ns per call for their reshapes and gained nothing per contact.
    """
    mr = np.empty(3)
    n = 0
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0  # hooke_history: point values
    # plane: point p, unit normal q into the domain, velocity u (locals: a store into the histories may alias
    # the arrays, which would otherwise be reloaded for every particle)
    px, py, pz, qx, qy, qz, ux, uy, uz = geom
    x0, y0, hx, hy = px, py, pz, qx  # height field: grid origin and spacing
    nby, nbx = bed.shape
    xmax = x0 + (nbx - 1) * hx
    ymax = y0 + (nby - 1) * hy
    al_w, be_w, kn_w, ks_w, ccn_w, ccs_w, ccf_w, mur_w = (wprops[0], wprops[1], wprops[2], wprops[3], wprops[4],
                                                          wprops[5], wprops[6], wprops[7])
    # a rough bed (height field with the pocket columns d_bed, z_star; :mod:`.pocket`): friction and rolling
    # resistance at least tan(phi0) of the particle's pocket; a smooth bed (8 columns) skips it
    rough = kind == HEIGHT_FIELD and wprops.shape[0] > 9 and wprops[8] > 0.0
    d_bed = wprops[8] if rough else 0.0
    z_star = wprops[9] if rough else 0.0
    rx, ry, rz = reaction[0], reaction[1], reaction[2]  # the plane's reaction, summed in registers
    for k in range(idx.shape[0]):
        i = np.uint64(idx[k])  # unsigned: no negative-index wraparound test on each access
        ri = radius[i]
        v0, v1, v2 = vel[i, 0], vel[i, 1], vel[i, 2]
        if kind == PLANE:
            dist = ((pos[i, 0] - px) * qx + (pos[i, 1] - py) * qy
                    + (pos[i, 2] - pz) * qz)
            overlap = ri - dist
            apart = overlap <= 0.0 and (law == HOOKE_HISTORY or overlap + reach_t * abs(
                (v0 - ux) * qx + (v1 - uy) * qy + (v2 - uz) * qz) <= 0.0)
        else:
            cx = pos[i, 0]
            cy = pos[i, 1]
            cz = pos[i, 2]
            apart = cx < x0 or cx > xmax or cy < y0 or cy > ymax  # outside the grid: no contact
            overlap = 0.0
            if not apart:
                sx = cx
                sy = cy
                dist = 0.0
                qx = 0.0
                qy = 0.0
                qz = 1.0
                for it in range(3):
                    z, gx, gy = _bilinear(x0, y0, hx, hy, bed, min(max(sx, x0), xmax), min(max(sy, y0), ymax))
                    norm = math.sqrt(gx * gx + gy * gy + 1.0)
                    qx = -gx / norm
                    qy = -gy / norm
                    qz = 1.0 / norm
                    dist = (cx - sx) * qx + (cy - sy) * qy + (cz - z) * qz
                    sx = cx - dist * qx
                    sy = cy - dist * qy
                overlap = ri - dist
                apart = overlap <= 0.0 and overlap + reach_t * abs(v0 * qx + v1 * qy + v2 * qz) <= 0.0
        if apart:
            hist[i, 0] = 0.0
            hist[i, 1] = 0.0
            hist[i, 2] = 0.0
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            continue
        if overlap > 0.0:
            n += 1
        nx, ny, nz = -qx, -qy, -qz
        # velocity of the boundary's contact point relative to i's: u - v_i - (r_i w_i) x n
        o0, o1, o2 = omega[i, 0], omega[i, 1], omega[i, 2]
        wx = ri * o0
        wy = ri * o1
        wz = ri * o2
        vx = ux - v0 - (wy * nz - wz * ny)
        vy = uy - v1 - (wz * nx - wx * nz)
        vz = uz - v2 - (wx * ny - wy * nx)
        wx = ri * omega_h[i, 0]
        wy = ri * omega_h[i, 1]
        wz = ri * omega_h[i, 2]
        gx = ux - vel_h[i, 0] - (wy * nz - wz * ny)
        gy = uy - vel_h[i, 1] - (wz * nx - wx * nz)
        gz = uz - vel_h[i, 2] - (wx * ny - wy * nx)
        kn = min(props[i, 2], kn_w)
        beta = min(props[i, 1], be_w)
        mu_r = min(props[i, 7], mur_w)
        if rough:
            pocket = pocket_tangent(2.0 * ri, d_bed, z_star)
            beta = max(beta, pocket)
            mu_r = max(mu_r, pocket)
        if law == HOOKE_HISTORY:
            phi, fx, fy, fz, ftx, fty, ftz, fn = hooke_history(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i,
                                                               kn, min(props[i, 3], ks_w), min(props[i, 4], ccn_w),
                                                               min(props[i, 5], ccs_w), min(props[i, 0], al_w),
                                                               beta, dt)
        else:
            phi, fx, fy, fz, ftx, fty, ftz, fn = contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i, kn,
                                                             min(props[i, 3], ks_w), min(props[i, 4], ccn_w),
                                                             min(props[i, 5], ccs_w), min(props[i, 6], ccf_w),
                                                             min(props[i, 0], al_w), beta, dt, lo, hi)
        if overlap <= 0.0:  # touching only within the interval: no rolling contact now
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            if phi <= 0.0:
                continue
        force[i, 0] += fx
        force[i, 1] += fy
        force[i, 2] += fz
        torque[i, 0] += ri * (ny * ftz - nz * fty)
        torque[i, 1] += ri * (nz * ftx - nx * ftz)
        torque[i, 2] += ri * (nx * fty - ny * ftx)
        if mu_r > 0.0 and overlap > 0.0:
            rolling_law(nx, ny, nz, o0, o1, o2, fn, ri, mu_r, kn, inertia[i] + mass[i] * ri * ri, rhist, i, dt, mr)
            torque[i, 0] += mr[0]
            torque[i, 1] += mr[1]
            torque[i, 2] += mr[2]
        if phi <= 0.0:
            continue
        rx -= fx
        ry -= fy
        rz -= fz
    if kind == PLANE:
        reaction[0] = rx
        reaction[1] = ry
        reaction[2] = rz
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
    within the force interval (``max(-lo, hi) |v . n|``, the step-averaged law's test in :func:`plane_forces`;
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
