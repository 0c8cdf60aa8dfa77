"""Face fluxes of the finite-volume shallow-water solver (docs/theory.md, *Shallow-water equations*), one grid row at a time.

MUSCL reconstruction of ``h, eta, u, v`` with a slope limiter (second order) or piecewise-constant
values (first order), hydrostatic reconstruction at each face (Audusse et al. 2004,
``z* = max(zL, zR)``, ``h*_K = max(0, eta_K - z*)``) and an HLL / HLLC flux (:func:`_face_flux`).

Well-balancing to round-off: the momentum flux is split as ``F = D + p*_L`` with the pressure
``p = g h^2 / 2`` kept apart, so that the face terms and the centred bed-slope source combine into
``-g (h+ + h-)/2 (eta+ - eta-) / dx``, which is exactly zero for a lake at rest.

Row kernels work on a column range ``lo..hi`` (padded indices) so that the caller skips cells whose
update is exactly zero (:func:`breachflow.swe.step.activity`).
"""
from __future__ import annotations

import math

from .layout import _jit


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


#: bed step (m) at a pit or crest from which the depth and surface slopes are zero (:func:`slopes`)
BED_STEP = 0.01
#: a lower neighbour shallower than this fraction of the bed step down to it counts as dry (:func:`slopes`)
DRY_FRACTION = 0.1


@_jit
def _dry_fade(hn, step):
    """Slope factor beside a neighbour of depth *hn* whose bed is *step* >= 0 below the cell's:
    ``1 - s (1 - w)``, ``w = min(1, hn / (DRY_FRACTION step))`` (0 when it is dry), ``s = min(1, step /
    BED_STEP)``."""
    if hn >= DRY_FRACTION * step:
        return 1.0
    w = hn / (DRY_FRACTION * step)
    return 1.0 - min(1.0, step / BED_STEP) * (1.0 - w)


#: slack (m) of :func:`_bed_bound` (the round-off of ``eta - h`` on a flat bed is no bed slope)
BED_SLACK = 1e-9


@_jit
def _bed_bound(sz, dm, dp):
    """Factor ``<= 1`` on the ``h`` and ``eta`` slopes of a cell so that the bed slope they imply, *sz* =
    ``s_eta - s_h``, lies between 0 and ``minmod(dm, dp)``, the limited slope of the bed itself (bed steps
    *dm* behind, *dp* ahead; :data:`BED_SLACK` of slack)."""
    a = abs(sz)
    bound = BED_SLACK
    if sz * dm > 0.0 and sz * dp > 0.0:
        bound += min(abs(dm), abs(dp))
    return 1.0 if a <= bound else bound / a


