"""Ghost cells of the shallow-water solver from the boundary conditions (docs/theory.md, *Shallow-water equations*): levels (exact or
absorbing), discharge inlets, free outflow with continued bed and surface slopes, walls."""
from __future__ import annotations

import math

import numpy as np

from .layout import BC_LEVEL, BC_OUTFLOW, BC_WALL, EAST, G, NORTH, SOUTH, WEST, _jit


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
