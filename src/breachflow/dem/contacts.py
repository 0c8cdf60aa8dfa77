"""Contact detection and the linear spring–dashpot contact law with friction history (SPEC §5).

Neighbour search: a hashed cell grid. Each particle is inserted in every cell its bounding box
(radius + skin/2) overlaps, so the cell size can follow the *typical* diameter while a 10:1 size
ratio only costs the few large particles more insertions; a pair is reported once, from the cell
at the minimum corner of the intersection of both boxes. Only awake particles search, so the cost
follows the number of moving particles (sleeping ones sit in a separate grid rebuilt on sleep/wake).
Periodic x / y use minimum-image distances and wrapped cell coordinates.

Contact law (SPEC §5): :mod:`.contact_law` (the window-averaged spring–dashpot, rolling resistance).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .contact_law import (ROLLING_DAMPING_RATIO, ROLLING_STIFFNESS, contact_law, contact_window,  # noqa: F401
                          rolling_law)

OFFSET = 1 << 20  # cell-coordinate offset for packing three signed ints into one int64


@numba.njit(cache=True, inline="always", error_model="numpy")
def _pack(cx, cy, cz):
    return ((cx + OFFSET) << 42) | ((cy + OFFSET) << 21) | (cz + OFFSET)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _hash(code, mask):
    h = (code * 0x5851F42D4C957F2D) & 0x7FFFFFFFFFFFFFFF
    return (h >> 17) & mask


@numba.njit(cache=True, inline="always", error_model="numpy")
def _wrap_cell(c, n, periodic):
    if periodic:
        c = c % n
        if c < 0:
            c += n
    return c


@numba.njit(cache=True, error_model="numpy")
def build_grid(idx, pos, radius, margin, geom, periodic, ncell, table_bits, single):
    """Hashed cell grid of particles *idx*: each in every cell its box overlaps, or (``single``, for
    nearly uniform sizes with cells >= the largest reach) only in the cell of its centre.

    geom = (origin xyz, cell size xyz, period Lx, Ly); periodic = (px, py) as int;
    ncell = cells per period in x, y. Returns (bucket_start, entry_particle, entry_code).
    """
    size = 1 << table_bits
    mask = size - 1
    counts = np.zeros(size + 1, np.int64)
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    for pass_ in range(2):
        if pass_ == 1:
            total = 0
            for b in range(size):
                c = counts[b]
                counts[b] = total
                total += c
            counts[size] = total
            fill = counts[:size].copy()
            ent_p = np.empty(total, np.int64)
            ent_c = np.empty(total, np.int64)
        for k in range(idx.shape[0]):
            i = idx[k]
            r = 0.0 if single else radius[i] + margin
            for d in range(3):
                lo[d] = int(math.floor((pos[i, d] - r - geom[d]) / geom[3 + d]))
                hi[d] = int(math.floor((pos[i, d] + r - geom[d]) / geom[3 + d]))
            for cx in range(lo[0], hi[0] + 1):
                wx = _wrap_cell(cx, ncell[0], periodic[0])
                for cy in range(lo[1], hi[1] + 1):
                    wy = _wrap_cell(cy, ncell[1], periodic[1])
                    for cz in range(lo[2], hi[2] + 1):
                        code = _pack(wx, wy, cz)
                        b = _hash(code, mask)
                        if pass_ == 0:
                            counts[b] += 1
                        else:
                            s = fill[b]
                            ent_p[s] = i
                            ent_c[s] = code
                            fill[b] = s + 1
    return counts, ent_p, ent_c


@numba.njit(cache=True, inline="always", error_model="numpy")
def min_image(dx, L, periodic):
    if periodic:
        dx -= L * math.floor(dx / L + 0.5)
    return dx


@numba.njit(cache=True, error_model="numpy")
def _scan(i, lo, hi, pos, radius, margin, geom, periodic, ncell, start, ent_p, ent_c, mask,
          only_greater, single, out_a, out_b, n_out):
    cap = out_a.shape[0]
    for cx in range(lo[0], hi[0] + 1):
        wx = _wrap_cell(cx, ncell[0], periodic[0])
        for cy in range(lo[1], hi[1] + 1):
            wy = _wrap_cell(cy, ncell[1], periodic[1])
            for cz in range(lo[2], hi[2] + 1):
                code = _pack(wx, wy, cz)
                b = _hash(code, mask)
                for s in range(start[b], start[b + 1]):
                    if ent_c[s] != code:
                        continue
                    j = ent_p[s]
                    if j == i or (only_greater and j < i):
                        continue
                    dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
                    dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
                    dz = pos[j, 2] - pos[i, 2]
                    if not single:
                        rj = radius[j] + margin
                        # report once: only from the min corner of the two boxes' intersection
                        jx = int(math.floor((pos[i, 0] + dx - rj - geom[0]) / geom[3]))
                        jy = int(math.floor((pos[i, 1] + dy - rj - geom[1]) / geom[4]))
                        jz = int(math.floor((pos[i, 2] + dz - rj - geom[2]) / geom[5]))
                        if max(lo[0], jx) != cx or max(lo[1], jy) != cy or max(lo[2], jz) != cz:
                            continue
                    reach = radius[i] + radius[j] + 2.0 * margin
                    if dx * dx + dy * dy + dz * dz < reach * reach:
                        if n_out < cap:
                            out_a[n_out] = min(i, j)
                            out_b[n_out] = max(i, j)
                        n_out += 1
    return n_out


@numba.njit(cache=True, error_model="numpy")
def _find_pairs_dense(search_idx, pos, radius, margin, geom, periodic, ncell, out_a, out_b):
    """:func:`_find_pairs_half` on a dense cell array over the particles' bounding box (counting sort, as
    LAMMPS' bins); returns -1 when that box holds more than 27 cells per particle (sparse: use the hash)."""
    n = search_idx.shape[0]
    cell = np.empty((n, 3), np.int64)
    lo = np.zeros(3, np.int64)
    dim = np.zeros(3, np.int64)
    for k in range(n):
        i = search_idx[k]
        for d in range(3):
            c = int(math.floor((pos[i, d] - geom[d]) / geom[3 + d]))
            if d < 2 and periodic[d]:
                c = _wrap_cell(c, ncell[d], 1)
            cell[k, d] = c
            if k == 0 or c < lo[d]:
                lo[d] = c
            if k == 0 or c > dim[d]:
                dim[d] = c  # the largest cell for now
    for d in range(3):
        dim[d] = dim[d] - lo[d] + 1
    for d in range(2):
        if periodic[d]:
            lo[d] = 0
            dim[d] = ncell[d]
    total = dim[0] * dim[1] * dim[2]
    if n == 0 or total > 27 * n + 4096:
        return 0 if n == 0 else -1
    start = np.zeros(total + 1, np.int64)
    home = np.empty(n, np.int64)
    for k in range(n):
        c = ((cell[k, 2] - lo[2]) * dim[1] + (cell[k, 1] - lo[1])) * dim[0] + (cell[k, 0] - lo[0])
        home[k] = c
        start[c + 1] += 1
    for c in range(total):
        start[c + 1] += start[c]
    fill = start[:total].copy()
    order = np.empty(n, np.int64)
    for k in range(n):
        order[fill[home[k]]] = search_idx[k]
        fill[home[k]] += 1
    cap = out_a.shape[0]
    n_out = 0
    for k in range(n):
        i = search_idx[k]
        for oz in range(0, 2):
            z = cell[k, 2] - lo[2] + oz
            if z >= dim[2]:
                continue
            for oy in range(-1 if oz else 0, 2):
                y = cell[k, 1] - lo[1] + oy
                if periodic[1]:
                    y = _wrap_cell(y, dim[1], 1)
                elif y < 0 or y >= dim[1]:
                    continue
                for ox in range(-1 if (oz or oy) else 0, 2):
                    x = cell[k, 0] - lo[0] + ox
                    if periodic[0]:
                        x = _wrap_cell(x, dim[0], 1)
                    elif x < 0 or x >= dim[0]:
                        continue
                    own = ox == 0 and oy == 0 and oz == 0
                    c = (z * dim[1] + y) * dim[0] + x
                    for e in range(start[c], start[c + 1]):
                        j = order[e]
                        if own and j <= i:
                            continue
                        dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
                        dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
                        dz = pos[j, 2] - pos[i, 2]
                        reach = radius[i] + radius[j] + 2.0 * margin
                        if dx * dx + dy * dy + dz * dz < reach * reach:
                            if n_out < cap:
                                out_a[n_out] = min(i, j)
                                out_b[n_out] = max(i, j)
                            n_out += 1
    return n_out


