"""numba kernels of triangle meshes: the bucket-grid point locator (CSR lists of triangles and nodes per
bucket), barycentric interpolation in the containing triangle, the report's neighbourhood mean (Fig 4.4),
and the bucket ordering of points for locality."""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _build_buckets(node_x, node_y, tri, bx0, by0, size, nbx, nby):
    """CSR lists of the triangles whose bounding box overlaps each bucket (two passes: count, fill)."""
    ntri = tri.shape[0]
    counts = np.zeros(nbx * nby + 1, dtype=np.int64)
    lo_i = np.empty(ntri, dtype=np.int64)
    hi_i = np.empty(ntri, dtype=np.int64)
    lo_j = np.empty(ntri, dtype=np.int64)
    hi_j = np.empty(ntri, dtype=np.int64)
    for t in range(ntri):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        xmin = min(node_x[a], node_x[b], node_x[c])
        xmax = max(node_x[a], node_x[b], node_x[c])
        ymin = min(node_y[a], node_y[b], node_y[c])
        ymax = max(node_y[a], node_y[b], node_y[c])
        lo_i[t] = min(max(int((xmin - bx0) / size), 0), nbx - 1)
        hi_i[t] = min(max(int((xmax - bx0) / size), 0), nbx - 1)
        lo_j[t] = min(max(int((ymin - by0) / size), 0), nby - 1)
        hi_j[t] = min(max(int((ymax - by0) / size), 0), nby - 1)
        for j in range(lo_j[t], hi_j[t] + 1):
            for i in range(lo_i[t], hi_i[t] + 1):
                counts[j * nbx + i + 1] += 1
    for k in range(1, counts.size):
        counts[k] += counts[k - 1]
    items = np.empty(counts[-1], dtype=np.int64)
    fill = counts[:-1].copy()
    for t in range(ntri):
        for j in range(lo_j[t], hi_j[t] + 1):
            for i in range(lo_i[t], hi_i[t] + 1):
                b = j * nbx + i
                items[fill[b]] = t
                fill[b] += 1
    return counts, items


@numba.njit(cache=True)
def mesh_locate(node_x, node_y, tri, bx0, by0, size, nbx, nby, bstart, bitems, x, y):
    """Containing triangle of (x, y) and its barycentric weights; ``(-1, nan, nan, nan)`` outside."""
    fi = (x - bx0) / size
    fj = (y - by0) / size
    if not (fi >= 0.0 and fi <= nbx and fj >= 0.0 and fj <= nby):
        return -1, np.nan, np.nan, np.nan
    bi = min(int(fi), nbx - 1)
    bj = min(int(fj), nby - 1)
    b = bj * nbx + bi
    for k in range(bstart[b], bstart[b + 1]):
        t = bitems[k]
        a, c, d = tri[t, 0], tri[t, 1], tri[t, 2]
        xa, ya = node_x[a], node_y[a]
        e1x, e1y = node_x[c] - xa, node_y[c] - ya
        e2x, e2y = node_x[d] - xa, node_y[d] - ya
        det = e1x * e2y - e1y * e2x
        if det == 0.0:
            continue
        qx, qy = x - xa, y - ya
        l1 = (qx * e2y - qy * e2x) / det
        l2 = (e1x * qy - e1y * qx) / det
        l0 = 1.0 - l1 - l2
        tol = -1e-12
        if l0 >= tol and l1 >= tol and l2 >= tol:
            return t, l0, l1, l2
    return -1, np.nan, np.nan, np.nan


@numba.njit(cache=True)
def mesh_barycentric_point(node_x, node_y, tri, bed, depth, u, v, bx0, by0, size, nbx, nby, bstart, bitems, x, y):
    """Barycentric sample of one point; returns ``(inside, bed, depth, u, v)`` (NaN outside, dry → 0)."""
    t, l0, l1, l2 = mesh_locate(node_x, node_y, tri, bx0, by0, size, nbx, nby, bstart, bitems, x, y)
    if t < 0:
        return False, np.nan, np.nan, np.nan, np.nan
    a, c, d = tri[t, 0], tri[t, 1], tri[t, 2]
    b = l0 * bed[a] + l1 * bed[c] + l2 * bed[d]
    h = l0 * depth[a] + l1 * depth[c] + l2 * depth[d]
    if h <= 1e-6:
        return True, b, 0.0, 0.0, 0.0
    return True, b, h, l0 * u[a] + l1 * u[c] + l2 * u[d], l0 * v[a] + l1 * v[c] + l2 * v[d]


@numba.njit(cache=True)
def _bucket_nodes(node_x, node_y, bx0, by0, size, nbx, nby):
    """CSR lists of node indices per bucket."""
    counts = np.zeros(nbx * nby + 1, dtype=np.int64)
    nn = node_x.size
    which = np.empty(nn, dtype=np.int64)
    for n in range(nn):
        i = min(max(int((node_x[n] - bx0) / size), 0), nbx - 1)
        j = min(max(int((node_y[n] - by0) / size), 0), nby - 1)
        which[n] = j * nbx + i
        counts[which[n] + 1] += 1
    for k in range(1, counts.size):
        counts[k] += counts[k - 1]
    items = np.empty(nn, dtype=np.int64)
    fill = counts[:-1].copy()
    for n in range(nn):
        items[fill[which[n]]] = n
        fill[which[n]] += 1
    return counts, items


