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
                          force, torque, reaction, lo, hi, vel_h, omega_h, HOOKE_HISTORY, PLANE, hist, hist)
    # the terrain's scratch arrays are not used on a plane: the histories stand in (no allocation per call)
    return _wall_loop(idx, geom, hist, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force,
                      torque, reaction, lo, hi, vel_h, omega_h, STEP_AVERAGED, PLANE, hist, hist)


@numba.njit(cache=True, error_model="numpy")
def heightfield_forces(idx, x0, y0, hx, hy, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia,
                       props, dt, force, torque, lo, hi, vel_h, omega_h, law=0):
    """Contacts with the terrain ``z = bed(x, y)`` (bilinear through the grid's cell centres; ``_wall_loop``).

    The contacts are the nearest points of the patches under the particle (:func:`terrain_contacts`): one on
    a plane, the floor and the wall at a wall's foot. Outside the grid: no contact.
    Forces are averaged over the force interval ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`).
    Returns #contacts (overlapping now).
    """
    geom = (x0, y0, hx, hy, 0.0, 0.0, 0.0, 0.0, 0.0)
    return _wall_loop(idx, geom, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force,
                      torque, np.zeros(3), lo, hi, vel_h, omega_h, law, HEIGHT_FIELD,
                      np.empty((MAX_TERRAIN_CONTACTS, 4)), np.empty((MAX_TERRAIN_CANDIDATES, 5)))


@numba.njit(cache=True, inline="always", error_model="numpy")
def _wall_loop(idx, geom, bed, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props, dt, force, torque,
               reaction, lo, hi, vel_h, omega_h, law, kind, cts, found):
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
    # height field: *cts* the terrain's contacts of one particle (:func:`terrain_contacts`; rows nx, ny, nz,
    # overlap; the first keeps the particle's histories), *found* its scratch
    for k in range(idx.shape[0]):
        i = np.uint64(idx[k])  # unsigned: no negative-index wraparound test on each access
        ri = radius[i]
        v0, v1, v2 = vel[i, 0], vel[i, 1], vel[i, 2]
        m = 1
        if kind == PLANE:
            dist = ((pos[i, 0] - px) * qx + (pos[i, 1] - py) * qy
                    + (pos[i, 2] - pz) * qz)
            overlap = ri - dist
            apart = overlap <= 0.0 and (law == HOOKE_HISTORY or overlap + reach_t * abs(
                (v0 - ux) * qx + (v1 - uy) * qy + (v2 - uz) * qz) <= 0.0)
        else:
            m = terrain_contacts(x0, y0, hx, hy, bed, pos[i, 0], pos[i, 1], pos[i, 2], ri, v0, v1, v2, reach_t,
                                 cts, found)
            apart = m == 0
        if apart:
            hist[i, 0] = 0.0
            hist[i, 1] = 0.0
            hist[i, 2] = 0.0
            rhist[i, 0] = 0.0
            rhist[i, 1] = 0.0
            rhist[i, 2] = 0.0
            continue
        for c in range(m):
            if kind == HEIGHT_FIELD:
                qx, qy, qz, overlap = cts[c, 0], cts[c, 1], cts[c, 2], cts[c, 3]
            # the first contact keeps the particle's shear and rolling histories; a further one (a wall beside
            # the floor it rests on) starts from none each step: its normal force and its friction within the
            # step, no elastic shear memory (the particle's row is set aside while it is computed)
            if c > 0:
                s0, s1, s2 = hist[i, 0], hist[i, 1], hist[i, 2]
                hist[i, 0] = 0.0
                hist[i, 1] = 0.0
                hist[i, 2] = 0.0
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
            mu_r = min(props[i, 7], mur_w) if c == 0 else 0.0
            if rough:
                pocket = pocket_tangent(2.0 * ri, d_bed, z_star)
                beta = max(beta, pocket)
                mu_r = max(mu_r, pocket) if c == 0 else 0.0
            if law == HOOKE_HISTORY:
                phi, fx, fy, fz, ftx, fty, ftz, fn = hooke_history(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist,
                                                                   i, kn, min(props[i, 3], ks_w),
                                                                   min(props[i, 4], ccn_w), min(props[i, 5], ccs_w),
                                                                   min(props[i, 0], al_w), beta, dt)
            else:
                phi, fx, fy, fz, ftx, fty, ftz, fn = contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i,
                                                                 kn, min(props[i, 3], ks_w), min(props[i, 4], ccn_w),
                                                                 min(props[i, 5], ccs_w), min(props[i, 6], ccf_w),
                                                                 min(props[i, 0], al_w), beta, dt, lo, hi)
            if c > 0:
                hist[i, 0] = s0
                hist[i, 1] = s1
                hist[i, 2] = s2
            elif overlap <= 0.0:  # touching only within the interval: no rolling contact now
                rhist[i, 0] = 0.0
                rhist[i, 1] = 0.0
                rhist[i, 2] = 0.0
            if overlap <= 0.0:
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


