"""Neighbour search of the DEM (docs/theory.md, *DEM contact*): a cell grid and the pair list (split out of :mod:`.pair_contacts`).

Each particle is inserted in every cell its bounding box (radius + skin/2) overlaps, so the cell size can
follow the *typical* diameter while a 10:1 size ratio only costs the few large particles more insertions;
a pair is reported once, from the cell at the minimum corner of the intersection of both boxes. Nearly
uniform spheres without sleepers use one cell per particle and a half stencil (own cell + 13 forward
cells, as LAMMPS' half lists), on a dense cell array when compact (:mod:`.bins`: a counting sort into
padded bins with ghost copies across periodic seams, so the search reads 5 contiguous runs of entries per
cell with plain distances). Only awake particles search (sleeping ones sit in a
separate grid rebuilt on sleep/wake). Elsewhere periodic x / y use minimum-image distances and wrapped
cell coordinates. The list is kept until some awake particle moved more than skin/2, checked after each drift
(:func:`displacement_since`, as LAMMPS' ``neigh_modify check yes``).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .bins import _find_pairs_dense, _near_in, bin_dense, search_bins  # noqa: F401  (re-exported)
from .periodic import min_image, outside, wrapped  # noqa: F401  (re-exported)

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
    """Cell coordinate *c* wrapped into [0, n) on a periodic axis (the integer modulo only when outside)."""
    if periodic and (c < 0 or c >= n):
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
def _append_if_near(i, j, pos, radius, margin, geom, periodic, out_a, out_b, n_out):
    """List the pair (min(i, j), max(i, j)) if its gap is below ``2 margin`` (the skin); returns the new
    count (pairs beyond the capacity of out_a are counted, not stored: the caller retries bigger)."""
    dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
    dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
    dz = pos[j, 2] - pos[i, 2]
    reach = radius[i] + radius[j] + 2.0 * margin
    if dx * dx + dy * dy + dz * dz < reach * reach:
        if n_out < out_a.shape[0]:
            out_a[n_out] = min(i, j)
            out_b[n_out] = max(i, j)
        n_out += 1
    return n_out


@numba.njit(cache=True, error_model="numpy")
def _scan(i, lo, hi, pos, radius, margin, geom, periodic, ncell, start, ent_p, ent_c, mask,
          only_greater, single, out_a, out_b, n_out):
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
                    if not single:
                        dx = min_image(pos[j, 0] - pos[i, 0], geom[6], periodic[0])
                        dy = min_image(pos[j, 1] - pos[i, 1], geom[7], periodic[1])
                        dz = pos[j, 2] - pos[i, 2]
                        rj = radius[j] + margin
                        # report once: only from the min corner of the two boxes' intersection
                        jx = int(math.floor((pos[i, 0] + dx - rj - geom[0]) / geom[3]))
                        jy = int(math.floor((pos[i, 1] + dy - rj - geom[1]) / geom[4]))
                        jz = int(math.floor((pos[i, 2] + dz - rj - geom[2]) / geom[5]))
                        if max(lo[0], jx) != cx or max(lo[1], jy) != cy or max(lo[2], jz) != cz:
                            continue
                    n_out = _append_if_near(i, j, pos, radius, margin, geom, periodic, out_a, out_b, n_out)
    return n_out


@numba.njit(cache=True, error_model="numpy")
def _find_pairs_half(search_idx, pos, radius, margin, geom, periodic, ncell, start, ent_p, ent_c, mask, out_a, out_b):
    """:func:`find_pairs` for one cell per particle (cells >= the largest reach) and no sleeping grid: each
    particle scans its own cell (partners j > i) and the 13 cells of the forward half of its 27-cell
    neighbourhood (all partners), so each pair is met once, from one side (a half stencil, as LAMMPS'
    half neighbour lists; periodic ranges hold >= 4 cells, so forward and backward cells differ)."""
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
                        n_out = _append_if_near(i, j, pos, radius, margin, geom, periodic, out_a, out_b, n_out)
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
def wrap_and_check(idx, pos, vel, omega, geom, periodic, box, use_box, active, awake, left_ids):
    """Wrap periodic coordinates (:func:`.periodic.wrapped`); deactivate particles outside *box* (xmin, xmax, ymin,
    ymax, zmin, zmax; :func:`.periodic.outside`): inactive, asleep, at rest, listed in *left_ids*.

    Returns (#left, first non-finite particle index or -1; such a particle is left as it is).
    """
    nleft = 0
    bad = -1
    px = periodic[0]
    py = periodic[1]
    for k in range(idx.shape[0]):
        i = idx[k]
        if not (math.isfinite(pos[i, 0]) and math.isfinite(pos[i, 1]) and math.isfinite(pos[i, 2])
                and math.isfinite(vel[i, 0]) and math.isfinite(vel[i, 1]) and math.isfinite(vel[i, 2])):
            if bad < 0:
                bad = i
            continue
        if px:
            pos[i, 0] = wrapped(pos[i, 0], geom[0], geom[6])
        if py:
            pos[i, 1] = wrapped(pos[i, 1], geom[1], geom[7])
        if use_box and outside(pos[i, 0], pos[i, 1], pos[i, 2], box, px, py):
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
def search_awake(idx, pos, radius, margin, geom, periodic, ncell, out_a, out_b):
    """:func:`find_pairs` for one cell per particle and no sleeping grid (the half stencil): on the dense cell
    array when compact, else on the hashed grid, which is then the only one built (same table size as the
    driver's ``DemSimulation._grid``)."""
    n = _find_pairs_dense(idx, pos, radius, margin, geom, periodic, ncell, out_a, out_b)
    if n >= 0:
        return n
    est = max(1024, 16 * idx.shape[0])
    bits = 0
    while (1 << bits) < est:
        bits += 1
    start, ent_p, ent_c = build_grid(idx, pos, radius, margin, geom, periodic, ncell, bits, True)
    return _find_pairs_half(idx, pos, radius, margin, geom, periodic, ncell, start, ent_p, ent_c, (1 << bits) - 1,
                            out_a, out_b)


@numba.njit(cache=True, error_model="numpy")
def sort_pairs(n, cand_a, cand_b, npart, new_a, new_b):
    """Order the *n* found pairs ``(cand_a < cand_b)`` by key ``(a, b)`` into *new_a*, *new_b*: a counting
    sort by ``a`` (CSR rows), then an insertion sort of each short row by ``b``."""
    row = np.zeros(npart + 1, np.int64)
    for k in range(n):
        row[cand_a[k] + 1] += 1
    for i in range(npart):
        row[i + 1] += row[i]
    for k in range(n):  # row[a] ends as the end of row a (the start of row a + 1)
        a = cand_a[k]
        s = row[a]
        new_a[s] = a
        new_b[s] = cand_b[k]
        row[a] = s + 1
    begin = 0
    for i in range(npart):
        end = row[i]
        for s in range(begin + 1, end):
            b = new_b[s]
            r = s - 1
            while r >= begin and new_b[r] > b:
                new_b[r + 1] = new_b[r]
                r -= 1
            new_b[r + 1] = b
        begin = end


@numba.njit(cache=True, error_model="numpy")
def carry(n, new_a, new_b, pa, pb, hist, rhist, new_h, new_r):
    """Carry the shear / rolling histories over from the old list (*pa*, *pb*, *hist*, *rhist*, sorted by
    key ``(a, b)``) to the *n* sorted pairs *new_a*, *new_b* in one merge walk, dropping repeats (a pair
    found twice: a woken particle still in the stale sleeping grid). Pairs new to the list start with zero
    histories. Returns the pair count."""
    o = 0
    nold = pa.shape[0]
    w = 0
    for k in range(n):
        a = new_a[k]
        b = new_b[k]
        if w > 0 and new_b[w - 1] == b and new_a[w - 1] == a:
            continue
        new_a[w] = a
        new_b[w] = b
        while o < nold and (pa[o] < a or (pa[o] == a and pb[o] < b)):
            o += 1
        if o < nold and pa[o] == a and pb[o] == b:
            for d in range(3):
                new_h[w, d] = hist[o, d]
                new_r[w, d] = rhist[o, d]
        else:
            for d in range(3):
                new_h[w, d] = 0.0
                new_r[w, d] = 0.0
        w += 1
    return w


@numba.njit(cache=True, error_model="numpy")
def sort_and_carry(n, cand_a, cand_b, pa, pb, hist, rhist, npart, new_a, new_b, new_h, new_r):
    """Order the *n* found pairs ``(cand_a < cand_b)`` by key ``(a, b)`` into *new_a*, *new_b*
    (:func:`sort_pairs`) and carry the shear / rolling histories over from the old list (:func:`carry`):
    O(n + old + npart), no global sort. Returns the pair count."""
    sort_pairs(n, cand_a, cand_b, npart, new_a, new_b)
    return carry(n, new_a, new_b, pa, pb, hist, rhist, new_h, new_r)


def empty_buffers():
    """Zero-capacity pair buffers for :func:`rebuild`: (candidates a, b; spare list a, b, shear, rolling,
    touch; other list a, b, shear, rolling, touch)."""
    i, f, t = np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.bool_)
    return (i, i.copy(), i.copy(), i.copy(), f, f.copy(), t, i.copy(), i.copy(), f.copy(), f.copy(), t.copy())


@numba.njit(cache=True, error_model="numpy")
def _search(idx, pos, radius, half_skin, geom, periodic, ncell, single, sgrid, out_a, out_b):
    """The pairs of the awake particles *idx* with gap below the skin: :func:`search_awake` when the list is
    theirs alone (one cell per particle, empty sleeping grid), else :func:`find_pairs` over a hashed grid
    of *idx* (the driver's ``DemSimulation._grid``) and the sleeping grid *sgrid* ``(start, entry particle,
    entry code, table bits)``; a woken particle still in that (stale) grid may be reported twice."""
    s_start, s_ent_p, s_ent_c, s_bits = sgrid
    if single and s_ent_p.shape[0] == 0:
        return search_awake(idx, pos, radius, half_skin, geom, periodic, ncell, out_a, out_b)
    est = max(1024, 16 * idx.shape[0])
    bits = 0
    while (1 << bits) < est:
        bits += 1
    start, ent_p, ent_c = build_grid(idx, pos, radius, half_skin, geom, periodic, ncell, bits, single)
    return find_pairs(idx, pos, radius, half_skin, geom, periodic, ncell, start, ent_p, ent_c, bits, s_start,
                      s_ent_p, s_ent_c, s_bits, single, out_a, out_b)


@numba.njit(cache=True, error_model="numpy")
def rebuild(idx, pos, radius, half_skin, geom, periodic, ncell, single, sgrid, pa, pb, hist, rhist, pos_build, bufs):
    """Rebuild the pair list of the awake particles *idx* — with each other and with the sleepers of the
    sleeping grid *sgrid* (``_search``; pairs of two sleepers are not listed) — into the spare set of
    *bufs* (:func:`empty_buffers`; capacities grow geometrically, never shrink), carrying the histories over
    from the current list *pa*, *pb*, *hist*, *rhist* (:func:`sort_and_carry`), and record the build
    positions. The order equals sorting the keys ``a << 32 | b``. Returns the new list (views into the spare
    set: pa, pb, hist, rhist, touch) and the buffers with spare and other swapped (the current list must not
    live in the spare set). Parked histories (pairs of two sleepers) are the driver's, untouched here."""
    cand_a, cand_b, xa, xb, xh, xr, xt, ya, yb, yh, yr, yt = bufs
    while True:
        n = _search(idx, pos, radius, half_skin, geom, periodic, ncell, single, sgrid, cand_a, cand_b)
        if n <= cand_a.shape[0]:
            break
        cap = max(2 * cand_a.shape[0], n + n // 4 + 64)
        cand_a = np.empty(cap, np.int64)
        cand_b = np.empty(cap, np.int64)
    if n > xa.shape[0]:
        cap = max(2 * xa.shape[0], n + n // 4 + 64)
        xa = np.empty(cap, np.int64)
        xb = np.empty(cap, np.int64)
        xh = np.empty((cap, 3))
        xr = np.empty((cap, 3))
        xt = np.empty(cap, np.bool_)
    n = sort_and_carry(n, cand_a, cand_b, pa, pb, hist, rhist, pos.shape[0], xa, xb, xh, xr)
    xt[:n] = False
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            pos_build[i, d] = pos[i, d]
    return xa[:n], xb[:n], xh[:n], xr[:n], xt[:n], (cand_a, cand_b, ya, yb, yh, yr, yt, xa, xb, xh, xr, xt)
