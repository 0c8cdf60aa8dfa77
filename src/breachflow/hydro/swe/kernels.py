"""Numba kernels of the finite-volume shallow-water solver (SPEC §4).

Conserved variables ``h, hu, hv`` on a structured grid padded with ``G = 2`` ghost layers
(arrays ``(ny + 4, nx + 4)``, index ``[j, i]``, x along axis 1). Per stage:

1. ghost cells from the boundary conditions (:func:`fill_ghosts`);
2. primitive variables ``u, v, eta = h + z`` (:func:`primitives`);
3. MUSCL reconstruction of ``h, eta, u, v`` with a slope limiter (second order) or piecewise-constant
   values (first order), hydrostatic reconstruction at each face (Audusse et al. 2004,
   ``z* = max(zL, zR)``, ``h*_K = max(0, eta_K - z*)``) and an HLL / HLLC flux (:func:`rhs`);
4. a forward-Euler stage with implicit Manning friction (:func:`stage_update`); two stages combined
   as SSP-RK2 (Heun) give second order in time.

Well-balancing to round-off: the momentum flux is split as ``F = D + p*_L`` with the pressure
``p = g h^2 / 2`` kept apart, so that the face terms and the centred bed-slope source combine into
``-g (h+ + h-)/2 (eta+ - eta-) / dx``, which is exactly zero for a lake at rest.
"""
from __future__ import annotations

import math

import numba
import numpy as np

G = 2  # ghost layers

# boundary kinds (per boundary cell)
BC_OUTFLOW = 0
BC_WALL = 1
BC_LEVEL = 2
BC_DISCHARGE = 3

# sides
WEST, EAST, SOUTH, NORTH = 0, 1, 2, 3

LIMITERS = {"minmod": 0, "mc": 1, "vanleer": 2}
RIEMANN = {"hll": 0, "hllc": 1}

_jit = numba.njit(cache=True, fastmath=False, nogil=True)
_pjit = numba.njit(cache=True, fastmath=False, nogil=True, parallel=True)


@_jit
def _limit(a, b, limiter):
    """Limited slope from the backward and forward differences *a*, *b*."""
    if a * b <= 0.0:
        return 0.0
    if limiter == 0:  # minmod
        return a if abs(a) < abs(b) else b
    if limiter == 1:  # monotonised central
        c = 0.5 * (a + b)
        s = 1.0 if a > 0.0 else -1.0
        return s * min(2.0 * abs(a), 2.0 * abs(b), abs(c))
    return 2.0 * a * b / (a + b)  # van Leer


@_jit
def _interp_series(times, values, side, k, t):
    """Linear interpolation of the boundary value of cell *k* of *side* at time *t* (held at the ends)."""
    nt = times.shape[0]
    if nt == 1 or t <= times[0]:
        return values[side, 0, k]
    if t >= times[nt - 1]:
        return values[side, nt - 1, k]
    lo = 0
    hi = nt - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    w = (t - times[lo]) / (times[hi] - times[lo])
    return (1.0 - w) * values[side, lo, k] + w * values[side, hi, k]