@numba.njit(cache=True)
def _mesh_neighbourhood_many(node_x, node_y, tri, bed, depth, u, v, bx0, by0, size, nbx, nby, bstart, bitems,
                             nstart, nitems, px, py, pr, smax, order, ob, oh, ou, ov, inside):
    for kk in range(order.size):
        k = order[kk]
        x = px[k]
        y = py[k]
        t, l0, l1, l2 = mesh_locate(node_x, node_y, tri, bx0, by0, size, nbx, nby, bstart, bitems, x, y)
        if t < 0:
            inside[k] = False
            ob[k] = np.nan
            oh[k] = np.nan
            ou[k] = np.nan
            ov[k] = np.nan
            continue
        r = max(pr[k], smax)
        r2 = r * r
        ilo = min(max(int((x - r - bx0) / size), 0), nbx - 1)
        ihi = min(max(int((x + r - bx0) / size), 0), nbx - 1)
        jlo = min(max(int((y - r - by0) / size), 0), nby - 1)
        jhi = min(max(int((y + r - by0) / size), 0), nby - 1)
        n = 0
        sb = 0.0
        sh = 0.0
        su = 0.0
        sv = 0.0
        for j in range(jlo, jhi + 1):
            for i in range(ilo, ihi + 1):
                b = j * nbx + i
                for q in range(nstart[b], nstart[b + 1]):
                    nd = nitems[q]
                    ex = node_x[nd] - x
                    ey = node_y[nd] - y
                    if ex * ex + ey * ey <= r2:
                        n += 1
                        sb += bed[nd]
                        sh += depth[nd]
                        su += u[nd]
                        sv += v[nd]
        inside[k] = True
        ob[k] = sb / n
        h = sh / n
        if h <= 1e-6:
            oh[k] = 0.0
            ou[k] = 0.0
            ov[k] = 0.0
        else:
            oh[k] = h
            ou[k] = su / n
            ov[k] = sv / n



# --------------------------------------------------------------------------------------------------
# bulk kernel over a packed copy of the fields (one cache line holds all fields of a node), and the
# counting sort of points by bucket
# --------------------------------------------------------------------------------------------------

@numba.njit(cache=True)
def _mesh_barycentric_packed(pack, tri, bx0, by0, size, nbx, nby, bstart, bitems, px, py, order,
                             ob, oh, ou, ov, inside):
    """``pack[n] = (x, y, bed, depth, u, v)``; same arithmetic as ``mesh_barycentric_point``."""
    for kk in range(order.size):
        k = order[kk]
        x = px[k]
        y = py[k]
        found = -1
        l0 = l1 = l2 = 0.0
        fi = (x - bx0) / size
        fj = (y - by0) / size
        if fi >= 0.0 and fi <= nbx and fj >= 0.0 and fj <= nby:
            b = min(int(fj), nby - 1) * nbx + min(int(fi), nbx - 1)
            for q in range(bstart[b], bstart[b + 1]):
                t = bitems[q]
                a, c, d = tri[t, 0], tri[t, 1], tri[t, 2]
                xa, ya = pack[a, 0], pack[a, 1]
                e1x, e1y = pack[c, 0] - xa, pack[c, 1] - ya
                e2x, e2y = pack[d, 0] - xa, pack[d, 1] - ya
                det = e1x * e2y - e1y * e2x
                if det == 0.0:
                    continue
                qx, qy = x - xa, y - ya
                m1 = (qx * e2y - qy * e2x) / det
                m2 = (e1x * qy - e1y * qx) / det
                m0 = 1.0 - m1 - m2
                if m0 >= -1e-12 and m1 >= -1e-12 and m2 >= -1e-12:
                    found = t
                    l0, l1, l2 = m0, m1, m2
                    break
        if found < 0:
            inside[k] = False
            ob[k] = np.nan
            oh[k] = np.nan
            ou[k] = np.nan
            ov[k] = np.nan
            continue
        a, c, d = tri[found, 0], tri[found, 1], tri[found, 2]
        inside[k] = True
        ob[k] = l0 * pack[a, 2] + l1 * pack[c, 2] + l2 * pack[d, 2]
        h = l0 * pack[a, 3] + l1 * pack[c, 3] + l2 * pack[d, 3]
        if h <= 1e-6:
            oh[k] = 0.0
            ou[k] = 0.0
            ov[k] = 0.0
        else:
            oh[k] = h
            ou[k] = l0 * pack[a, 4] + l1 * pack[c, 4] + l2 * pack[d, 4]
            ov[k] = l0 * pack[a, 5] + l1 * pack[c, 5] + l2 * pack[d, 5]


@numba.njit(cache=True)
def _bucket_order(px, py, bx0, by0, size, nbx, nby):
    """Counting sort of the points by bucket (points outside the buckets last): O(N)."""
    n = px.size
    nb = nbx * nby
    key = np.empty(n, dtype=np.int64)
    counts = np.zeros(nb + 2, dtype=np.int64)
    for k in range(n):
        fi = (px[k] - bx0) / size
        fj = (py[k] - by0) / size
        if fi >= 0.0 and fi <= nbx and fj >= 0.0 and fj <= nby:
            b = min(int(fj), nby - 1) * nbx + min(int(fi), nbx - 1)
        else:
            b = nb
        key[k] = b
        counts[b + 1] += 1
    for b in range(1, nb + 2):
        counts[b] += counts[b - 1]
    order = np.empty(n, dtype=np.int64)
    for k in range(n):
        order[counts[key[k]]] = k
        counts[key[k]] += 1
    return order

