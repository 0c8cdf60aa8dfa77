"""Dense cell bins of the DEM neighbour search (split out of :mod:`.neighbours`): LAMMPS-style binning of nearly
uniform spheres, a counting sort into a padded dense cell array with ghost copies across periodic seams
(:func:`bin_dense`), and the half-stencil search over 5 contiguous runs of entries per cell with plain
distances (:func:`search_bins`). :func:`.neighbours.find_pairs` uses it when the particles' box is compact."""
from __future__ import annotations

import math

import numba
import numpy as np

from .periodic import wrapped


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
    beyond the capacity of *out_a* are counted, not stored). The pair order is the scan's (callers sort).

    Every candidate is written to the slot after the last kept pair (``_near_in``), the last slot once
    the buffers are full: when the count equals the capacity exactly, a candidate met after the last pair
    may have overwritten it, so the scan is repeated with one spare slot (rare; tests/dem/test_neighbours.py)."""
    cap = out_a.shape[0]
    if cap == 0:  # no capacity: count only (the pairs are written to a scratch slot)
        return _scan_bins(dim, start, bid, bp, np.empty(1, np.int64), np.empty(1, np.int64))
    n = _scan_bins(dim, start, bid, bp, out_a, out_b)
    if n == cap:
        a = np.empty(cap + 1, np.int64)
        b = np.empty(cap + 1, np.int64)
        _scan_bins(dim, start, bid, bp, a, b)
        out_a[:] = a[:cap]
        out_b[:] = b[:cap]
    return n


@numba.njit(cache=True, error_model="numpy")
def _scan_bins(dim, start, bid, bp, out_a, out_b):
    """The scan of :func:`search_bins` into buffers of at least one slot (the last one is the scratch slot
    once they are full)."""
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
    """:func:`.neighbours._find_pairs_half` on a dense cell array (:func:`bin_dense`, :func:`search_bins`). Returns the
    pair count, or -1 when the particles' box is sparse (use the hash)."""
    dim, start, bid, bp = bin_dense(search_idx, pos, radius, margin, geom, periodic, ncell)
    if dim[0] <= 0:
        return dim[0]
    return search_bins(dim, start, bid, bp, out_a, out_b)
