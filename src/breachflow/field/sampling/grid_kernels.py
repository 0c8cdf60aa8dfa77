"""numba kernels of structured grids: bilinear interpolation between the four surrounding cell centres
(weights clamped to the outermost centres in the grid's border strip) and the report's neighbourhood mean
(Fig 4.4), per point (callable from other kernels) and in bulk."""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _axis_weight(p, p0, dp, n):
    """Lower index and weight of the upper neighbour along one axis of cell centres; -1 if outside."""
    f = (p - p0) / dp
    if not (f >= -0.5 and f <= n - 0.5):  # also catches NaN
        return -1, 0.0
    if n == 1:
        return 0, 0.0
    i = int(np.floor(f))
    if i < 0:
        return 0, 0.0
    if i > n - 2:
        return n - 2, 1.0
    return i, f - i


@numba.njit(cache=True)
def grid_bilinear_point(bed, depth, u, v, x0, y0, dx, dy, x, y):
    """Bilinear sample of one point; returns ``(inside, bed, depth, u, v)`` (NaN outside, dry → 0)."""
    ny, nx = depth.shape
    i, tx = _axis_weight(x, x0, dx, nx)
    j, ty = _axis_weight(y, y0, dy, ny)
    if i < 0 or j < 0:
        return False, np.nan, np.nan, np.nan, np.nan
    i1 = min(i + 1, nx - 1)
    j1 = min(j + 1, ny - 1)
    w00 = (1.0 - tx) * (1.0 - ty)
    w10 = tx * (1.0 - ty)
    w01 = (1.0 - tx) * ty
    w11 = tx * ty
    b = w00 * bed[j, i] + w10 * bed[j, i1] + w01 * bed[j1, i] + w11 * bed[j1, i1]
    h = w00 * depth[j, i] + w10 * depth[j, i1] + w01 * depth[j1, i] + w11 * depth[j1, i1]
    if h <= 1e-6:  # DRY_DEPTH
        return True, b, 0.0, 0.0, 0.0
    uu = w00 * u[j, i] + w10 * u[j, i1] + w01 * u[j1, i] + w11 * u[j1, i1]
    vv = w00 * v[j, i] + w10 * v[j, i1] + w01 * v[j1, i] + w11 * v[j1, i1]
    return True, b, h, uu, vv


@numba.njit(cache=True)
def grid_neighbourhood_point(bed, depth, u, v, x0, y0, dx, dy, x, y, radius):
    """Mean of the cell-centre values within ``radius`` of (x, y) (Fig 4.4); ``(inside, bed, depth, u, v, count)``."""
    ny, nx = depth.shape
    fx = (x - x0) / dx
    fy = (y - y0) / dy
    if not (fx >= -0.5 and fx <= nx - 0.5 and fy >= -0.5 and fy <= ny - 0.5):
        return False, np.nan, np.nan, np.nan, np.nan, 0
    ilo = max(int(np.ceil((x - radius - x0) / dx)), 0)
    ihi = min(int(np.floor((x + radius - x0) / dx)), nx - 1)
    jlo = max(int(np.ceil((y - radius - y0) / dy)), 0)
    jhi = min(int(np.floor((y + radius - y0) / dy)), ny - 1)
    r2 = radius * radius
    n = 0
    sb = 0.0
    sh = 0.0
    su = 0.0
    sv = 0.0
    for j in range(jlo, jhi + 1):
        ey = y0 + j * dy - y
        for i in range(ilo, ihi + 1):
            ex = x0 + i * dx - x
            if ex * ex + ey * ey <= r2:
                n += 1
                sb += bed[j, i]
                sh += depth[j, i]
                su += u[j, i]
                sv += v[j, i]
    if n == 0:
        return False, np.nan, np.nan, np.nan, np.nan, 0
    h = sh / n
    if h <= 1e-6:
        return True, sb / n, 0.0, 0.0, 0.0, n
    return True, sb / n, h, su / n, sv / n, n


@numba.njit(cache=True)
def _grid_neighbourhood_many(bed, depth, u, v, x0, y0, dx, dy, px, py, pr, smax, order, ob, oh, ou, ov, inside):
    for kk in range(order.size):
        k = order[kk]
        r = max(pr[k], smax)
        ins, b, h, uu, vv, n = grid_neighbourhood_point(bed, depth, u, v, x0, y0, dx, dy, px[k], py[k], r)
        inside[k] = ins
        ob[k] = b
        oh[k] = h
        ou[k] = uu
        ov[k] = vv



# --------------------------------------------------------------------------------------------------
# bulk kernel over a packed copy of the fields (one cache line holds all fields of a gridpoint)
# --------------------------------------------------------------------------------------------------

@numba.njit(cache=True)
def _grid_bilinear_packed(pack, x0, y0, dx, dy, px, py, ob, oh, ou, ov, inside):
    """``pack[j, i] = (bed, depth, u, v)``; same arithmetic as ``grid_bilinear_point``."""
    ny, nx = pack.shape[0], pack.shape[1]
    for k in range(px.size):
        i, tx = _axis_weight(px[k], x0, dx, nx)
        j, ty = _axis_weight(py[k], y0, dy, ny)
        if i < 0 or j < 0:
            inside[k] = False
            ob[k] = np.nan
            oh[k] = np.nan
            ou[k] = np.nan
            ov[k] = np.nan
            continue
        i1 = min(i + 1, nx - 1)
        j1 = min(j + 1, ny - 1)
        w00 = (1.0 - tx) * (1.0 - ty)
        w10 = tx * (1.0 - ty)
        w01 = (1.0 - tx) * ty
        w11 = tx * ty
        inside[k] = True
        ob[k] = w00 * pack[j, i, 0] + w10 * pack[j, i1, 0] + w01 * pack[j1, i, 0] + w11 * pack[j1, i1, 0]
        h = w00 * pack[j, i, 1] + w10 * pack[j, i1, 1] + w01 * pack[j1, i, 1] + w11 * pack[j1, i1, 1]
        if h <= 1e-6:
            oh[k] = 0.0
            ou[k] = 0.0
            ov[k] = 0.0
        else:
            oh[k] = h
            ou[k] = w00 * pack[j, i, 2] + w10 * pack[j, i1, 2] + w01 * pack[j1, i, 2] + w11 * pack[j1, i1, 2]
            ov[k] = w00 * pack[j, i, 3] + w10 * pack[j, i1, 3] + w01 * pack[j1, i, 3] + w11 * pack[j1, i1, 3]

