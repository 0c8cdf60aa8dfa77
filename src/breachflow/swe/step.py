"""One forward-Euler stage of the shallow-water solver over the whole grid (docs/theory.md, *Shallow-water equations*), fused by rows.

Per stage: primitive variables and the wave-speed bound in one pass (:func:`primitives`), the column
range of each row whose update can be non-zero (:func:`activity`), then :func:`stage`: per block of
rows (one block per numba thread) the x faces of a row, the y faces above it (the faces below carried
from the previous row, the y slopes of the next row computed once), the flux divergence with the
centred bed-slope source and the update with implicit Manning friction — no face or residual arrays
over the grid. Two stages combined as SSP-RK2 (Heun) give second order in time.

Quiet cells cost no flux work: a cell whose cross stencil (two cells each way in x and y; obstacle
cells excepted) holds water at rest — ``hu = hv = 0`` — with one bitwise-equal surface ``eta``, or is
entirely dry (``h = 0``), has exactly zero face fluxes and bed-slope source (hydrostatic reconstruction
gives equal face depths on both sides, every limited slope is zero), so its update is the identity
and is applied without computing them; a face between a working cell and a skipped open cell is zero,
one between a working cell and an obstacle is a wall face and is computed. Results are identical to
the full computation (``tests/swe/test_porous_quiet.py``: levee obstacles next to the breach flow).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .fluxes import x_row, y_face_row, y_slopes_row
from .layout import G, _jit, _pjit


@_pjit
def primitives(h, hu, hv, z, obst, u, v, eta, h_dry, dx, dy, g, want_rate, rows):
    """Velocities (zero below the dry threshold), water surface on all cells and, with *want_rate*,
    ``rows[j]`` = max over the open cells of row j (ghosts included) of ``(|u| + c)/dx + (|v| + c)/dy``,
    ``c = sqrt(g h)`` (the CFL rate)."""
    for j in numba.prange(h.shape[0]):
        rate = 0.0
        for i in range(h.shape[1]):
            hh = h[j, i]
            blocked = obst[j, i] == 1
            uu = 0.0
            vv = 0.0
            if hh > h_dry and not blocked:
                uu = hu[j, i] / hh
                vv = hv[j, i] / hh
            u[j, i] = uu
            v[j, i] = vv
            eta[j, i] = hh + z[j, i]
            if want_rate and not blocked and hh > 0.0:
                c = math.sqrt(g * hh)
                r = (abs(uu) + c) / dx + (abs(vv) + c) / dy
                if r > rate:
                    rate = r
        if want_rate:
            rows[j] = rate


@_pjit
def activity(h, hu, hv, eta, obst, lo, hi, clo, chi, full, skip_quiet, tol, g):
    """``lo[j]..hi[j]``: the columns of interior row j between its first and last non-quiet cell (empty,
    ``lo > hi``, if all are quiet). Without *skip_quiet* every interior cell.

    Cell c is quiet if it is an obstacle, or if every open cell k of its cross stencil (c and two cells
    each way in x and y; obstacle cells take no part, a discharge inlet makes c active) has
    ``|hu_k|, |hv_k| <= tol h_c sqrt(g h_c)`` and either ``|eta_k - eta_c| <= tol h_c`` for all k (water
    at rest with one level) or ``h_k = 0`` for all k (dry land). With ``tol = 0`` the fluxes and the
    bed-slope source of a quiet cell are exactly zero, so skipping them changes nothing; with
    ``tol > 0`` each skipped update is below about ``tol h`` (a relative change of round-off size for
    ``tol`` ~ 1e-14), which stops the numerical precursor of a wave — non-zero but exponentially small
    far ahead of it — from keeping the whole grid busy. (Array loads are written out here: a helper
    taking the arrays would count their references at every cell.)

    Only candidates are examined (all cells if *full*): ``clo[j]..chi[j]`` are the columns of row j that
    may have changed since the last check (every other cell was quiet then and kept its state), so a
    cell can only have changed status if it lies within two cells (x) of the changed columns of rows
    j-2..j+2, or within two cells of the boundary (ghost cells are refilled every stage).
    """
    ny = h.shape[0] - 2 * G
    nx = h.shape[1] - 2 * G
    for j in numba.prange(G, G + ny):
        a = G + nx
        b = G - 1
        # candidate columns: the boundary bands [G, G+1], [G+nx-2, G+nx-1] and [c0, c1]
        c0 = G
        c1 = G + nx - 1
        if not full and j >= G + 2 and j < G + ny - 2:
            c0 = min(clo[j - 2], clo[j - 1], clo[j], clo[j + 1], clo[j + 2]) - 2
            c1 = max(chi[j - 2], chi[j - 1], chi[j], chi[j + 1], chi[j + 2]) + 2
            c0 = max(c0, G + 2)
            c1 = min(c1, G + nx - 3)
        if not skip_quiet:
            a = G
            b = G + nx - 1
        else:
            mid = max(c1 - c0 + 1, 0)
            for sweep in range(2):  # from the west for lo, from the east for hi
                if sweep == 1 and a > G + nx - 1:
                    break  # all quiet
                for k in range(4 + mid):
                    if sweep == 0:
                        if k < 2:
                            i = G + k
                        elif k < 2 + mid:
                            i = c0 + k - 2
                        else:
                            i = G + nx - 2 + (k - 2 - mid)
                    else:
                        if k < 2:
                            i = G + nx - 1 - k
                        elif k < 2 + mid:
                            i = c1 - (k - 2)
                        else:
                            i = G + 1 - (k - 2 - mid)
                        if i < a:
                            break
                    if i < G or i > G + nx - 1:
                        continue
                    o = obst[j, i]
                    hc = h[j, i]
                    tq = tol * hc * math.sqrt(g * hc)
                    te = tol * hc
                    e = eta[j, i]
                    quiet = o == 1 or (o == 0 and abs(hu[j, i]) <= tq and abs(hv[j, i]) <= tq)
                    if o == 0 and quiet:
                        level = True
                        dry = hc == 0.0
                        for m in range(8):
                            dist = 1 + (m & 1)
                            d = m >> 1  # direction: -x, +x, -y, +y
                            jj = j + (dist if d == 3 else (-dist if d == 2 else 0))
                            ii = i + (dist if d == 1 else (-dist if d == 0 else 0))
                            oo = obst[jj, ii]
                            if oo == 1:
                                continue
                            if oo != 0 or not (abs(hu[jj, ii]) <= tq and abs(hv[jj, ii]) <= tq):
                                quiet = False
                                break
                            if not abs(eta[jj, ii] - e) <= te:
                                level = False
                            if h[jj, ii] != 0.0:
                                dry = False
                            if not (level or dry):
                                quiet = False
                                break
                    if not quiet:
                        if sweep == 0:
                            a = i
                        else:
                            b = i
                        break
        lo[j] = a
        hi[j] = b


@_jit
def _hull(lo, hi, j0, j1):
    """Smallest column range holding the ranges of rows j0..j1 (empty ranges count for nothing)."""
    a = lo[j0]
    b = hi[j0]
    for j in range(j0 + 1, j1 + 1):
        a = min(a, lo[j])
        b = max(b, hi[j])
    return a, b


@_jit
def _update(h0, hu0, hv0, h, hu, hv, dh, dhu, dhv, n, dt, g, h_dry, w0, w1):
    """``w0 U0 + w1 (U + dt L)`` of one cell with implicit Manning friction on the Euler part; returns
    the three values and the depth clipped away (m).

    Friction solves ``q' + dt g n^2 |q'| q' / h'^(7/3) = q + dt L_q`` for ``q'`` in closed form
    (``|q'| = 2|q*| / (1 + sqrt(1 + 4 a |q*|))``, ``a = dt g n^2 / h'^(7/3)``): it only shrinks the
    discharge, never reverses it, and stays bounded as ``h' -> 0``.
    """
    hn = h + dt * dh
    qx = hu + dt * dhu
    qy = hv + dt * dhv
    clipped = 0.0
    if hn <= h_dry:
        if hn < 0.0:
            clipped = -hn
            hn = 0.0
        qx = 0.0
        qy = 0.0
    elif n > 0.0:
        qm = math.sqrt(qx * qx + qy * qy)
        if qm > 0.0:
            a = dt * g * n * n / (hn * hn * hn ** (1.0 / 3.0))
            f = 2.0 / (1.0 + math.sqrt(1.0 + 4.0 * a * qm))
            qx *= f
            qy *= f
    if w0 == 0.0:
        return hn, qx, qy, clipped
    return w0 * h0 + w1 * hn, w0 * hu0 + w1 * qx, w0 * hv0 + w1 * qy, clipped


@_jit
def _stage_rows(h, hu, hv, u, v, eta, obst, lo, hi, h0, hu0, hv0, manning, idx, idy, g, second_order, limiter,
                riemann, dt, h_dry, w0, hout, huout, hvout, j0, j1):
    """:func:`stage` on the interior rows ``j0 .. j1 - 1``; returns the depth clipped away."""
    nx = h.shape[1] - 2 * G
    nxp = h.shape[1]
    w1 = 1.0 - w0
    s_cur = np.empty((4, nxp))   # y slopes of the current row
    s_nxt = np.empty((4, nxp))   # y slopes of the next row
    f_below = np.empty((4, nxp))  # y faces below / above the current row
    f_above = np.empty((4, nxp))
    acc = np.empty((3, nxp))
    clipped = 0.0
    # the faces below the first row: slopes of rows j0 - 1 (into s_nxt) and j0
    a, b = _hull(lo, hi, j0 - 2, j0)
    y_slopes_row(h, u, v, eta, obst, j0 - 1, a, b, second_order, limiter, s_nxt)
    a, b = _hull(lo, hi, j0 - 1, j0 + 1)
    y_slopes_row(h, u, v, eta, obst, j0, a, b, second_order, limiter, s_cur)
    a, b = _hull(lo, hi, j0 - 1, j0)
    y_face_row(h, u, v, eta, obst, j0 - 1, a, b, g, riemann, s_nxt, s_cur, f_below)
    for j in range(j0, j1):
        a, b = _hull(lo, hi, j, j + 2)
        y_slopes_row(h, u, v, eta, obst, j + 1, a, b, second_order, limiter, s_nxt)
        a, b = _hull(lo, hi, j, j + 1)
        y_face_row(h, u, v, eta, obst, j, a, b, g, riemann, s_cur, s_nxt, f_above)
        a = lo[j]
        b = hi[j]
        if a <= b:
            # a face towards a skipped open cell is zero; towards an obstacle it is a wall (reflected momentum)
            x_row(h, u, v, eta, obst, j, a, b, idx, g, second_order, limiter, riemann, a > G and obst[j, a - 1] != 1,
                  b < G + nx - 1 and obst[j, b + 1] != 1, acc)
        # y faces towards a skipped (quiet) open interior cell count as zero, as the skipped cell takes none;
        # faces towards an obstacle are walls and always count
        lo_b = lo[j - 1] if j - 1 >= G else G
        hi_b = hi[j - 1] if j - 1 >= G else G + nx - 1
        lo_a = lo[j + 1] if j + 1 < h.shape[0] - G else G
        hi_a = hi[j + 1] if j + 1 < h.shape[0] - G else G + nx - 1
        for i in range(G, G + nx):
            if obst[j, i] != 0:
                hout[j, i] = 0.0
                huout[j, i] = 0.0
                hvout[j, i] = 0.0
            elif i >= a and i <= b:
                dh = acc[0, i]
                dhu = acc[1, i]
                dhv = acc[2, i]
                fb0 = 0.0
                fb1 = 0.0
                fb2 = 0.0
                fb3 = 0.0
                fa0 = 0.0
                fa1 = 0.0
                fa2 = 0.0
                if (i >= lo_b and i <= hi_b) or obst[j - 1, i] == 1:
                    fb0 = f_below[0, i]
                    fb1 = f_below[1, i]
                    fb2 = f_below[2, i]
                    fb3 = f_below[3, i]
                if (i >= lo_a and i <= hi_a) or obst[j + 1, i] == 1:
                    fa0 = f_above[0, i]
                    fa1 = f_above[1, i]
                    fa2 = f_above[2, i]
                dh += (fb0 - fa0) * idy
                dhv += (fb1 + fb3 - fa1) * idy - g * h[j, i] * s_cur[1, i] * idy
                dhu += (fb2 - fa2) * idy
                hn, qx, qy, c = _update(h0[j, i], hu0[j, i], hv0[j, i], h[j, i], hu[j, i], hv[j, i], dh, dhu, dhv,
                                        manning[j, i], dt, g, h_dry, w0, w1)
                hout[j, i] = hn
                huout[j, i] = qx
                hvout[j, i] = qy
                clipped += c
            elif w0 == 0.0:  # quiet: the update is the identity
                hout[j, i] = h[j, i]
                huout[j, i] = hu[j, i]
                hvout[j, i] = hv[j, i]
            else:
                hout[j, i] = w0 * h0[j, i] + w1 * h[j, i]
                huout[j, i] = w0 * hu0[j, i] + w1 * hu[j, i]
                hvout[j, i] = w0 * hv0[j, i] + w1 * hv[j, i]
        f_below, f_above = f_above, f_below
        s_cur, s_nxt = s_nxt, s_cur
    return clipped


@_pjit
def stage(h, hu, hv, u, v, eta, obst, lo, hi, h0, hu0, hv0, manning, dx, dy, g, second_order, limiter, riemann,
          dt, h_dry, w0, hout, huout, hvout, blocks):
    """``out = w0 U0 + (1 - w0) (U + dt L(U))`` on every interior cell; *U* = (h, hu, hv) with its
    primitives (u, v, eta) and activity ranges (lo, hi), *U0* = (h0, hu0, hv0). *out* may be *U0* but
    not *U*. *blocks* blocks of rows in parallel (one per numba thread; each writes only its own rows,
    the face rows between blocks are computed by both). Returns the depth clipped away (sum of negative
    depths, m), a positivity diagnostic."""
    ny = h.shape[0] - 2 * G
    nblk = max(1, min(ny, blocks))
    clipped = 0.0
    for k in numba.prange(nblk):
        j0 = G + (k * ny) // nblk
        j1 = G + ((k + 1) * ny) // nblk
        clipped += _stage_rows(h, hu, hv, u, v, eta, obst, lo, hi, h0, hu0, hv0, manning, 1.0 / dx, 1.0 / dy, g,
                               second_order, limiter, riemann, dt, h_dry, w0, hout, huout, hvout, j0, j1)
    return clipped


@_pjit
def copy_interior(src, dst):
    """``dst = src`` on the interior cells."""
    for j in numba.prange(G, src.shape[0] - G):
        for i in range(G, src.shape[1] - G):
            dst[j, i] = src[j, i]