@numba.njit(cache=True, error_model="numpy")
def _find_pairs_half(search_idx, pos, radius, margin, geom, periodic, ncell, start, ent_p, ent_c, mask, out_a, out_b):
    """:func:`find_pairs` for one cell per particle (cells >= the largest reach) and no sleeping grid: each
    particle scans its own cell (partners j > i) and the 13 cells of the forward half of its 27-cell
    neighbourhood (all partners), so each pair is met once, from one side (a half stencil, as LAMMPS'
    half neighbour lists; periodic ranges hold >= 4 cells, so forward and backward cells differ)."""
    cap = out_a.shape[0]
    n_out = 0
    for k in range(search_idx.shape[0]):
        i = search_idx[k]
        hx = int(math.floor((pos[i, 0] - geom[0]) / geom[3]))
        hy = int(math.floor((pos[i, 1] - geom[1]) / geom[4]))
        hz = int(math.floor((pos[i, 2] - geom[2]) / geom[5]))
        for oz in range(0, 2):
            for oy in range(-1 if oz else 0, 2):
                for ox in range(-1 if (oz or oy) else 0, 2):
                    own = ox == 0 and oy == 0 and oz == 0
                    code = _pack(_wrap_cell(hx + ox, ncell[0], periodic[0]), _wrap_cell(hy + oy, ncell[1], periodic[1]),
                                 hz + oz)
                    b = _hash(code, mask)
                    for s in range(start[b], start[b + 1]):
                        if ent_c[s] != code:
                            continue
                        j = ent_p[s]
                        if own and j <= i:
                            continue
                        dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
                        dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
                        dz = pos[j, 2] - pos[i, 2]
                        reach = radius[i] + radius[j] + 2.0 * margin
                        if dx * dx + dy * dy + dz * dz < reach * reach:
                            if n_out < cap:
                                out_a[n_out] = min(i, j)
                                out_b[n_out] = max(i, j)
                            n_out += 1
    return n_out