@_jit
def _ghost(h, hu, hv, z, jg, ig, ji, ii, z_out, eta_out, kind, level, q_in, outer_un, nx_out, ny_out, h_dry, g):
    """Set ghost cell (jg, ig) from its mirror interior cell (ji, ii); (nx_out, ny_out) is the outward
    normal; *outer_un* the relaxed outer normal velocity of an absorbing level boundary (NaN: exact level).

    Where water leaves with the state extrapolated from inside (free outflow, supercritical outflow
    through a level boundary) the ghost bed is *z_out* and the ghost surface *eta_out*, both continued
    from inside (:func:`fill_ghosts`); the velocity is the interior one.
    """
    z[jg, ig] = z[ji, ii]
    hi = h[ji, ii]
    if hi > h_dry:
        ui = hu[ji, ii] / hi
        vi = hv[ji, ii] / hi
    else:
        ui = 0.0
        vi = 0.0
    if kind == BC_WALL:
        # walls are handled as no-flow faces (ghost flagged obstacle); the copy only feeds slopes
        h[jg, ig] = hi
        hu[jg, ig] = hu[ji, ii]
        hv[jg, ig] = hv[ji, ii]
    elif kind == BC_OUTFLOW:
        # free outflow: zero gradient, but water never re-enters (inward normal velocity set to zero)
        z[jg, ig] = z_out
        hg = max(eta_out - z_out, 0.0) if hi > h_dry else hi
        h[jg, ig] = hg
        un = ui * nx_out + vi * ny_out
        if un < 0.0:
            ui -= un * nx_out
            vi -= un * ny_out
        hu[jg, ig] = hg * ui
        hv[jg, ig] = hg * vi
    elif kind == BC_LEVEL and hi > h_dry and ui * nx_out + vi * ny_out >= math.sqrt(g * hi):
        # supercritical outflow: the level cannot be imposed, the boundary is free
        z[jg, ig] = z_out
        hg = max(eta_out - z_out, 0.0)
        h[jg, ig] = hg
        hu[jg, ig] = hg * ui
        hv[jg, ig] = hg * vi
    elif kind == BC_LEVEL and outer_un == outer_un and hi > h_dry:
        # absorbing level: the outgoing invariant R+ = u_n + 2c from inside, the incoming one
        # R- = U - 2 c_t from water at the prescribed level moving with U, the interior normal velocity
        # averaged over the relaxation time (outer_un). Waves shorter than that leave the domain; in a
        # steady state U = u_n and the boundary stage is the prescribed level. Inflow at most critical.
        ct = math.sqrt(g * max(level - z[jg, ig], 0.0))
        r_out = ui * nx_out + vi * ny_out + 2.0 * math.sqrt(g * hi)
        r_in = outer_un - 2.0 * ct
        cb = 0.25 * (r_out - r_in)
        un = 0.5 * (r_out + r_in)
        if un < -cb:
            cb = -r_in / 3.0
            un = -cb
        if cb < 0.0:
            cb = 0.0
        hg = cb * cb / g
        ut_i = -ui * ny_out + vi * nx_out
        h[jg, ig] = hg
        hu[jg, ig] = hg * (un * nx_out - ut_i * ny_out)
        hv[jg, ig] = hg * (un * ny_out + ut_i * nx_out)
    elif kind == BC_LEVEL:
        # prescribed level; normal velocity from the outgoing Riemann invariant u_n + 2c of the interior,
        # inflow kept subcritical (|u_n| <= c_b); a dry interior sees a reservoir at rest
        hg = level - z[jg, ig]
        if hg < 0.0:
            hg = 0.0
        un_i = ui * nx_out + vi * ny_out
        ut_i = -ui * ny_out + vi * nx_out
        cb = math.sqrt(g * hg)
        if hi > h_dry:
            un = un_i + 2.0 * (math.sqrt(g * hi) - cb)
            if un < -cb:
                un = -cb
        else:
            un = 0.0
        h[jg, ig] = hg
        hu[jg, ig] = hg * (un * nx_out - ut_i * ny_out)
        hv[jg, ig] = hg * (un * ny_out + ut_i * nx_out)
    else:  # prescribed unit discharge q_in into the domain
        if level == level:  # level given too: supercritical inflow, both imposed
            hg = level - z[jg, ig]
            if hg < 0.0:
                hg = 0.0
        else:
            # subcritical: depth extrapolated from inside (the critical depth fills a dry inlet)
            hg = hi if hi > h_dry else (q_in * q_in / g) ** (1.0 / 3.0)
        h[jg, ig] = hg
        if hg > 0.0:
            # inward normal is -(nx_out, ny_out); tangential velocity zero
            hu[jg, ig] = -q_in * nx_out
            hv[jg, ig] = -q_in * ny_out
        else:
            hu[jg, ig] = 0.0
            hv[jg, ig] = 0.0


def ghost_bed_slopes(z, obst):
    """Bed change per cell outwards, ``(4, nmax)``, at each boundary cell of the padded bed *z*.

    Minmod of the two bed differences next to the boundary (``z_b - z_b1`` and ``z_b1 - z_b2``, b the
    boundary cell, b1 and b2 the next ones inwards), so that a single bump or pit at the edge is not
    continued; zero where one of the three cells is an obstacle or the grid is a single cell across.
    A uniform slope is continued exactly.
    """
    zi = z[G:-G, G:-G]
    blocked = obst[G:-G, G:-G] == 1
    ny, nx = zi.shape
    out = np.zeros((4, max(nx, ny)))
    lines = {WEST: (zi, blocked), EAST: (zi[:, ::-1], blocked[:, ::-1]),
             SOUTH: (zi.T, blocked.T), NORTH: (zi[::-1, :].T, blocked[::-1, :].T)}
    for side, (a, b) in lines.items():  # a[k, m]: cell m inwards from the boundary of boundary cell k
        n = a.shape[0]
        if a.shape[1] < 2:
            continue
        d1 = a[:, 0] - a[:, 1]
        if a.shape[1] >= 3:
            d2 = a[:, 1] - a[:, 2]
            d = np.where(d1 * d2 > 0.0, np.where(np.abs(d1) < np.abs(d2), d1, d2), 0.0)
            bad = b[:, 0] | b[:, 1] | b[:, 2]
        else:
            d = d1
            bad = b[:, 0] | b[:, 1]
        out[side, :n] = np.where(bad, 0.0, d)
    return out


