"""Contact forces of the DEM (docs/theory.md, *DEM contact*): particle pairs from the neighbour list; planes and terrain in
:mod:`.wall_contacts` (re-exported here).

Neighbour search: :mod:`.neighbours` (cell grid, half stencil, skin check; re-exported here). Contact
laws (docs/theory.md, *DEM contact*): :mod:`.contact_law` (the step-averaged spring–dashpot with rolling resistance, and
LAMMPS' ``gran/hooke/history``), chosen by name in :data:`.contact_law.contact_laws`.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .contact_law import (HOOKE_HISTORY, ROLLING_DAMPING_RATIO, ROLLING_STIFFNESS, STEP_AVERAGED,  # noqa: F401
                          contact_law, averaging_interval, hooke_history, rolling_law)
from .neighbours import (build_grid, displacement_since, find_pairs, min_image,  # noqa: F401  (re-exported)
                         wrap_and_check)
from .wall_contacts import _bilinear, heightfield_forces, plane_candidates, plane_forces  # noqa: F401  (re-exported)


#: unsigned offsets for the flat (3 N) views of the pair loop (mixed signed/unsigned int64 would be float)
U1, U2, U3 = np.uint64(1), np.uint64(2), np.uint64(3)


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def pair_forces_interval(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius, mass, inertia,
                       props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo,
                       hi, law=0):
    """Contact forces of all listed pairs (the loop ``_pair_loop``, arguments and result there).

    When every particle is awake and active and all share one property row (one material, nothing asleep:
    :func:`uniform_awake`, an O(N) scan per call), a copy of the loop compiled for that case runs: the pair's
    properties are loop constants instead of ``min`` of 8 columns of both partners, and there are no sleep,
    activity or wake tests per pair; it gives the general loop's results bit for bit
    (tests/dem/test_pair_fast_path.py). ``fastmath={"contract"}`` only: ``a * b + c`` may be fused into one
    rounding (FMA); no NaN / inf / reassociation assumptions. Both make the pair loop faster
    (``python3 tasks.py bench dem_kernel`` times it); the one-material copy costs compile time on an empty
    cache (``bench dem_kernel --compile``). The one-material
    and the general copies are compiled once per contact law (*law* a constant in each), so that the code of
    one law does not change the speed of the other's loop.
    """
    if uniform_awake(props, awake, active):
        if law == HOOKE_HISTORY:
            return _pair_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius,
                              mass, inertia, props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake,
                              wake_ids, n_wake, lo, hi, HOOKE_HISTORY, True)
        return _pair_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius,
                          mass, inertia, props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake,
                          wake_ids, n_wake, lo, hi, STEP_AVERAGED, True)
    if law == HOOKE_HISTORY:
        return _pair_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius,
                          mass, inertia, props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake,
                          wake_ids, n_wake, lo, hi, HOOKE_HISTORY, False)
    return _pair_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius,
                      mass, inertia, props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake,
                      wake_ids, n_wake, lo, hi, STEP_AVERAGED, False)


@numba.njit(cache=True, error_model="numpy")
def uniform_awake(props, awake, active):
    """True if there are particles, all awake and active, all with bitwise the same property row (so that
    ``min`` of two partners' values is row 0's value, signed zeros included). Branch-free scans, about
    1.3 ns per particle (``python3 tasks.py bench dem_kernel`` prints it)."""
    if props.shape[0] == 0:
        return False
    a = np.ascontiguousarray(awake).view(np.uint8)
    b = np.ascontiguousarray(active).view(np.uint8)
    off = np.uint8(0)
    for i in range(a.size):
        off |= (a[i] & b[i]) ^ np.uint8(1)
    x = np.ascontiguousarray(props).reshape(-1).view(np.int64)
    y = x[props.shape[1]:]
    bits = np.int64(0)
    for k in range(y.size):  # each row against the one before it
        bits |= y[k] ^ x[k]
    return off == 0 and bits == 0


@numba.njit(cache=True, inline="always", error_model="numpy")
def _pair_loop(pa, pb, hist, rhist, touching, pos, vel, omega, vel_h, omega_h, split, radius, mass, inertia,
               props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids, n_wake, lo,
               hi, law, uniform):
    """Contact forces of all listed pairs; pairs of two sleeping particles are skipped (frozen).

    *vel*, *omega*: velocities at the evaluation time (dashpots); *vel_h*, *omega_h*: the ones that moved
    the positions over the last step (shear increments, read only if *split*), see
    :func:`~breachflow.dem.contact_law.contact_law`.

    *rhist* (npairs, 3): rolling moment histories (:func:`~breachflow.dem.contact_law.rolling_law`, if the contact's
    rolling_friction, props column 7, is > 0); *mass*, *inertia* (N,) for the rolling dashpot.

    props (N, 8): adhesion, friction, kn, ks, c_cn, c_cs, c_cf (columns 0..6; one cache line per particle). A sleeping partner of a
    moving particle (contact-point speed > wake_speed) gets wake[j] = True and is listed in
    wake_ids[n_wake[0]...]. Forces are averaged over the force interval ``[lo, hi]`` (s, relative to now;
    :func:`~breachflow.dem.contact_law.contact_law`), so a pair that touches only within it gets its
    share. Returns #contacts (overlapping now). The (N, 3) arrays must be C-contiguous (flat views below).
    """
    mr = np.empty(3)
    # flat views of the (N, 3) arrays, element 3 i + k (U1..U3: unsigned offsets): the row length is a constant
    # instead of a stride loaded for each access (old/new 1.01-1.06 for either law on the 1000-sphere bed,
    # ``python3 tasks.py bench dem_kernel --old <src>``); the same arithmetic, results bit for bit
    posf, velf, omegaf = pos.reshape(-1), vel.reshape(-1), omega.reshape(-1)
    vel_hf, omega_hf, forcef, torquef = vel_h.reshape(-1), omega_h.reshape(-1), force.reshape(-1), torque.reshape(-1)
    ncontacts = 0
    # uniform: the pair's properties are the (common) row 0, bit for bit min(props[i], props[j])
    kn_u, ks_u, ccn_u, ccs_u, ccf_u, al_u, be_u, mur_u = (props[0, 2], props[0, 3], props[0, 4], props[0, 5], props[0, 6],
                                                          props[0, 0], props[0, 1], props[0, 7]) if uniform else (
                                                          0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0
    # the list is sorted by i: i's force and torque are summed in registers and stored when i changes (as
    # LAMMPS' fxtmp); any order gives the same sums up to round-off
    ci = np.uint64(0)
    fix = fiy = fiz = tix = tiy = tiz = 0.0
    for p in range(pa.shape[0]):
        i = np.uint64(pa[p])  # unsigned: no negative-index wraparound test on each access
        j = np.uint64(pb[p])
        if i != ci:
            forcef[U3 * ci] += fix
            forcef[U3 * ci + U1] += fiy
            forcef[U3 * ci + U2] += fiz
            torquef[U3 * ci] += tix
            torquef[U3 * ci + U1] += tiy
            torquef[U3 * ci + U2] += tiz
            fix = fiy = fiz = tix = tiy = tiz = 0.0
            ci = i
        if not uniform and (not (awake[i] or awake[j]) or not (active[i] and active[j])):
            continue
        dx = min_image(posf[U3 * j] - posf[U3 * i], geom[6], periodic[0])
        dy = min_image(posf[U3 * j + U1] - posf[U3 * i + U1], geom[7], periodic[1])
        dz = posf[U3 * j + U2] - posf[U3 * i + U2]
        d2 = dx * dx + dy * dy + dz * dz
        ri = radius[i]
        rj = radius[j]
        rs = ri + rj
        gap2 = d2 - rs * rs
        if gap2 >= 0.0:  # apart now (most listed pairs): in contact within the interval at most
            if law == HOOKE_HISTORY:  # point values: apart (reach_t = 0)
                apart = True
            else:  # reach_t |dv.d| <= (d^2 - rs^2)/2 <= d (d - rs): no contact in the interval either, no sqrt
                vd = reach_t * abs((velf[U3 * i] - velf[U3 * j]) * dx + (velf[U3 * i + U1] - velf[U3 * j + U1]) * dy
                                   + (velf[U3 * i + U2] - velf[U3 * j + U2]) * dz)
                apart = vd <= 0.5 * gap2 or (vd + (rs - math.sqrt(d2)) * math.sqrt(d2) <= 0.0)
            if apart:
                hist[p, 0] = 0.0
                hist[p, 1] = 0.0
                hist[p, 2] = 0.0
                rhist[p, 0] = 0.0
                rhist[p, 1] = 0.0
                rhist[p, 2] = 0.0
                touching[p] = False
                continue
        dist = math.sqrt(d2)
        overlap = rs - dist
        if dist > 1e-12 * rs:
            inv = 1.0 / dist
            nx = dx * inv
            ny = dy * inv
            nz = dz * inv
        else:  # coincident centres: any direction will do, pick +z
            nx, ny, nz = 0.0, 0.0, 1.0
        # velocity of j's contact point relative to i's: v_j - v_i - (ri w_i + rj w_j) x n
        wx = ri * omegaf[U3 * i] + rj * omegaf[U3 * j]
        wy = ri * omegaf[U3 * i + U1] + rj * omegaf[U3 * j + U1]
        wz = ri * omegaf[U3 * i + U2] + rj * omegaf[U3 * j + U2]
        vx = velf[U3 * j] - velf[U3 * i] - (wy * nz - wz * ny)
        vy = velf[U3 * j + U1] - velf[U3 * i + U1] - (wz * nx - wx * nz)
        vz = velf[U3 * j + U2] - velf[U3 * i + U2] - (wx * ny - wy * nx)
        gx, gy, gz = vx, vy, vz
        if split:
            wx = ri * omega_hf[U3 * i] + rj * omega_hf[U3 * j]
            wy = ri * omega_hf[U3 * i + U1] + rj * omega_hf[U3 * j + U1]
            wz = ri * omega_hf[U3 * i + U2] + rj * omega_hf[U3 * j + U2]
            gx = vel_hf[U3 * j] - vel_hf[U3 * i] - (wy * nz - wz * ny)
            gy = vel_hf[U3 * j + U1] - vel_hf[U3 * i + U1] - (wz * nx - wx * nz)
            gz = vel_hf[U3 * j + U2] - vel_hf[U3 * i + U2] - (wx * ny - wy * nx)
        if uniform:
            kn, ks, ccn, ccs, ccf, alpha, beta = kn_u, ks_u, ccn_u, ccs_u, ccf_u, al_u, be_u
        else:
            kn = min(props[i, 2], props[j, 2])
            ks = min(props[i, 3], props[j, 3])
            ccn = min(props[i, 4], props[j, 4])
            ccs = min(props[i, 5], props[j, 5])
            ccf = min(props[i, 6], props[j, 6])
            alpha = min(props[i, 0], props[j, 0])
            beta = min(props[i, 1], props[j, 1])
        if law == HOOKE_HISTORY:
            phi, fx, fy, fz, ftx, fty, ftz, fn = hooke_history(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p,
                                                               kn, ks, ccn, ccs, alpha, beta, dt)
        else:
            phi, fx, fy, fz, ftx, fty, ftz, fn = contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p, kn,
                                                             ks, ccn, ccs, ccf, alpha, beta, dt, lo, hi)
        touching[p] = overlap > 0.0
        if overlap <= 0.0:  # touching only within the interval: no rolling contact now
            rhist[p, 0] = 0.0
            rhist[p, 1] = 0.0
            rhist[p, 2] = 0.0
            if phi <= 0.0:
                continue
        else:
            ncontacts += 1
        fix += fx
        fiy += fy
        fiz += fz
        forcef[U3 * j] -= fx
        forcef[U3 * j + U1] -= fy
        forcef[U3 * j + U2] -= fz
        # torque (r n) x f_t on i, and (r_j (-n)) x (-f_t) on j
        cx = ny * ftz - nz * fty
        cy = nz * ftx - nx * ftz
        cz = nx * fty - ny * ftx
        tix += ri * cx
        tiy += ri * cy
        tiz += ri * cz
        torquef[U3 * j] += rj * cx
        torquef[U3 * j + U1] += rj * cy
        torquef[U3 * j + U2] += rj * cz
        mu_r = mur_u if uniform else min(props[i, 7], props[j, 7])
        if mu_r > 0.0 and overlap > 0.0:
            i_eff = 1.0 / (1.0 / (inertia[i] + mass[i] * ri * ri) + 1.0 / (inertia[j] + mass[j] * rj * rj))
            rolling_law(nx, ny, nz, omegaf[U3 * i] - omegaf[U3 * j], omegaf[U3 * i + U1] - omegaf[U3 * j + U1],
                        omegaf[U3 * i + U2] - omegaf[U3 * j + U2], fn, ri * rj / (ri + rj), mu_r, kn, i_eff, rhist, p,
                        dt, mr)
            torquef[U3 * i] += mr[0]
            torquef[U3 * i + U1] += mr[1]
            torquef[U3 * i + U2] += mr[2]
            torquef[U3 * j] -= mr[0]
            torquef[U3 * j + U1] -= mr[1]
            torquef[U3 * j + U2] -= mr[2]
        if not uniform and awake[i] != awake[j]:
            m = i if awake[i] else j
            s = j if awake[i] else i
            sp = (math.sqrt(velf[U3 * m] ** 2 + velf[U3 * m + U1] ** 2 + velf[U3 * m + U2] ** 2)
                  + radius[m] * math.sqrt(omegaf[U3 * m] ** 2 + omegaf[U3 * m + U1] ** 2 + omegaf[U3 * m + U2] ** 2))
            if sp > wake_speed and not wake[s]:
                wake[s] = True
                wake_ids[n_wake[0]] = s
                n_wake[0] += 1
    if pa.shape[0]:
        forcef[U3 * ci] += fix
        forcef[U3 * ci + U1] += fiy
        forcef[U3 * ci + U2] += fiz
        torquef[U3 * ci] += tix
        torquef[U3 * ci + U1] += tiy
        torquef[U3 * ci + U2] += tiz
    return ncontacts


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