@numba.njit(cache=True, error_model="numpy")
def find_pairs(search_idx, pos, radius, margin, geom, periodic, ncell,
               start_a, ent_p_a, ent_c_a, bits_a, start_s, ent_p_s, ent_c_s, bits_s, single, out_a, out_b):
    """Pairs (a < b) with gap < 2*margin, searched from awake particles *search_idx*.

    Grid "a" holds the awake particles (pairs counted once with j > i), grid "s" the sleeping ones.
    Returns the number of pairs; if it exceeds the capacity of out_a, the caller retries bigger.
    """
    mask_a = (1 << bits_a) - 1
    mask_s = (1 << bits_s) - 1
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    n_out = 0
    if single and ent_p_s.shape[0] == 0:  # awake grid only: half stencil, on a dense grid if compact
        n_out = _find_pairs_dense(search_idx, pos, radius, margin, geom, periodic, ncell, out_a, out_b)
        if n_out >= 0:
            return n_out
        return _find_pairs_half(search_idx, pos, radius, margin, geom, periodic, ncell, start_a, ent_p_a, ent_c_a,
                                mask_a, out_a, out_b)
    for k in range(search_idx.shape[0]):
        i = search_idx[k]
        r = radius[i] + margin
        for d in range(3):
            if single:  # the 27 cells around the home cell (cells are >= the largest reach)
                home = int(math.floor((pos[i, d] - geom[d]) / geom[3 + d]))
                lo[d] = home - 1
                hi[d] = home + 1
            else:
                lo[d] = int(math.floor((pos[i, d] - r - geom[d]) / geom[3 + d]))
                hi[d] = int(math.floor((pos[i, d] + r - geom[d]) / geom[3 + d]))
        n_out = _scan(i, lo, hi, pos, radius, margin, geom, periodic, ncell, start_a, ent_p_a, ent_c_a,
                      mask_a, True, single, out_a, out_b, n_out)
        if ent_p_s.shape[0] > 0:
            n_out = _scan(i, lo, hi, pos, radius, margin, geom, periodic, ncell, start_s, ent_p_s,
                          ent_c_s, mask_s, False, single, out_a, out_b, n_out)
    return n_out


