"""Contact detection and the linear spring–dashpot contact law with friction history (SPEC §5).

Neighbour search: a hashed cell grid. Each particle is inserted in every cell its bounding box
(radius + skin/2) overlaps, so the cell size can follow the *typical* diameter while a 10:1 size
ratio only costs the few large particles more insertions; a pair is reported once, from the cell
at the minimum corner of the intersection of both boxes. Only awake particles search, so the cost
follows the number of moving particles (sleeping ones sit in a separate grid rebuilt on sleep/wake).
Periodic x / y use minimum-image distances and wrapped cell coordinates.

Contact law (SPEC §5), ``n`` from particle i to its partner, overlap ``u_N > 0``:

* normal ``f_N = -k_N u_N n + c_CN (v_rel . n) n`` on i;
* tangential spring on the accumulated displacement ``u_S`` (kept per pair across steps and
  rotated into the current tangent plane with its length kept), ``f_S = k_S u_S``;
  slip limit ``u_S_hat = (alpha + beta k_N u_N) / k_S``; beyond it ``u_S`` is cut back to
  ``u_S_hat`` (plastic slip); dashpot ``c_CS v_S`` while sticking, ``c_CF v_S`` while slipping;
* torque ``(r n) x f_S`` on each partner (lever arm D/2);
* rolling resistance (extension, ``rolling_friction`` mu_r > 0): :func:`rolling_law`.

Properties of a contact are the minimum of the partners' values.
"""
from __future__ import annotations

import math

import numba
import numpy as np

OFFSET = 1 << 20
#: rolling stiffness ``k_r = ROLLING_STIFFNESS * k_N mu_r^2 R_r^2`` (Ai et al. 2011, 3-D value)
ROLLING_STIFFNESS = 2.25
#: rolling dashpot ``C_r = ROLLING_DAMPING_RATIO * 2 sqrt(I_r k_r)`` (Ai et al. 2011 eta_r)
ROLLING_DAMPING_RATIO = 0.3  # cell-coordinate offset for packing three signed ints into one int64


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


@numba.njit(cache=True, inline="always", error_model="numpy")
def contact_window(u, w, lo, hi):
    """Active part of the force window ``[lo, hi]`` (s, relative to the evaluation time) for the overlap
    ``u(tau) = u + w tau``: returns (fraction phi of the window in contact, midpoint m of the active part).

    ``hi <= lo`` (a point evaluation, e.g. :meth:`DemSimulation.refresh_forces`): (1, 0) if u > 0 else (0, 0).
    """
    if hi <= lo:
        return (1.0, 0.0) if u > 0.0 else (0.0, 0.0)
    a = lo
    b = hi
    if w > 0.0:
        a = max(a, -u / w)
    elif w < 0.0:
        b = min(b, -u / w)
    elif u <= 0.0:
        return 0.0, 0.0
    if b <= a:
        return 0.0, 0.0
    return (b - a) / (hi - lo), 0.5 * (a + b)