#: most contacts a particle has with the terrain at once (a floor and a wall, a valley's two sides)
MAX_TERRAIN_CONTACTS = 4
#: most patches of the terrain a particle's footprint is searched over (beyond: the nearest to its centre)
MAX_TERRAIN_CANDIDATES = 36
#: two terrain contacts whose normals are closer than this angle (cosine of 15 degrees) are one contact, the
#: deeper kept: the bilinear patches of a smooth slope each have a nearest point of their own
SAME_CONTACT_COS = 0.9659258262890683


@numba.njit(cache=True, inline="always", error_model="numpy")
def _patch(x0, y0, hx, hy, bed, ix, iy, px, py):
    """Elevation and gradient at (px, py) of the bilinear patch (ix, iy) (between cell centres ix, ix + 1 and
    iy, iy + 1), whatever patch the point's own coordinates fall in."""
    return _on_patch(bed, ix, iy, (px - (x0 + ix * hx)) / hx, (py - (y0 + iy * hy)) / hy, hx, hy)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _on_patch(bed, ix, iy, tx, ty, hx, hy):
    """Elevation and gradient of the bilinear patch (ix, iy) at its local coordinates (tx, ty) (0..1)."""
    z00 = bed[iy, ix]
    z10 = bed[iy, ix + 1]
    z01 = bed[iy + 1, ix]
    z11 = bed[iy + 1, ix + 1]
    z = (z00 * (1 - tx) * (1 - ty) + z10 * tx * (1 - ty) + z01 * (1 - tx) * ty + z11 * tx * ty)
    gx = ((z10 - z00) * (1 - ty) + (z11 - z01) * ty) / hx
    gy = ((z01 - z00) * (1 - tx) + (z11 - z10) * tx) / hy
    return z, gx, gy