@_jit
def fill_ghosts(h, hu, hv, z, bed_dz, kinds, times, levels, discharges, outer_un, t, h_dry, g):
    """Fill the two ghost layers on the four sides from the boundary specification at time *t*;
    ``outer_un (4, nmax)`` holds the relaxed outer velocities of absorbing level cells (NaN elsewhere);
    ``bed_dz (4, nmax)`` the bed change per cell outwards at each boundary cell (:func:`ghost_bed_slopes`).
    The continued bed and surface of outflows are those of :func:`_outflow_ghost`."""
    ny = h.shape[0] - 2 * G
    nx = h.shape[1] - 2 * G
    for k in range(ny):
        j = G + k
        for layer in range(G):
            zo, eo = _outflow_ghost(h, z, j, G, 0, 1, nx, bed_dz[WEST, k], layer, h_dry)
            _ghost(h, hu, hv, z, j, G - 1 - layer, j, G + layer, zo, eo, kinds[WEST, k],
                   _interp_series(times, levels, WEST, k, t), _interp_series(times, discharges, WEST, k, t),
                   outer_un[WEST, k], -1.0, 0.0, h_dry, g)
            zo, eo = _outflow_ghost(h, z, j, G + nx - 1, 0, -1, nx, bed_dz[EAST, k], layer, h_dry)
            _ghost(h, hu, hv, z, j, G + nx + layer, j, G + nx - 1 - layer, zo, eo, kinds[EAST, k],
                   _interp_series(times, levels, EAST, k, t), _interp_series(times, discharges, EAST, k, t),
                   outer_un[EAST, k], 1.0, 0.0, h_dry, g)
    for k in range(nx):
        i = G + k
        for layer in range(G):
            zo, eo = _outflow_ghost(h, z, G, i, 1, 0, ny, bed_dz[SOUTH, k], layer, h_dry)
            _ghost(h, hu, hv, z, G - 1 - layer, i, G + layer, i, zo, eo, kinds[SOUTH, k],
                   _interp_series(times, levels, SOUTH, k, t), _interp_series(times, discharges, SOUTH, k, t),
                   outer_un[SOUTH, k], 0.0, -1.0, h_dry, g)
            zo, eo = _outflow_ghost(h, z, G + ny - 1, i, -1, 0, ny, bed_dz[NORTH, k], layer, h_dry)
            _ghost(h, hu, hv, z, G + ny + layer, i, G + ny - 1 - layer, i, zo, eo, kinds[NORTH, k],
                   _interp_series(times, levels, NORTH, k, t), _interp_series(times, discharges, NORTH, k, t),
                   outer_un[NORTH, k], 0.0, 1.0, h_dry, g)