@numba.njit(cache=True, error_model="numpy")
def pair_forces(pa, pb, hist, touching, pos, vel, omega, radius, props, awake, active, geom, periodic,
                dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo=0.0, hi=0.0):
    """:func:`pair_forces_rolling` without rolling histories (rolling resistance ignored)."""
    rhist = np.zeros((pa.shape[0], 3))
    ones = np.ones(radius.shape[0])
    p = props.copy()
    p[:, 7] = 0.0
    return pair_forces_rolling(pa, pb, hist, rhist, touching, pos, vel, omega, radius, ones, ones, p, awake,
                               active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo, hi)


@numba.njit(cache=True, error_model="numpy")
def pair_forces_rolling(pa, pb, hist, rhist, touching, pos, vel, omega, radius, mass, inertia, props, awake,
                        active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo=0.0, hi=0.0):
    """:func:`pair_forces_window` with the same velocities for dashpots and shear increments."""
    return pair_forces_window(pa, pb, hist, rhist, touching, pos, vel, omega, vel, omega, False, radius, mass,
                              inertia, props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake,
                              wake_ids, n_wake, lo, hi)


@numba.njit(cache=True, error_model="numpy")
def pair_forces_window(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius, mass, inertia,
                       props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo,
                       hi):
    """Contact forces of all listed pairs; pairs of two sleeping particles are skipped (frozen).

    *vel*, *omega*: velocities at the evaluation time (dashpots); *vel_h*, *omega_h*: the ones that moved
    the positions over the last step (shear increments, read only if *split*), see
    :func:`~breachflow.dem.contact_law.contact_law`.

    *rhist* (npairs, 3): rolling moment histories (:func:`~breachflow.dem.contact_law.rolling_law`, if the contact's
    rolling_friction, props column 7, is > 0); *mass*, *inertia* (N,) for the rolling dashpot.

    props (N, 8): adhesion, friction, kn, ks, c_cn, c_cs, c_cf (columns 0..6; one cache line per particle). A sleeping partner of a
    moving particle (contact-point speed > wake_speed) gets wake[j] = True and is listed in
    wake_ids[n_wake[0]...]. Forces are averaged over the force window ``[lo, hi]`` (s, relative to now;
    :func:`~breachflow.dem.contact_law.contact_law`), so a pair that touches only within it gets its
    share. Returns #contacts (overlapping now).
    """
    out = np.empty(7)
    mr = np.empty(3)
    ncontacts = 0
    reach_t = max(-lo, hi)
    for p in range(pa.shape[0]):
        i = pa[p]
        j = pb[p]
        if not (awake[i] or awake[j]) or not (active[i] and active[j]):
            continue
        dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
        dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
        dz = pos[j, 2] - pos[i, 2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        ri = radius[i]
        rj = radius[j]
        overlap = ri + rj - dist
        if overlap <= 0.0 and overlap * dist + reach_t * abs(
                (vel[i, 0] - vel[j, 0]) * dx + (vel[i, 1] - vel[j, 1]) * dy + (vel[i, 2] - vel[j, 2]) * dz) <= 0.0:
            hist[p, 0] = 0.0
            hist[p, 1] = 0.0
            hist[p, 2] = 0.0
            rhist[p, 0] = 0.0
            rhist[p, 1] = 0.0
            rhist[p, 2] = 0.0
            touching[p] = False
            continue
        if dist > 1e-12 * (ri + rj):
            nx = dx / dist
            ny = dy / dist
            nz = dz / dist
        else:  # coincident centres: any direction will do, pick +z
            nx, ny, nz = 0.0, 0.0, 1.0
        # velocity of j's contact point relative to i's: v_j - v_i - (ri w_i + rj w_j) x n
        wx = ri * omega[i, 0] + rj * omega[j, 0]
        wy = ri * omega[i, 1] + rj * omega[j, 1]
        wz = ri * omega[i, 2] + rj * omega[j, 2]
        vx = vel[j, 0] - vel[i, 0] - (wy * nz - wz * ny)
        vy = vel[j, 1] - vel[i, 1] - (wz * nx - wx * nz)
        vz = vel[j, 2] - vel[i, 2] - (wx * ny - wy * nx)
        gx, gy, gz = vx, vy, vz
        if split:
            wx = ri * omega_h[i, 0] + rj * omega_h[j, 0]
            wy = ri * omega_h[i, 1] + rj * omega_h[j, 1]
            wz = ri * omega_h[i, 2] + rj * omega_h[j, 2]
            gx = vel_h[j, 0] - vel_h[i, 0] - (wy * nz - wz * ny)
            gy = vel_h[j, 1] - vel_h[i, 1] - (wz * nx - wx * nz)
            gz = vel_h[j, 2] - vel_h[i, 2] - (wx * ny - wy * nx)
        phi = contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p,
                          min(props[i, 2], props[j, 2]), min(props[i, 3], props[j, 3]),
                          min(props[i, 4], props[j, 4]), min(props[i, 5], props[j, 5]),
                          min(props[i, 6], props[j, 6]), min(props[i, 0], props[j, 0]),
                          min(props[i, 1], props[j, 1]), dt, lo, hi, out)
        touching[p] = overlap > 0.0
        if overlap <= 0.0:  # touching only within the window: no rolling contact now
            rhist[p, 0] = 0.0
            rhist[p, 1] = 0.0
            rhist[p, 2] = 0.0
            if phi <= 0.0:
                continue
        else:
            ncontacts += 1
        force[i, 0] += out[0]
        force[i, 1] += out[1]
        force[i, 2] += out[2]
        force[j, 0] -= out[0]
        force[j, 1] -= out[1]
        force[j, 2] -= out[2]
        # torque (r n) x f_t on i, and (r_j (-n)) x (-f_t) on j
        cx = ny * out[5] - nz * out[4]
        cy = nz * out[3] - nx * out[5]
        cz = nx * out[4] - ny * out[3]
        torque[i, 0] += ri * cx
        torque[i, 1] += ri * cy
        torque[i, 2] += ri * cz
        torque[j, 0] += rj * cx
        torque[j, 1] += rj * cy
        torque[j, 2] += rj * cz
        mu_r = min(props[i, 7], props[j, 7])
        if mu_r > 0.0 and overlap > 0.0:
            i_eff = 1.0 / (1.0 / (inertia[i] + mass[i] * ri * ri) + 1.0 / (inertia[j] + mass[j] * rj * rj))
            rolling_law(nx, ny, nz, omega[i, 0] - omega[j, 0], omega[i, 1] - omega[j, 1],
                        omega[i, 2] - omega[j, 2], out[6], ri * rj / (ri + rj), mu_r,
                        min(props[i, 2], props[j, 2]), i_eff, rhist, p, dt, mr)
            for d in range(3):
                torque[i, d] += mr[d]
                torque[j, d] -= mr[d]
        if awake[i] != awake[j]:
            m = i if awake[i] else j
            s = j if awake[i] else i
            sp = math.sqrt(vel[m, 0] ** 2 + vel[m, 1] ** 2 + vel[m, 2] ** 2) + radius[m] * math.sqrt(
                omega[m, 0] ** 2 + omega[m, 1] ** 2 + omega[m, 2] ** 2)
            if sp > wake_speed and not wake[s]:
                wake[s] = True
                wake_ids[n_wake[0]] = s
                n_wake[0] += 1
    return ncontacts