@numba.njit(cache=True, inline="always", error_model="numpy")
def contact_law(nx, ny, nz, overlap, vx, vy, vz, gx, gy, gz, hist, p, kn, ks, c_cn, c_cs, c_cf, alpha, beta, dt, lo,
                hi, out):
    """Force on particle i from one contact (SPEC §5), averaged over the integrator's force window;
    updates the shear history *hist* in place. Returns the window fraction in contact (0: none).

    (nx, ny, nz): unit normal from i to the partner; (vx, vy, vz): velocity of the partner's contact
    point relative to i's at the evaluation time (dashpots, window); (gx, gy, gz): the same over the last
    step, i.e. with the velocities that moved the positions (the half-step ones of Verlet), which advances
    the shear displacement consistently with the overlap; *overlap* ``u`` at the evaluation time (may be
    <= 0); the pair's history is row *p* of *hist* (``u_S`` at the previous evaluation, ``dt`` earlier). Writes
    (fx, fy, fz, ftx, fty, ftz, compressive normal force) into *out*.

    Window (issue 12): a kick–drift–kick integrator applies the force evaluated at ``t`` over
    ``[t - dt/2, t + dt/2]`` (``lo = -dt/2, hi = dt/2``). The contact law is piecewise — the dashpot
    jumps from 0 to ``c_CN v_N`` at onset and back at release, springs have a kink — so a point value
    makes the impulse depend on where in a step the contact begins (restitution errors up to ~10 % at the
    default step). Here the overlap is taken linear across the window, ``u(tau) = u + w tau`` with the
    closing speed ``w = -v_rel . n``, and the law is averaged over it: with phi the fraction of the
    window in contact and m the midpoint of the in-contact part, ``F = phi [(-k_N u(m) + c_CN v_N) n +
    k_S u_S(m) + c_t v_S]``, ``u_S(m) = u_S(t) + v_S m`` (capped at the Coulomb limit of ``u(m)``; a
    contact sliding now and in contact only before now keeps ``u_S`` at that limit instead).
    When the whole window is in contact (phi = 1, m = 0) this is the usual point value, bit for bit.
    The shear history counts from the touching time: a fresh contact (zero history, approaching) gets
    ``u_S = g_S min(dt, u/g_N)`` instead of ``g_S dt``.
    """
    vn = vx * nx + vy * ny + vz * nz
    w = -vn
    full = overlap > max(-lo, hi) * abs(vn)  # in contact over the whole window (the common case)
    if full:
        phi, m = 1.0, 0.0
    else:
        phi, m = contact_window(overlap, w, lo, hi)
    if phi <= 0.0:
        hist[p, 0] = 0.0
        hist[p, 1] = 0.0
        hist[p, 2] = 0.0
        for k in range(7):
            out[k] = 0.0
        return 0.0
    tx = vx - vn * nx
    ty = vy - vn * ny
    tz = vz - vn * nz
    # rotate the history into the current tangent plane, keeping its length
    h0x = hist[p, 0]
    h0y = hist[p, 1]
    h0z = hist[p, 2]
    h0 = math.sqrt(h0x * h0x + h0y * h0y + h0z * h0z)
    hn = h0x * nx + h0y * ny + h0z * nz
    hx = h0x - hn * nx
    hy = h0y - hn * ny
    hz = h0z - hn * nz
    h1 = math.sqrt(hx * hx + hy * hy + hz * hz)
    if h1 > 0.0:
        sc = h0 / h1
        hx *= sc
        hy *= sc
        hz *= sc
    slipping = False
    gn = gx * nx + gy * ny + gz * nz
    if overlap > 0.0:  # in contact at the evaluation time: advance the stored history
        d = dt
        if h0 == 0.0 and gn < 0.0 and overlap < -gn * dt:  # fresh contact: it began overlap/g_N ago
            d = -overlap / gn
        hx += (gx - gn * nx) * d
        hy += (gy - gn * ny) * d
        hz += (gz - gn * nz) * d
        us = math.sqrt(hx * hx + hy * hy + hz * hz)
        us_hat = (alpha + beta * kn * overlap) / ks
        if us >= us_hat:  # plastic slip: the spring is cut back to the Coulomb limit
            slipping = True
            if us > 0.0:
                sc = us_hat / us
                hx *= sc
                hy *= sc
                hz *= sc
        hist[p, 0] = hx
        hist[p, 1] = hy
        hist[p, 2] = hz
        if full:  # the point value
            c_t = c_cf if slipping else c_cs
            fnm = -kn * overlap + c_cn * vn
            ftx = ks * hx + c_t * tx
            fty = ks * hy + c_t * ty
            ftz = ks * hz + c_t * tz
            out[0] = fnm * nx + ftx
            out[1] = fnm * ny + fty
            out[2] = fnm * nz + ftz
            out[3] = ftx
            out[4] = fty
            out[5] = ftz
            out[6] = -fnm
            return 1.0
        if slipping and m < 0.0 and us_hat > 0.0:  # sliding before now: the spring sat at the Coulomb limit
            sc = (alpha + beta * kn * (overlap + w * m)) / ks / us_hat
            sx = hx * sc
            sy = hy * sc
            sz = hz * sc
        else:  # sticking: the spring's elastic path
            sx = hx + tx * m
            sy = hy + ty * m
            sz = hz + tz * m
    else:  # in contact only during part of the window: not at the evaluation time
        hist[p, 0] = 0.0
        hist[p, 1] = 0.0
        hist[p, 2] = 0.0
        if w > 0.0:  # onset ahead, at a = 2m - hi: u_S(m) = v_S (m - a)
            d = hi - m
            sx = tx * d
            sy = ty * d
            sz = tz * d
        else:  # release behind, the last history dt ago: u_S(m) = u_S(-dt) + g_S (m + dt)
            d = m + dt
            sx = hx + (gx - gn * nx) * d
            sy = hy + (gy - gn * ny) * d
            sz = hz + (gz - gn * nz) * d
    um = overlap + w * m  # overlap at the midpoint of the in-contact part
    if m != 0.0:  # part of the window only: the Coulomb limit of the mid-window overlap
        us = math.sqrt(sx * sx + sy * sy + sz * sz)
        us_hat = (alpha + beta * kn * um) / ks
        if us >= us_hat:
            slipping = True
            if us > 0.0:
                sc = us_hat / us
                sx *= sc
                sy *= sc
                sz *= sc
    c_t = c_cf if slipping else c_cs  # friction dashpot while slipping, shear dashpot while sticking
    fnm = phi * (-kn * um + c_cn * vn)
    ftx = phi * (ks * sx + c_t * tx)
    fty = phi * (ks * sy + c_t * ty)
    ftz = phi * (ks * sz + c_t * tz)
    out[0] = fnm * nx + ftx
    out[1] = fnm * ny + fty
    out[2] = fnm * nz + ftz
    out[3] = ftx
    out[4] = fty
    out[5] = ftz
    out[6] = -fnm  # compressive normal force magnitude (N)
    return phi