@_jit
def _outflow_ghost(h, z, jb, ib, dj, di, n, dz, layer, h_dry):
    """Bed and water surface ``(z_g, eta_g)`` of ghost layer *layer* (0: next to the boundary cell
    (jb, ib); (dj, di) the step inwards, *n* cells across) of a boundary that water leaves.

    The bed continues the boundary cell's bed slope *dz* (change per cell outwards) where it falls
    outwards (``z_g = z_b + l dz``, l = 1, 2 cells out), else it is mirrored. The surface continues the
    interior surface slope ``s`` (minmod of the two differences next to the boundary, wet cells only),
    clipped to ``[dz, 0]``: ``eta_g = eta_b + l s``. A uniform flow (``s = dz``) then sees its own
    depth in the ghost cells and stays at normal depth. On a flat or outward-rising bed, or with a flat
    surface (a lake at rest; ``|s| <= 1e-12 (1 + |eta_b|)``), the ghost is the mirror cell (zero
    gradient of depth, as before). A mirrored, flat ghost bed with the interior depth would force the
    surface flat at a sloping outlet and take the gravity term from the boundary cell: the outlet
    ponds (issue 12).
    """
    jm = jb + layer * dj
    im = ib + layer * di
    zb = z[jb, ib]
    eb = h[jb, ib] + zb
    s = 0.0
    if n >= 2 and h[jb, ib] > h_dry and h[jb + dj, ib + di] > h_dry:
        s = eb - (h[jb + dj, ib + di] + z[jb + dj, ib + di])
        if n >= 3:
            if h[jb + 2 * dj, ib + 2 * di] > h_dry:
                s2 = (h[jb + dj, ib + di] + z[jb + dj, ib + di]) - (h[jb + 2 * dj, ib + 2 * di] + z[jb + 2 * dj, ib + 2 * di])
                if s * s2 <= 0.0:
                    s = 0.0
                elif abs(s2) < abs(s):
                    s = s2
            else:
                s = 0.0
    if s < dz:
        s = dz
    if not (dz < 0.0 and s < -1e-12 * (1.0 + abs(eb))):
        # flat or rising bed, or a flat surface (round-off differences count as flat): the mirrored
        # bed and the mirror cell's depth, which keeps a lake at rest at rest to round-off
        return z[jm, im], h[jm, im] + z[jm, im]
    return zb + (layer + 1) * dz, eb + (layer + 1) * s


@_jit
def relax_outer_velocity(h, hu, hv, outer_un, relaxation, dt, h_dry):
    """``U += min(dt / T, 1) (u_n - U)`` at every absorbing level cell: the outer water follows the
    interior's mean normal velocity with relaxation time T (s), so the mean level stays prescribed."""
    ny = h.shape[0] - 2 * G
    nx = h.shape[1] - 2 * G
    for side in range(4):
        n = ny if side < 2 else nx
        for k in range(n):
            if not (outer_un[side, k] == outer_un[side, k]):
                continue
            if side == WEST:
                j, i, sgn, normal_x = G + k, G, -1.0, True
            elif side == EAST:
                j, i, sgn, normal_x = G + k, G + nx - 1, 1.0, True
            elif side == SOUTH:
                j, i, sgn, normal_x = G, G + k, -1.0, False
            else:
                j, i, sgn, normal_x = G + ny - 1, G + k, 1.0, False
            un = 0.0
            if h[j, i] > h_dry:
                un = sgn * (hu[j, i] if normal_x else hv[j, i]) / h[j, i]
            w = dt / relaxation[side, k]
            if w > 1.0:
                w = 1.0
            outer_un[side, k] += w * (un - outer_un[side, k])


@_pjit
def primitives(h, hu, hv, z, obst, u, v, eta, h_dry):
    """Velocities (zero below the dry threshold) and water surface on all cells."""
    for j in numba.prange(h.shape[0]):
        for i in range(h.shape[1]):
            hh = h[j, i]
            if hh > h_dry and obst[j, i] != 1:
                u[j, i] = hu[j, i] / hh
                v[j, i] = hv[j, i] / hh
            else:
                u[j, i] = 0.0
                v[j, i] = 0.0
            eta[j, i] = hh + z[j, i]


@_pjit
def max_wave_rate(h, u, v, obst, dx, dy, g):
    """max over open cells (ghosts included) of (|u| + c)/dx + (|v| + c)/dy, c = sqrt(g h)."""
    rows = np.zeros(h.shape[0])
    for j in numba.prange(h.shape[0]):
        rate = 0.0
        for i in range(h.shape[1]):
            if obst[j, i] == 1:
                continue
            hh = h[j, i]
            if hh <= 0.0:
                continue
            c = math.sqrt(g * hh)
            r = (abs(u[j, i]) + c) / dx + (abs(v[j, i]) + c) / dy
            if r > rate:
                rate = r
        rows[j] = rate
    return rows.max()