@_jit
def slopes(hm, hc, hp, em, ec, ep, um, uc, up, vm, vc, vp, limiter):
    """Limited slopes of ``h, eta, u, v`` of a cell from its values and those of its two neighbours
    (scalars only: a helper taking arrays would count their references at every cell).

    Where the cell's bed ``z = eta - h`` is a local minimum or maximum along the direction (a pit or a
    crest between steps: both neighbours' beds higher, or both lower), the slopes of ``h`` and ``eta`` are
    zero (first order) once both steps reach :data:`BED_STEP`. Otherwise the implied bed ``eta - h`` of the reconstruction tilts inside a cell
    whose bed is flat, e.g. a pit took the level of its outlet and the bed of the dry bank opposite as a
    surface slope: the source ``-g h deta/dx`` drove its whole water column towards the outlet, against a
    bank face that hydrostatic reconstruction leaves without reaction (dry on both sides), until friction
    balanced it — heads metres above the upstream one (``tests/swe/test_energy_bound.py``). On smooth beds
    only the cells at the bottom of a trough or the top of a bump are affected (Thacker's bowl keeps its
    error). A lake at rest stays at rest (its ``eta`` slopes are zero anyway). The slopes fade out as the
    smaller of the two bed steps grows from 0 to :data:`BED_STEP` (a switch would flip on the round-off of
    interpolated beds and make near-identical terrains give different solutions).

    Beside a dry neighbour lower than the cell's bed (an overfall brink) the slopes of ``h`` and ``eta``
    fade out too, linearly as that neighbour's depth falls from :data:`DRY_FRACTION` of the step down to 0
    (:func:`_dry_fade`; flat beds and dry cells up-slope, e.g. Thacker's shore, are unchanged; ANUGA DE1
    goes to first order near all dry cells, with its ``hfactor`` from the smallest depth around a cell).
    A dry cell's ``eta`` is its bed, not a water surface: on a raised-bed pile column spilling onto a lower
    dry cell the limiter took that bed as the column's surface slope (half a metre across a cell whose bed
    is flat) and the source ``-g h deta/dx`` drove its water to 4.6-5.7 m/s, heads 0.1-0.7 m above the
    reservoir's (``tests/swe/test_energy_bound.py``, the pile column of the nested closure).

    Beside a face that is a wall or a fall for the centre values (one side's bed above the other side's
    surface, e.g. a crest carrying a thin film above a pile cell) the bed slope the reconstruction implies,
    ``s_eta - s_h``, is bounded by the bed's own limited slope ``minmod(z_c - z_m, z_p - z_c)`` (both
    slopes scaled down together, :func:`_bed_bound`; the bound sets in as that gap grows to
    :data:`BED_STEP`). Otherwise the limiter took the film's surface above and a lower shallow cell's
    surface below as one surface slope of a cell whose bed is flat (its implied bed tilted 0.64 m across
    the cell between steps of 1.27 and 0.08 m) and the source ``-g h deta/dx`` drove 0.67 m of water to
    7.65 m/s, 2.4 m of head above the reservoir's (HEC-RAS nested closure, seed 12;
    ``test_a_pile_cell_at_the_foot_of_a_fall_gains_no_head``). Where both faces connect (a smooth bed,
    a lake at rest, flat beds) nothing changes."""
    zc = ec - hc
    dm = zc - (em - hm)
    dp = (ep - hp) - zc
    f = 1.0
    if dm * dp < 0.0:  # fades linearly to zero as the smaller step grows to BED_STEP: continuous in the bed
        f = max(0.0, 1.0 - min(abs(dm), abs(dp)) / BED_STEP)
    # beside a neighbour whose bed is lower by a step and whose depth is below DRY_FRACTION of that step (an
    # overfall brink: its eta is its bed); the fade sets in as the step grows to BED_STEP, so that the
    # round-off steps of a flat bed change nothing
    f *= _dry_fade(hm, max(dm, 0.0)) * _dry_fade(hp, max(-dp, 0.0))
    sh = f * _limit(hc - hm, hp - hc, limiter)
    se = f * _limit(ec - em, ep - ec, limiter)
    # beside a face that is a wall or a fall for the centre values (one side's bed above the other's surface)
    # the implied bed slope is bounded by the bed's own; the bound sets in as that gap grows to BED_STEP
    gap = max(max(zc, em - hm) - min(ec, em), max(zc, ep - hp) - min(ec, ep))
    if gap > 0.0:
        f = 1.0 - min(1.0, gap / BED_STEP) * (1.0 - _bed_bound(se - sh, dm, dp))
        sh *= f
        se *= f
    return sh, se, _limit(uc - um, up - uc, limiter), _limit(vc - vm, vp - vc, limiter)


@_jit
def x_row(h, u, v, eta, obst, j, lo, hi, idx, g, second_order, limiter, riemann, cut_lo, cut_hi, acc):
    """x faces of row *j* around cells ``lo..hi``: ``acc[0..2, i]`` = flux divergence of ``h, hu, hv`` in x
    plus the centred x bed-slope source (per unit area). Slopes of the left cell are carried from the
    previous face. *cut_lo* / *cut_hi*: the face west of ``lo`` / east of ``hi`` borders a skipped
    (quiet) cell and counts as zero (the bed-slope source of cell ``lo`` is kept)."""
    for i in range(lo, hi + 1):
        acc[0, i] = 0.0
        acc[1, i] = 0.0
        acc[2, i] = 0.0
    shl = 0.0
    sel = 0.0
    sul = 0.0
    svl = 0.0
    i = lo if cut_lo else lo - 1
    if second_order and obst[j, i] == 0 and obst[j, i - 1] == 0 and obst[j, i + 1] == 0:
        shl, sel, sul, svl = slopes(h[j, i - 1], h[j, i], h[j, i + 1], eta[j, i - 1], eta[j, i], eta[j, i + 1],
                                    u[j, i - 1], u[j, i], u[j, i + 1], v[j, i - 1], v[j, i], v[j, i + 1], limiter)
    nxp = h.shape[1]
    if cut_lo and not obst[j, lo] == 1:
        acc[1, lo] -= g * h[j, lo] * sel * idx
    for i in range(lo if cut_lo else lo - 1, hi if cut_hi else hi + 1):
        ir = i + 1
        blocked_l = obst[j, i] == 1
        blocked_r = obst[j, ir] == 1
        shr = 0.0
        ser = 0.0
        sur = 0.0
        svr = 0.0
        if second_order and obst[j, ir] == 0 and ir + 1 < nxp and obst[j, i] == 0 and obst[j, ir + 1] == 0:
            shr, ser, sur, svr = slopes(h[j, i], h[j, ir], h[j, ir + 1], eta[j, i], eta[j, ir], eta[j, ir + 1],
                                        u[j, i], u[j, ir], u[j, ir + 1], v[j, i], v[j, ir], v[j, ir + 1], limiter)
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
            elif blocked_l:
                hr = h[j, ir] - 0.5 * shr
                er = eta[j, ir] - 0.5 * ser
                ur = u[j, ir] - 0.5 * sur
                vr = v[j, ir] - 0.5 * svr
                fh, d, ft, jj = _face_flux(hr, er, -ur, vr, hr, er, ur, vr, g, riemann, up)
                fh = 0.0
                ft = 0.0
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
            if i >= lo and not blocked_l:
                acc[0, i] -= fh * idx
                acc[1, i] -= d * idx
                acc[2, i] -= ft * idx
            if ir <= hi and not blocked_r:
                acc[0, ir] += fh * idx
                acc[1, ir] += (d + jj) * idx
                acc[2, ir] += ft * idx
                # centred bed-slope source combined with the face pressures (see module doc)
                acc[1, ir] -= g * h[j, ir] * ser * idx
        shl = shr
        sel = ser
        sul = sur
        svl = svr