@numba.njit(cache=True, error_model="numpy")
def wall_contact(i, nx, ny, nz, overlap, wvel, hist, rhist, pos, vel, omega, vel_h, omega_h, radius, mass, inertia,
                 props, wprops, dt, lo, hi, force, torque, out, mr):
    """Contact of particle i with a boundary (n from the centre towards the boundary), averaged over the
    force window ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`); returns the window fraction in contact.

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
    phi = contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, i,
                      min(props[i, 2], wprops[2]), min(props[i, 3], wprops[3]), min(props[i, 4], wprops[4]),
                      min(props[i, 5], wprops[5]), min(props[i, 6], wprops[6]), min(props[i, 0], wprops[0]),
                      min(props[i, 1], wprops[1]), dt, lo, hi, out)
    if overlap <= 0.0:
        rhist[i, 0] = 0.0
        rhist[i, 1] = 0.0
        rhist[i, 2] = 0.0
        if phi <= 0.0:
            return phi
    force[i, 0] += out[0]
    force[i, 1] += out[1]
    force[i, 2] += out[2]
    torque[i, 0] += ri * (ny * out[5] - nz * out[4])
    torque[i, 1] += ri * (nz * out[3] - nx * out[5])
    torque[i, 2] += ri * (nx * out[4] - ny * out[3])
    mu_r = min(props[i, 7], wprops[7])
    if mu_r > 0.0 and overlap > 0.0:
        rolling_law(nx, ny, nz, omega[i, 0], omega[i, 1], omega[i, 2], out[6], ri, mu_r,
                    min(props[i, 2], wprops[2]), inertia[i] + mass[i] * ri * ri, rhist, i, dt, mr)
        torque[i, 0] += mr[0]
        torque[i, 1] += mr[1]
        torque[i, 2] += mr[2]
    return phi


@numba.njit(cache=True, error_model="numpy")
def plane_forces(idx, point, normal, wvel, wprops, hist, rhist, pos, vel, omega, radius, mass, inertia, props,
                 dt, force, torque, reaction, lo, hi, vel_h, omega_h):
    """Contacts of particles *idx* with the plane through *point* with unit *normal* (into the domain).

    Adds the force on the plane (minus the sum of particle forces) to *reaction*; returns #contacts
    (overlapping now). Forces are averaged over the force window ``[lo, hi]``
    (:func:`~breachflow.dem.contact_law.contact_law`).
    """
    out = np.empty(7)
    mr = np.empty(3)
    n = 0
    reach_t = max(-lo, hi)
    for k in range(idx.shape[0]):
        i = idx[k]
        dist = ((pos[i, 0] - point[0]) * normal[0] + (pos[i, 1] - point[1]) * normal[1]
                + (pos[i, 2] - point[2]) * normal[2])
        overlap = radius[i] - dist
        if overlap <= 0.0 and overlap + reach_t * abs((vel[i, 0] - wvel[0]) * normal[0] + (vel[i, 1] - wvel[1])
                                                      * normal[1] + (vel[i, 2] - wvel[2]) * normal[2]) <= 0.0:
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
                        omega_h, radius, mass, inertia, props, wprops, dt, lo, hi, force, torque, out, mr) <= 0.0:
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
                       props, dt, force, torque, lo, hi, vel_h, omega_h):
    """Contacts with the terrain ``z = bed(x, y)`` (bilinear through the grid's cell centres).

    The contact point is the foot of the perpendicular from the centre on the local tangent plane,
    refined by three fixed-point iterations (exact on planar patches). Outside the grid: no contact.
    Forces are averaged over the force window ``[lo, hi]`` (:func:`~breachflow.dem.contact_law.contact_law`).
    """
    out = np.empty(7)
    mr = np.empty(3)
    wvel = np.zeros(3)
    reach_t = max(-lo, hi)
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
                     inertia, props, wprops, dt, lo, hi, force, torque, out, mr)
    return n


@numba.njit(cache=True, error_model="numpy")
def wrap_and_check(idx, pos, vel, omega, geom, periodic, box, use_box, active, awake, left_ids):
    """Wrap periodic coordinates; deactivate particles outside *box* (xmin, xmax, ymin, ymax, zmin, zmax).

    Returns (#left, first non-finite particle index or -1).
    """
    nleft = 0
    bad = -1
    for k in range(idx.shape[0]):
        i = idx[k]
        if not (math.isfinite(pos[i, 0]) and math.isfinite(pos[i, 1]) and math.isfinite(pos[i, 2])
                and math.isfinite(vel[i, 0]) and math.isfinite(vel[i, 1]) and math.isfinite(vel[i, 2])):
            if bad < 0:
                bad = i
            continue
        for d in range(2):
            if periodic[d]:
                L = geom[6 + d]
                pos[i, d] -= L * math.floor((pos[i, d] - geom[d]) / L)
        if use_box:
            out = False
            for d in range(3):
                if d < 2 and periodic[d]:
                    continue
                if pos[i, d] < box[2 * d] or pos[i, d] > box[2 * d + 1]:
                    out = True
            if out:
                active[i] = False
                awake[i] = False
                for d in range(3):
                    vel[i, d] = 0.0
                    omega[i, d] = 0.0
                left_ids[nleft] = i
                nleft += 1
    return nleft, bad


@numba.njit(cache=True, error_model="numpy")
def displacement_since(idx, pos, pos_ref, geom, periodic):
    """max ``|x_i - x_ref_i|`` over *idx* with periodic minimum image."""
    m = 0.0
    for k in range(idx.shape[0]):
        i = idx[k]
        dx = min_image(pos[i, 0] - pos_ref[i, 0], geom[6], periodic[0])
        dy = min_image(pos[i, 1] - pos_ref[i, 1], geom[7], periodic[1])
        dz = pos[i, 2] - pos_ref[i, 2]
        d2 = dx * dx + dy * dy + dz * dz
        if d2 > m:
            m = d2
    return math.sqrt(m)


@numba.njit(cache=True, error_model="numpy")
def sleep_update(idx, vel, omega, vel_prev, omega_prev, radius, v_sleep, n_sleep, counter, awake, sleep_ids, allow):
    """Count consecutive slow steps (``|v|`` and ``r |w|`` below v_sleep); after n_sleep of them the particle
    sleeps (velocities zeroed) at the next step where *allow* is True. Returns the number that fell asleep (listed in sleep_ids)."""
    ns = 0
    v2 = v_sleep * v_sleep
    for k in range(idx.shape[0]):
        i = idx[k]
        sv = vel[i, 0] ** 2 + vel[i, 1] ** 2 + vel[i, 2] ** 2
        sw = (omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2) * radius[i] ** 2
        if sv < v2 and sw < v2:
            counter[i] += 1
            if allow and counter[i] >= n_sleep:
                awake[i] = False
                counter[i] = 0
                for d in range(3):
                    vel[i, d] = 0.0
                    omega[i, d] = 0.0
                    vel_prev[i, d] = 0.0
                    omega_prev[i, d] = 0.0
                sleep_ids[ns] = i
                ns += 1
        else:
            counter[i] = 0
    return ns