@_jit
def _face_flux(hl, etal, unl, utl, hr, etar, unr, utr, g, riemann, upwind):
    """Hydrostatic reconstruction + HLL(C) flux across a face, normal frame.

    ``upwind`` -1 / +1 forces the flux of the left / right state (prescribed-discharge inlets), 0 = HLL(C).
    Returns ``(F_h, D, F_t, J)``: mass flux, the normal-momentum flux without the left pressure
    (``F_n = D + g h*_L^2 / 2``), the tangential-momentum flux and ``J = (g/2)(h*_L^2 - h*_R^2)``.
    The left cell receives ``-D - g hl^2/2`` per unit length, the right cell ``D + J + g hr^2/2``.
    """
    zl = etal - hl
    zr = etar - hr
    zs = zl if zl > zr else zr
    hsl = etal - zs
    if hsl < 0.0:
        hsl = 0.0
    hsr = etar - zs
    if hsr < 0.0:
        hsr = 0.0
    if hsl <= 0.0 and hsr <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    pl = 0.5 * g * hsl * hsl
    pr = 0.5 * g * hsr * hsr
    rl = math.sqrt(hsl)
    rr = math.sqrt(hsr)
    sg = math.sqrt(g)
    cl = sg * rl
    cr = sg * rr
    if hsl <= 0.0:
        sl = unr - 2.0 * cr
        sr = unr + cr
    elif hsr <= 0.0:
        sl = unl - cl
        sr = unl + 2.0 * cl
    else:  # Einfeldt bounds
        uhat = (rl * unl + rr * unr) / (rl + rr)
        chat = math.sqrt(0.5 * g * (hsl + hsr))
        sl = min(unl - cl, uhat - chat)
        sr = max(unr + cr, uhat + chat)
    ql = hsl * unl
    qr = hsr * unr
    al = ql * unl
    ar = qr * unr
    if upwind == -1 or (upwind == 0 and sl >= 0.0):
        fh = ql
        d = al
        ft = ql * utl
    elif upwind == 1 or sr <= 0.0:
        fh = qr
        d = ar + pr - pl
        ft = qr * utr
    else:
        inv = 1.0 / (sr - sl)
        fh = (sr * ql - sl * qr + sl * sr * (hsr - hsl)) * inv
        d = (sr * al - sl * ar + sl * sr * (qr - ql)) * inv + sl * (pl - pr) * inv
        if riemann == 1:  # HLLC: transverse momentum upwinded with the contact wave
            den = hsr * (unr - sr) - hsl * (unl - sl)
            if den != 0.0:
                sstar = (sl * hsr * (unr - sr) - sr * hsl * (unl - sl)) / den
            else:
                sstar = 0.0
            ft = fh * (utl if sstar >= 0.0 else utr)
        else:
            ft = (sr * ql * utl - sl * qr * utr + sl * sr * (hsr * utr - hsl * utl)) * inv
    return fh, d, ft, pl - pr