@_jit
def y_slopes_row(h, u, v, eta, obst, j, lo, hi, second_order, limiter, s):
    """``s[0..3, i]`` = limited y slopes of ``h, eta, u, v`` of the cells ``lo..hi`` of row *j* (zero at
    first order)."""
    ok_row = second_order and j + 1 < h.shape[0]
    for i in range(lo, hi + 1):
        if ok_row and obst[j, i] == 0 and obst[j - 1, i] == 0 and obst[j + 1, i] == 0:
            a, b, c, d = slopes(h[j - 1, i], h[j, i], h[j + 1, i], eta[j - 1, i], eta[j, i], eta[j + 1, i],
                                u[j - 1, i], u[j, i], u[j + 1, i], v[j - 1, i], v[j, i], v[j + 1, i], limiter)
            s[0, i] = a
            s[1, i] = b
            s[2, i] = c
            s[3, i] = d
        else:
            s[0, i] = 0.0
            s[1, i] = 0.0
            s[2, i] = 0.0
            s[3, i] = 0.0


@_jit
def y_face_row(h, u, v, eta, obst, j, lo, hi, g, riemann, sl, sr, f):
    """Faces between rows *j* and *j + 1* at columns ``lo..hi`` into ``f[0..3, i] = (F_h, D, F_t, J)``
    (:func:`_face_flux` in the y frame); *sl*, *sr* the y slopes of rows j and j + 1."""
    jr = j + 1
    for i in range(lo, hi + 1):
        blocked_l = obst[j, i] == 1
        blocked_r = obst[jr, i] == 1
        if blocked_l and blocked_r:
            f[0, i] = 0.0
            f[1, i] = 0.0
            f[2, i] = 0.0
            f[3, i] = 0.0
            continue
        up = -1 if obst[j, i] == 2 else (1 if obst[jr, i] == 2 else 0)
        if blocked_r:
            hl = h[j, i] + 0.5 * sl[0, i]
            el = eta[j, i] + 0.5 * sl[1, i]
            vl = v[j, i] + 0.5 * sl[3, i]
            ul = u[j, i] + 0.5 * sl[2, i]
            fh, d, ft, jj = _face_flux(hl, el, vl, ul, hl, el, -vl, ul, g, riemann, up)
            fh = 0.0
            ft = 0.0
        elif blocked_l:
            hr = h[jr, i] - 0.5 * sr[0, i]
            er = eta[jr, i] - 0.5 * sr[1, i]
            vr = v[jr, i] - 0.5 * sr[3, i]
            ur = u[jr, i] - 0.5 * sr[2, i]
            fh, d, ft, jj = _face_flux(hr, er, -vr, ur, hr, er, vr, ur, g, riemann, up)
            fh = 0.0
            ft = 0.0
        else:
            hl = h[j, i] + 0.5 * sl[0, i]
            el = eta[j, i] + 0.5 * sl[1, i]
            vl = v[j, i] + 0.5 * sl[3, i]
            ul = u[j, i] + 0.5 * sl[2, i]
            hr = h[jr, i] - 0.5 * sr[0, i]
            er = eta[jr, i] - 0.5 * sr[1, i]
            vr = v[jr, i] - 0.5 * sr[3, i]
            ur = u[jr, i] - 0.5 * sr[2, i]
            fh, d, ft, jj = _face_flux(hl, el, vl, ul, hr, er, vr, ur, g, riemann, up)
        f[0, i] = fh
        f[1, i] = d
        f[2, i] = ft
        f[3, i] = jj
