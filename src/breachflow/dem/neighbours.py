"""Neighbour search of the DEM (SPEC §5): a cell grid and the pair list (split out of :mod:`.contacts`).

Each particle is inserted in every cell its bounding box (radius + skin/2) overlaps, so the cell size can
follow the *typical* diameter while a 10:1 size ratio only costs the few large particles more insertions;
a pair is reported once, from the cell at the minimum corner of the intersection of both boxes. Nearly
uniform spheres without sleepers use one cell per particle and a half stencil (own cell + 13 forward
cells, as LAMMPS' half lists), on a dense cell array when compact (:func:`bin_dense`: a counting sort into
padded bins with ghost copies across periodic seams, so the search reads 5 contiguous runs of entries per
cell with plain distances, :func:`search_bins`). Only awake particles search (sleeping ones sit in a
separate grid rebuilt on sleep/wake). Elsewhere periodic x / y use minimum-image distances and wrapped
cell coordinates. The list is kept until some awake particle moved more than skin/2
(:func:`displacement_since`, as LAMMPS' ``neigh_modify check yes``).
"""
from __future__ import annotations

import math

import numba
import numpy as np

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
def min_image(dx, L, periodic):
    """Minimum-image difference ``dx - L round(dx / L)`` for a periodic axis of length *L*. Wrapped
    coordinates differ by less than L/2 for most pairs: those skip the division (same result)."""
    if periodic and (dx >= 0.5 * L or dx < -0.5 * L):
        dx -= L * math.floor(dx / L + 0.5)
    return dx


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
def bin_dense(search_idx, pos, radius, margin, geom, periodic, ncell):
    """The particles *search_idx* counting-sorted into a dense cell array over their bounding box (whole
    periods on periodic axes), as LAMMPS' bins, with one padding layer on each side in x and y and on top in
    z, so that a cell's forward half stencil (:func:`search_bins`) never leaves the array. On a periodic
    axis the padding holds ghost copies (position shifted by the period) of the particles in the first and
    last layer of cells, as LAMMPS' ghost atoms: distances are plain differences, no minimum image and no
    wrapped cell coordinates in the search. Positions are wrapped into the period before binning.

    Returns (dim, start, bid, bp): the unpadded cells per axis (nx, ny, nz), the first entry of each padded
    cell (CSR, ``start[c]:start[c + 1]``, cell ``c = (z (ny + 2) + y) (nx + 2) + x`` for padded x, y in
    ``[0, n + 2)``, z in ``[0, nz + 1)``), the particle of each entry and its binned copy of the position
    and reach (x, y, z, radius + margin; contiguous in cell order). ``dim[0] = -1`` when the padded box
    holds more than 27 cells per particle (+ 4096; sparse: use the hash)."""
    n = search_idx.shape[0]
    cell = np.empty((n, 3), np.int64)
    wp = np.empty((n, 3))
    lo = np.zeros(3, np.int64)
    dim = np.zeros(3, np.int64)
    for k in range(n):
        i = search_idx[k]
        for d in range(3):
            x = pos[i, d]
            if d < 2 and periodic[d]:
                x = wrapped(x, geom[d], geom[6 + d])
                c = int(math.floor((x - geom[d]) / geom[3 + d]))
                c = min(max(c, 0), ncell[d] - 1)  # x in [lo, lo + L): only round-off can leave the range
            else:
                c = int(math.floor((x - geom[d]) / geom[3 + d]))
            wp[k, d] = x
            cell[k, d] = c
            if k == 0 or c < lo[d]:
                lo[d] = c
            if k == 0 or c > dim[d]:
                dim[d] = c
    for d in range(3):
        dim[d] = dim[d] - lo[d] + 1
    for d in range(2):
        if periodic[d]:
            lo[d] = 0
            dim[d] = ncell[d]
    if n == 0 or (dim[0] + 2) * (dim[1] + 2) * (dim[2] + 1) > 27 * n + 4096:  # padded cells
        dim[0] = 0 if n == 0 else -1
        return dim, np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros((0, 4))
    nx = dim[0]
    ny = dim[1]
    DX = nx + 2
    DY = ny + 2
    total = DX * DY * (dim[2] + 1)
    px = periodic[0]
    py = periodic[1]
    start = np.zeros(total + 1, np.int64)
    home = np.empty(n, np.int64)
    ghost = np.zeros(n, np.int64)  # periodic copies: bit 0/1 +/- x, bit 2/3 +/- y
    ng = 0
    for k in range(n):
        x = cell[k, 0] - lo[0] + 1
        y = cell[k, 1] - lo[1] + 1
        c = ((cell[k, 2] - lo[2]) * DY + y) * DX + x
        home[k] = c
        start[c + 1] += 1
        gx = (1 if x == 1 else (-1 if x == nx else 0)) if px else 0
        gy = (1 if y == 1 else (-1 if y == ny else 0)) if py else 0
        if gx != 0:
            start[c + gx * nx + 1] += 1
        if gy != 0:
            start[c + gy * ny * DX + 1] += 1
            if gx != 0:
                start[c + gx * nx + gy * ny * DX + 1] += 1
        ghost[k] = (gx + 1) | ((gy + 1) << 2)
    for c in range(total):
        start[c + 1] += start[c]
    fill = start[:total].copy()
    m = start[total]
    bid = np.empty(m, np.int64)
    bp = np.empty((m, 4))
    Lx = geom[6]
    Ly = geom[7]
    for k in range(n):
        i = search_idx[k]
        c = home[k]
        gx = (ghost[k] & 3) - 1
        gy = (ghost[k] >> 2) - 1
        r = radius[i] + margin
        for q in range(4):  # the particle, then its copies across the x, y and the corner seams
            if q == 0:
                cq = c
                sx = 0.0
                sy = 0.0
            elif q == 1:
                if gx == 0:
                    continue
                cq = c + gx * nx
                sx = gx * Lx
                sy = 0.0
            elif q == 2:
                if gy == 0:
                    continue
                cq = c + gy * ny * DX
                sx = 0.0
                sy = gy * Ly
            else:
                if gx == 0 or gy == 0:
                    continue
                cq = c + gx * nx + gy * ny * DX
                sx = gx * Lx
                sy = gy * Ly
            e = fill[cq]
            bid[e] = i
            bp[e, 0] = wp[k, 0] + sx
            bp[e, 1] = wp[k, 1] + sy
            bp[e, 2] = wp[k, 2]
            bp[e, 3] = r
            fill[cq] = e + 1
    return dim, start, bid, bp