@_pjit
def _x_sweep(h, u, v, eta, obst, idx, g, second_order, limiter, riemann, dh, dhu, dhv):
    """x faces between (j, i) and (j, i+1): sets dh, dhu, dhv of every interior cell (rows in parallel)."""
    nyp, nxp = h.shape
    ny = nyp - 2 * G
    nx = nxp - 2 * G
    for j in numba.prange(G, G + ny):
        for i in range(G, G + nx):
            dh[j, i] = 0.0
            dhu[j, i] = 0.0
            dhv[j, i] = 0.0
        # slopes of the left cell carried from the previous face
        shl = 0.0
        sel = 0.0
        sul = 0.0
        svl = 0.0
        for i in range(G - 1, G + nx):
            ir = i + 1
            blocked_l = obst[j, i] == 1
            blocked_r = obst[j, ir] == 1
            # slopes of the right cell
            shr = 0.0
            ser = 0.0
            sur = 0.0
            svr = 0.0
            if second_order and obst[j, ir] == 0 and ir + 1 < nxp and obst[j, ir - 1] == 0 and obst[j, ir + 1] == 0:
                shr = _limit(h[j, ir] - h[j, ir - 1], h[j, ir + 1] - h[j, ir], limiter)
                ser = _limit(eta[j, ir] - eta[j, ir - 1], eta[j, ir + 1] - eta[j, ir], limiter)
                sur = _limit(u[j, ir] - u[j, ir - 1], u[j, ir + 1] - u[j, ir], limiter)
                svr = _limit(v[j, ir] - v[j, ir - 1], v[j, ir + 1] - v[j, ir], limiter)
            if i == G - 1 and second_order and obst[j, i] == 0 and obst[j, i - 1] == 0 and obst[j, i + 1] == 0:
                shl = _limit(h[j, i] - h[j, i - 1], h[j, i + 1] - h[j, i], limiter)
                sel = _limit(eta[j, i] - eta[j, i - 1], eta[j, i + 1] - eta[j, i], limiter)
                sul = _limit(u[j, i] - u[j, i - 1], u[j, i + 1] - u[j, i], limiter)
                svl = _limit(v[j, i] - v[j, i - 1], v[j, i + 1] - v[j, i], limiter)
            up = -1 if obst[j, i] == 2 else (1 if obst[j, ir] == 2 else 0)
            if not (blocked_l and blocked_r):
                if blocked_r:  # wall: mirror of the left state
                    hl = h[j, i] + 0.5 * shl
                    el = eta[j, i] + 0.5 * sel
                    ul = u[j, i] + 0.5 * sul
                    vl = v[j, i] + 0.5 * svl
                    fh, d, ft, jj = _face_flux(hl, el, ul, vl, hl, el, -ul, vl, g, riemann, up)
                    fh = 0.0
                    ft = 0.0
                    hr = hl
                elif blocked_l:
                    hr = h[j, ir] - 0.5 * shr
                    er = eta[j, ir] - 0.5 * ser
                    ur = u[j, ir] - 0.5 * sur
                    vr = v[j, ir] - 0.5 * svr
                    fh, d, ft, jj = _face_flux(hr, er, -ur, vr, hr, er, ur, vr, g, riemann, up)
                    fh = 0.0
                    ft = 0.0
                    hl = hr
                else:
                    hl = h[j, i] + 0.5 * shl
                    el = eta[j, i] + 0.5 * sel
                    ul = u[j, i] + 0.5 * sul
                    vl = v[j, i] + 0.5 * svl
                    hr = h[j, ir] - 0.5 * shr
                    er = eta[j, ir] - 0.5 * ser
                    ur = u[j, ir] - 0.5 * sur
                    vr = v[j, ir] - 0.5 * svr
                    fh, d, ft, jj = _face_flux(hl, el, ul, vl, hr, er, ur, vr, g, riemann, up)
                if i >= G and not blocked_l:
                    dh[j, i] -= fh * idx
                    dhu[j, i] -= d * idx
                    dhv[j, i] -= ft * idx
                if ir < G + nx and not blocked_r:
                    dh[j, ir] += fh * idx
                    dhu[j, ir] += (d + jj) * idx
                    dhv[j, ir] += ft * idx
                    # centred bed-slope source combined with the face pressures (see module doc)
                    dhu[j, ir] -= g * h[j, ir] * ser * idx
            shl = shr
            sel = ser
            sul = sur
            svl = svr