@numba.njit(cache=True, inline="always", error_model="numpy")
def rolling_law(nx, ny, nz, wx, wy, wz, fn, r_eff, mu_r, kn, i_eff, rhist, p, dt, out):
    """Rolling resistance moment on particle i: elastic–plastic spring–dashpot ("type C", model EPSD of
    Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269). Updates the moment history ``rhist[p]``.

    (wx, wy, wz) = ``w_i - w_j`` (partner's spin, 0 for a wall); only its tangential part rolls.
    Spring ``M_k <- M_k - k_r w_t dt`` (history rotated into the current tangent plane, length kept),
    ``k_r = 2.25 k_N mu_r^2 R_r^2``; capped at full mobilisation ``|M_k| <= M_m = mu_r R_r F_N``;
    dashpot ``-C_r w_t``, ``C_r = 0.3 * 2 sqrt(I_r k_r)``, only below full mobilisation (Ai's f = 0),
    ``I_r`` the inertia about the contact point (``(1/I_ri + 1/I_rj)^-1``, ``I_ri = I_i + m_i r_i^2``).
    Unlike Ai et al., the total ``|M_k + M_d|`` is also capped at ``M_m``: otherwise the dashpot alone
    exceeds the limit while the spring winds up at a newly formed rolling contact, and a rolling sphere
    loses extra speed each time a contact forms. The partner gets ``-M``. Writes the moment into out[0:3].

    Why type C and not the constant directional torque (type A, ``-mu_r R_r F_N w/|w|``): type A flips
    sign every step around ``w = 0`` and cannot hold a sphere at rest on a slope or under a side load
    (it chatters); the spring gives a true static moment up to ``M_m`` (rest iff the load needs less),
    and while rolling (fully mobilised) it is exactly type A's constant ``M_m`` — so a rolling sphere on
    a plane decelerates at ``a = -(5/7) mu_r g`` and one on an incline accelerates at
    ``(5/7) g (sin t - mu_r cos t)``. Plastic capping only removes spring energy: no energy gain.
    """
    wn = wx * nx + wy * ny + wz * nz
    tx = wx - wn * nx
    ty = wy - wn * ny
    tz = wz - wn * nz
    h0x = rhist[p, 0]
    h0y = rhist[p, 1]
    h0z = rhist[p, 2]
    h0 = math.sqrt(h0x * h0x + h0y * h0y + h0z * h0z)
    hn = h0x * nx + h0y * ny + h0z * nz
    hx = h0x - hn * nx
    hy = h0y - hn * ny
    hz = h0z - hn * nz
    h1 = math.sqrt(hx * hx + hy * hy + hz * hz)
    if h1 > 0.0:
        sc = h0 / h1
        hx *= sc
        hy *= sc
        hz *= sc
    kr = ROLLING_STIFFNESS * kn * mu_r * mu_r * r_eff * r_eff
    hx -= kr * tx * dt
    hy -= kr * ty * dt
    hz -= kr * tz * dt
    m_max = mu_r * r_eff * max(fn, 0.0)
    mk = math.sqrt(hx * hx + hy * hy + hz * hz)
    if mk >= m_max:  # full mobilisation: plastic rolling at the limit moment, no dashpot
        sc = m_max / mk if mk > 0.0 else 0.0
        hx *= sc
        hy *= sc
        hz *= sc
        cr = 0.0
    else:
        cr = ROLLING_DAMPING_RATIO * 2.0 * math.sqrt(i_eff * kr)
    rhist[p, 0] = hx
    rhist[p, 1] = hy
    rhist[p, 2] = hz
    mx = hx - cr * tx
    my = hy - cr * ty
    mz = hz - cr * tz
    mt = math.sqrt(mx * mx + my * my + mz * mz)
    if mt > m_max:  # the dashpot may not lift the moment above the limit (e.g. while the spring winds up)
        sc = m_max / mt
        mx *= sc
        my *= sc
        mz *= sc
    out[0] = mx
    out[1] = my
    out[2] = mz


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
    the positions over the last step (shear increments, read only if *split*), see :func:`contact_law`.

    *rhist* (npairs, 3): rolling moment histories (:func:`rolling_law`, if the contact's
    rolling_friction, props column 7, is > 0); *mass*, *inertia* (N,) for the rolling dashpot.

    props (N, 8): adhesion, friction, kn, ks, c_cn, c_cs, c_cf (columns 0..6; one cache line per particle). A sleeping partner of a
    moving particle (contact-point speed > wake_speed) gets wake[j] = True and is listed in
    wake_ids[n_wake[0]...]. Forces are averaged over the force window ``[lo, hi]`` (s, relative to now;
    :func:`contact_law`), so a pair that touches only within it gets its share. Returns #contacts
    (overlapping now).
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
    force window ``[lo, hi]`` (:func:`contact_law`); returns the window fraction in contact.

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
    (overlapping now). Forces are averaged over the force window ``[lo, hi]`` (:func:`contact_law`).
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
    Forces are averaged over the force window ``[lo, hi]`` (:func:`contact_law`).
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