@numba.njit(cache=True, inline="always", error_model="numpy")
def _near_in(f0, f1, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out):
    """List the pairs of particle *ai* (binned position, reach) with the entries ``f0:f1`` of
    :func:`bin_dense` whose gap is below the skin (key order: min id first); returns the new count."""
    last = out_a.shape[0] - 1
    for f in range(f0, f1):
        dx = bp[f, 0] - xi
        dy = bp[f, 1] - yi
        dz = bp[f, 2] - zi
        reach = ri + bp[f, 3]
        b = bid[f]
        s = min(n_out, last)  # written always, kept only when near (no branch to mispredict)
        out_a[s] = min(ai, b)
        out_b[s] = max(ai, b)
        n_out += dx * dx + dy * dy + dz * dz < reach * reach
    return n_out


@numba.njit(cache=True, error_model="numpy")
def search_bins(dim, start, bid, bp, out_a, out_b):
    """The half-stencil search over the padded bins of :func:`bin_dense`, cell by cell: each particle meets
    the later entries of its own cell and the 13 forward cells (x + 1; the row y + 1 at z; the three rows
    at z + 1), read as 5 contiguous runs of entries (cells x - 1, x, x + 1 of a row are consecutive), so
    each pair is met once (through a ghost copy across a periodic seam). Returns the pair count (pairs
    beyond the capacity of *out_a* are counted, not stored). The pair order is the scan's (callers sort)."""
    if out_a.shape[0] == 0:  # no capacity: count only (the pairs are written to a scratch slot)
        out_a = np.empty(1, np.int64)
        out_b = np.empty(1, np.int64)
    nx = dim[0]
    ny = dim[1]
    DX = nx + 2
    DXY = DX * (ny + 2)
    n_out = 0
    for z in range(dim[2]):
        for y in range(1, ny + 1):
            base = (z * (ny + 2) + y) * DX
            for x in range(1, nx + 1):
                c = base + x
                s0 = start[c]
                e0 = start[c + 1]
                if s0 == e0:
                    continue
                own_end = start[c + 2]  # own cell and x + 1
                c1 = c + DX  # row y + 1 at z
                c2 = c + DXY - DX  # rows y - 1, y, y + 1 at z + 1
                c3 = c2 + DX
                c4 = c3 + DX
                a1 = start[c1 - 1]
                b1 = start[c1 + 2]
                a2 = start[c2 - 1]
                b2 = start[c2 + 2]
                a3 = start[c3 - 1]
                b3 = start[c3 + 2]
                a4 = start[c4 - 1]
                b4 = start[c4 + 2]
                for e in range(s0, e0):
                    ai = bid[e]
                    xi = bp[e, 0]
                    yi = bp[e, 1]
                    zi = bp[e, 2]
                    ri = bp[e, 3]
                    n_out = _near_in(e + 1, own_end, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out)
                    n_out = _near_in(a1, b1, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out)
                    n_out = _near_in(a2, b2, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out)
                    n_out = _near_in(a3, b3, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out)
                    n_out = _near_in(a4, b4, ai, xi, yi, zi, ri, bid, bp, out_a, out_b, n_out)
    return n_out