@_pjit
def _y_faces(h, u, v, eta, obst, g, second_order, limiter, riemann, fy):
    """y faces between (j, i) and (j+1, i) into fy[0..3] = (F_h, D, F_t, J); fy[4] = limited slope of eta
    in y of the upper cell (rows of faces in parallel; each row writes only its own entries)."""
    nyp, nxp = h.shape
    ny = nyp - 2 * G
    nx = nxp - 2 * G
    for j in numba.prange(G - 1, G + ny):
        jr = j + 1
        for i in range(G, G + nx):
            blocked_l = obst[j, i] == 1
            blocked_r = obst[jr, i] == 1
            fy[4, jr, i] = 0.0
            if blocked_l and blocked_r:
                fy[0, j, i] = 0.0
                fy[1, j, i] = 0.0
                fy[2, j, i] = 0.0
                fy[3, j, i] = 0.0
                continue
            up = -1 if obst[j, i] == 2 else (1 if obst[jr, i] == 2 else 0)
            shl = 0.0
            sel = 0.0
            sul = 0.0
            svl = 0.0
            shr = 0.0
            ser = 0.0
            sur = 0.0
            svr = 0.0
            if second_order:
                if obst[j, i] == 0 and obst[j - 1, i] == 0 and obst[j + 1, i] == 0:
                    shl = _limit(h[j, i] - h[j - 1, i], h[j + 1, i] - h[j, i], limiter)
                    sel = _limit(eta[j, i] - eta[j - 1, i], eta[j + 1, i] - eta[j, i], limiter)
                    sul = _limit(u[j, i] - u[j - 1, i], u[j + 1, i] - u[j, i], limiter)
                    svl = _limit(v[j, i] - v[j - 1, i], v[j + 1, i] - v[j, i], limiter)
                if obst[jr, i] == 0 and jr + 1 < nyp and obst[jr - 1, i] == 0 and obst[jr + 1, i] == 0:
                    shr = _limit(h[jr, i] - h[jr - 1, i], h[jr + 1, i] - h[jr, i], limiter)
                    ser = _limit(eta[jr, i] - eta[jr - 1, i], eta[jr + 1, i] - eta[jr, i], limiter)
                    sur = _limit(u[jr, i] - u[jr - 1, i], u[jr + 1, i] - u[jr, i], limiter)
                    svr = _limit(v[jr, i] - v[jr - 1, i], v[jr + 1, i] - v[jr, i], limiter)
            fy[4, jr, i] = ser
            if blocked_r:
                hl = h[j, i] + 0.5 * shl
                el = eta[j, i] + 0.5 * sel
                vl = v[j, i] + 0.5 * svl
                ul = u[j, i] + 0.5 * sul
                fh, d, ft, jj = _face_flux(hl, el, vl, ul, hl, el, -vl, ul, g, riemann, up)
                fh = 0.0
                ft = 0.0
            elif blocked_l:
                hr = h[jr, i] - 0.5 * shr
                er = eta[jr, i] - 0.5 * ser
                vr = v[jr, i] - 0.5 * svr
                ur = u[jr, i] - 0.5 * sur
                fh, d, ft, jj = _face_flux(hr, er, -vr, ur, hr, er, vr, ur, g, riemann, up)
                fh = 0.0
                ft = 0.0
            else:
                hl = h[j, i] + 0.5 * shl
                el = eta[j, i] + 0.5 * sel
                vl = v[j, i] + 0.5 * svl
                ul = u[j, i] + 0.5 * sul
                hr = h[jr, i] - 0.5 * shr
                er = eta[jr, i] - 0.5 * ser
                vr = v[jr, i] - 0.5 * svr
                ur = u[jr, i] - 0.5 * sur
                fh, d, ft, jj = _face_flux(hl, el, vl, ul, hr, er, vr, ur, g, riemann, up)
            fy[0, j, i] = fh
            fy[1, j, i] = d
            fy[2, j, i] = ft
            fy[3, j, i] = jj


@_pjit
def _y_accumulate(h, obst, idy, g, fy, dh, dhu, dhv):
    """Add the y-face fluxes and the centred y bed-slope source to every open interior cell."""
    nyp, nxp = h.shape
    ny = nyp - 2 * G
    nx = nxp - 2 * G
    for j in numba.prange(G, G + ny):
        for i in range(G, G + nx):
            if obst[j, i] == 1:
                continue
            dh[j, i] += (fy[0, j - 1, i] - fy[0, j, i]) * idy
            dhv[j, i] += (fy[1, j - 1, i] + fy[3, j - 1, i] - fy[1, j, i]) * idy - g * h[j, i] * fy[4, j, i] * idy
            dhu[j, i] += (fy[2, j - 1, i] - fy[2, j, i]) * idy


@_jit
def rhs(h, u, v, eta, obst, dx, dy, g, second_order, limiter, riemann, dh, dhu, dhv, fy):
    """Flux divergence and bed-slope source of every interior cell into dh, dhu, dhv (per unit area)."""
    _x_sweep(h, u, v, eta, obst, 1.0 / dx, g, second_order, limiter, riemann, dh, dhu, dhv)
    _y_faces(h, u, v, eta, obst, g, second_order, limiter, riemann, fy)
    _y_accumulate(h, obst, 1.0 / dy, g, fy, dh, dhu, dhv)