@numba.njit(cache=True, inline="always", error_model="numpy")
def terrain_contacts(x0, y0, hx, hy, bed, cx, cy, cz, r, vx, vy, vz, reach_t, out, found):
    """The contacts of a sphere (centre c, radius *r*, velocity v) with the terrain ``z = bed(x, y)``
    (bilinear patches between the cell centres of a grid at *x0*, *y0* spaced *hx*, *hy*), into the rows of
    *out* ``(nx, ny, nz, overlap)``, n the unit normal from the terrain towards the centre; returns their
    number (0 outside the grid, where there is no terrain). Rows of *found* (``MAX_TERRAIN_CANDIDATES`` x 5)
    are scratch.

    Every patch under the sphere's footprint ``[c - r, c + r]`` is searched for its point nearest the centre:
    three fixed-point steps to the foot of the perpendicular on the patch's tangent plane, kept on the patch.
    A foot inside the patch is a *face* contact (normal: the patch's, distance signed along it); a foot the
    patch's edges stop is an *edge* contact at that point of the surface (normal: from the point to the
    centre; a centre that has sunk below the terrain where it stands keeps the patch's normal and the signed
    distance along it). Face contacts count, the deepest first, unless within 15 degrees (:data:`SAME_CONTACT_COS`) of
    one already counted; an edge contact counts only where it is deeper than every face contact counted and
    not within 15 degrees of a contact counted (a ridge or a step's edge; not the edge of the patch next to
    the one a sphere rests on). A contact counts when the overlap ``r - distance`` is positive, or reaches
    zero within the force interval (``overlap + reach_t |v . n| > 0``). The first row is the contact whose
    normal is the most upward (the floor beside a wall): it keeps the particle's histories.

    A single tangent plane at the foot below the centre (this loop's former contact) missed a breach wall
    beside the floor a sphere rested on until the sphere's centre had passed over the wall's foot, and then
    pushed it out of the wall at once; near a wall's top it alternated between the wall's plane and the
    crest's, so a sphere dropped onto a 75-degree wall of 2 m cells was shot out at 12 m/s."""
    ny_, nx_ = bed.shape
    xmax = x0 + (nx_ - 1) * hx
    ymax = y0 + (ny_ - 1) * hy
    if cx < x0 or cx > xmax or cy < y0 or cy > ymax:  # outside the grid: no contact
        return 0
    ix0 = min(max(int(math.floor((cx - r - x0) / hx)), 0), nx_ - 2)
    ix1 = min(max(int(math.floor((cx + r - x0) / hx)), 0), nx_ - 2)
    iy0 = min(max(int(math.floor((cy - r - y0) / hy)), 0), ny_ - 2)
    iy1 = min(max(int(math.floor((cy + r - y0) / hy)), 0), ny_ - 2)
    # footprints wider than the scratch: the patches nearest the centre
    kx = int(math.sqrt(MAX_TERRAIN_CANDIDATES))
    if ix1 - ix0 + 1 > kx:
        ic = min(max(int(math.floor((cx - x0) / hx)), 0), nx_ - 2)
        ix0 = max(ic - kx // 2, 0)
        ix1 = min(ix0 + kx - 1, nx_ - 2)
    if iy1 - iy0 + 1 > kx:
        jc = min(max(int(math.floor((cy - y0) / hy)), 0), ny_ - 2)
        iy0 = max(jc - kx // 2, 0)
        iy1 = min(iy0 + kx - 1, ny_ - 2)
    # far above every corner of the patches under it (and not reaching them within the force interval): apart.
    # The bilinear surface lies below its highest corner, so this is exact; most of a pile is above its floor.
    top = -np.inf
    for iy in range(iy0, iy1 + 2):
        for ix in range(ix0, ix1 + 2):
            top = max(top, bed[iy, ix])
    if cz - r - reach_t * math.sqrt(vx * vx + vy * vy + vz * vz) > top:
        return 0
    # the centre above the terrain where it stands (a centre below it has sunk in: the patches' planes push it out)
    above = cz >= _bilinear(x0, y0, hx, hy, bed, cx, cy)[0]
    nf = 0
    for iy in range(iy0, iy1 + 1):
        ya = y0 + iy * hy
        yb = ya + hy
        for ix in range(ix0, ix1 + 1):
            xa = x0 + ix * hx
            xb = xa + hx
            sx = min(max(cx, xa), xb)
            sy = min(max(cy, ya), yb)
            face = True
            for it in range(3):
                z, gx, gy = _patch(x0, y0, hx, hy, bed, ix, iy, sx, sy)
                norm = math.sqrt(gx * gx + gy * gy + 1.0)
                qx = -gx / norm
                qy = -gy / norm
                qz = 1.0 / norm
                d = (cx - sx) * qx + (cy - sy) * qy + (cz - z) * qz
                tx = cx - d * qx
                ty = cy - d * qy
                sx = min(max(tx, xa), xb)
                sy = min(max(ty, ya), yb)
                face = sx == tx and sy == ty
            z, gx, gy = _patch(x0, y0, hx, hy, bed, ix, iy, sx, sy)
            norm = math.sqrt(gx * gx + gy * gy + 1.0)
            qx = -gx / norm
            qy = -gy / norm
            qz = 1.0 / norm
            ex = cx - sx
            ey = cy - sy
            ez = cz - z
            d = ex * qx + ey * qy + ez * qz
            if not face and above:  # an edge or corner point, the centre above the terrain: towards the centre
                le = math.sqrt(ex * ex + ey * ey + ez * ez)
                if le > 0.0:
                    qx = ex / le
                    qy = ey / le
                    qz = ez / le
                    d = le
            overlap = r - d
            if overlap <= 0.0 and overlap + reach_t * abs(vx * qx + vy * qy + vz * qz) <= 0.0:
                continue
            found[nf, 0] = qx
            found[nf, 1] = qy
            found[nf, 2] = qz
            found[nf, 3] = overlap
            found[nf, 4] = 1.0 if face else 0.0
            nf += 1
    m = 0
    edges = 0
    deepest_face = -np.inf
    for kind in range(2):  # faces first, then edges
        while True:
            best = -1
            for f in range(nf):
                if found[f, 4] == 1.0 - kind and (best < 0 or found[f, 3] > found[best, 3]):
                    best = f
            if best < 0:
                break
            found[best, 4] = -1.0  # taken
            if kind == 1 and (found[best, 3] <= deepest_face or edges == 1):
                continue
            same = False
            for c in range(m):
                if (found[best, 0] * out[c, 0] + found[best, 1] * out[c, 1]
                        + found[best, 2] * out[c, 2]) > SAME_CONTACT_COS:
                    same = True
            if same or m == out.shape[0]:
                continue
            out[m, 0] = found[best, 0]
            out[m, 1] = found[best, 1]
            out[m, 2] = found[best, 2]
            out[m, 3] = found[best, 3]
            m += 1
            if kind == 0:
                deepest_face = max(deepest_face, found[best, 3])
            else:
                edges += 1
    # the most upward normal first: it keeps the histories
    top = 0
    for c in range(1, m):
        if out[c, 2] > out[top, 2]:
            top = c
    if top > 0:
        for j in range(4):
            t = out[0, j]
            out[0, j] = out[top, j]
            out[top, j] = t
    return m


@numba.njit(cache=True, inline="always", error_model="numpy")
def _bilinear(x0, y0, hx, hy, bed, px, py):
    """Bed elevation and gradient of the bilinear surface through cell-centre values."""
    ny, nx = bed.shape
    fx = (px - x0) / hx
    fy = (py - y0) / hy
    ix = min(max(int(math.floor(fx)), 0), nx - 2)
    iy = min(max(int(math.floor(fy)), 0), ny - 2)
    return _on_patch(bed, ix, iy, fx - ix, fy - iy, hx, hy)



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