@numba.njit(cache=True, error_model="numpy")
def _find_pairs_dense(search_idx, pos, radius, margin, geom, periodic, ncell, out_a, out_b):
    """:func:`_find_pairs_half` on a dense cell array (:func:`bin_dense`, :func:`search_bins`). Returns the
    pair count, or -1 when the particles' box is sparse (use the hash)."""
    dim, start, bid, bp = bin_dense(search_idx, pos, radius, margin, geom, periodic, ncell)
    if dim[0] <= 0:
        return dim[0]
    return search_bins(dim, start, bid, bp, out_a, out_b)


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


@numba.njit(cache=True, inline="always", error_model="numpy")
def wrapped(x, lo, L):
    """*x* wrapped into the periodic range ``[lo, lo + L)``: ``x - L floor((x - lo) / L)``. Inside the range the
    floor is 0 (``0 < x - lo < L`` gives a quotient below 1 after rounding) and the division is skipped: the
    same result, bit for bit."""
    u = x - lo
    if u > 0.0 and u < L:
        return x - 0.0
    return x - L * math.floor(u / L)


@numba.njit(cache=True, inline="always", error_model="numpy")
def outside(x, y, z, box, px, py):
    """Whether ``(x, y, z)`` lies outside *box* (xmin, xmax, ymin, ymax, zmin, zmax) on its non-periodic axes."""
    return ((not px and (x < box[0] or x > box[1])) or (not py and (y < box[2] or y > box[3]))
            or z < box[4] or z > box[5])


@numba.njit(cache=True, error_model="numpy")
def wrap_and_check(idx, pos, vel, omega, geom, periodic, box, use_box, active, awake, left_ids):
    """Wrap periodic coordinates (:func:`wrapped`); deactivate particles outside *box* (xmin, xmax, ymin,
    ymax, zmin, zmax; :func:`outside`): inactive, asleep, at rest, listed in *left_ids*.

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
    """Zero-capacity pair buffers for :func:`rebuild` / :func:`relist`: (candidates a, b; spare list a, b, shear, rolling,
    touch; other list a, b, shear, rolling, touch)."""
    i, f, t = np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, np.bool_)
    return (i, i.copy(), i.copy(), i.copy(), f, f.copy(), t, i.copy(), i.copy(), f.copy(), f.copy(), t.copy())


@numba.njit(cache=True, error_model="numpy")
def relist(idx, pos, radius, half_skin, geom, periodic, ncell, pa, pb, hist, rhist, pos_build, bufs):
    """:func:`rebuild` of a list of awake particles alone (one cell per particle, no sleeping grid)."""
    return rebuild(idx, pos, radius, half_skin, geom, periodic, ncell, True,
                   (np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), 0), pa, pb, hist, rhist,
                   pos_build, bufs)


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