@_pjit
def stage_update(h0, hu0, hv0, h, hu, hv, dh, dhu, dhv, obst, manning, dt, g, h_dry, w0, hout, huout, hvout):
    """``out = w0 * U0 + (1 - w0) * (U + dt L(U))`` with implicit Manning friction on the Euler part.

    Friction solves ``q' + dt g n^2 |q'| q' / h'^(7/3) = q + dt L_q`` for ``q'`` in closed form
    (``|q'| = 2|q*| / (1 + sqrt(1 + 4 a |q*|))``, ``a = dt g n^2 / h'^(7/3)``): it only shrinks the
    discharge, never reverses it, and stays bounded as ``h' -> 0``. Returns the depth clipped away
    (sum of negative depths, m) as a positivity diagnostic.
    """
    ny = h.shape[0] - 2 * G
    nx = h.shape[1] - 2 * G
    clipped = 0.0
    w1 = 1.0 - w0
    for j in numba.prange(G, G + ny):
        for i in range(G, G + nx):
            if obst[j, i] != 0:
                hout[j, i] = 0.0
                huout[j, i] = 0.0
                hvout[j, i] = 0.0
                continue
            hn = h[j, i] + dt * dh[j, i]
            qx = hu[j, i] + dt * dhu[j, i]
            qy = hv[j, i] + dt * dhv[j, i]
            if hn <= h_dry:
                if hn < 0.0:
                    clipped -= hn
                    hn = 0.0
                qx = 0.0
                qy = 0.0
            else:
                n = manning[j, i]
                if n > 0.0:
                    qm = math.sqrt(qx * qx + qy * qy)
                    if qm > 0.0:
                        a = dt * g * n * n / (hn * hn * hn ** (1.0 / 3.0))
                        f = 2.0 / (1.0 + math.sqrt(1.0 + 4.0 * a * qm))
                        qx *= f
                        qy *= f
            if w0 == 0.0:
                hout[j, i] = hn
                huout[j, i] = qx
                hvout[j, i] = qy
            else:
                hout[j, i] = w0 * h0[j, i] + w1 * hn
                huout[j, i] = w0 * hu0[j, i] + w1 * qx
                hvout[j, i] = w0 * hv0[j, i] + w1 * qy
    return clipped


@_jit
def advance(h, hu, hv, z, obst, manning, bed_dz, kinds, times, levels, discharges, outer_un, relaxation,
            dx, dy, g, second_order, limiter, riemann, courant, h_dry,
            t, t_stop, max_steps, dt_min,
            h1, hu1, hv1, u, v, eta, dh, dhu, dhv, fy, stats):
    """March from *t* to *t_stop* (or *max_steps*) with adaptive CFL steps.

    Returns ``(t, steps, status)``; status 0 = reached t_stop, 1 = step limit, 2 = non-finite state or
    a time step below *dt_min* (runaway). ``stats[0] += clipped depth``, ``stats[1] = min dt``,
    ``stats[2] = max dt``.
    """
    steps = 0
    while t < t_stop and steps < max_steps:
        fill_ghosts(h, hu, hv, z, bed_dz, kinds, times, levels, discharges, outer_un, t, h_dry, g)
        primitives(h, hu, hv, z, obst, u, v, eta, h_dry)
        rate = max_wave_rate(h, u, v, obst, dx, dy, g)
        if not (rate == rate) or rate == math.inf:
            return t, steps, 2
        if rate > 0.0:
            dt = courant / rate
        else:
            dt = t_stop - t
        if t + dt > t_stop:
            dt = t_stop - t
        elif t + 1.5 * dt > t_stop:  # avoid a tiny last step
            dt = 0.5 * (t_stop - t)
        if dt < dt_min and t + dt < t_stop:
            return t, steps, 2
        rhs(h, u, v, eta, obst, dx, dy, g, second_order, limiter, riemann, dh, dhu, dhv, fy)
        if second_order:
            stats[0] += stage_update(h, hu, hv, h, hu, hv, dh, dhu, dhv, obst, manning, dt, g, h_dry, 0.0,
                                     h1, hu1, hv1)
            fill_ghosts(h1, hu1, hv1, z, bed_dz, kinds, times, levels, discharges, outer_un, t + dt, h_dry, g)
            primitives(h1, hu1, hv1, z, obst, u, v, eta, h_dry)
            rhs(h1, u, v, eta, obst, dx, dy, g, second_order, limiter, riemann, dh, dhu, dhv, fy)
            stats[0] += stage_update(h, hu, hv, h1, hu1, hv1, dh, dhu, dhv, obst, manning, dt, g, h_dry, 0.5,
                                     h, hu, hv)
        else:
            stats[0] += stage_update(h, hu, hv, h, hu, hv, dh, dhu, dhv, obst, manning, dt, g, h_dry, 0.0,
                                     h, hu, hv)
        relax_outer_velocity(h, hu, hv, outer_un, relaxation, dt, h_dry)
        t += dt
        steps += 1
        if dt < stats[1]:
            stats[1] = dt
        if dt > stats[2]:
            stats[2] = dt
        # cheap finiteness probe on a few cells each step; the full check is done by the caller
        if not (h[G, G] == h[G, G]):
            return t, steps, 2
    return t, steps, 0 if t >= t_stop else 1
