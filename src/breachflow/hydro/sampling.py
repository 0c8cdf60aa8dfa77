"""Sampling a hydrodynamic snapshot at particle positions (SPEC §6, report Fig 4.4).

One API for structured grids and triangle meshes::

    sampler = FieldSampler(snapshot, method="bilinear")      # or "neighbourhood"
    s = sampler.sample(px, py, radius)                       # FieldSample of float64 arrays, SI
    s.depth, s.u, s.v, s.bed, s.surface, s.inside

Methods (registry ``breachflow.sampling_methods``, one class per method with ``sample(...)``):

``bilinear``
    Linear interpolation: bilinear between the four surrounding cell centres on grids, barycentric
    inside the containing triangle on meshes (``barycentric`` and ``linear`` are aliases).
    ``f(x, y) = sum_k w_k f_k`` with ``w`` the bilinear / barycentric weights.
``neighbourhood``
    The report's averaging (Fig 4.4): the plain mean of the gridpoint values within the distance
    ``R = max(D/2, s_max)`` of the particle centre, ``D/2`` the particle radius and ``s_max`` the largest
    spacing between neighbouring gridpoints (grids: ``max(dx, dy)``; meshes: longest element edge).
    ``D > 2 s_max`` is a "large" particle averaging over its own disc; a "small" particle uses the
    smallest large-particle neighbourhood, so the neighbourhood of any point inside the field holds
    at least one gridpoint (on meshes at least the three nodes of the containing triangle).

Conventions: the water surface is ``bed + depth`` at the sampled point; where the sampled depth is
at or below :data:`~breachflow.hydro.snapshot.DRY_DEPTH` the point is dry: depth 0 and u = v = 0.
Points outside the field get ``inside=False`` and NaN values (never extrapolated) unless the sampler has
a *fallback* field: ``FieldSampler(local, fallback=regional)`` samples *regional* (a snapshot or a
sampler, same method) where a point lies outside *local* — the nested solver's local grid inside the
ingested regional model (``solver = "nested"``, :mod:`breachflow.hydro.nested`): outside the local
window the field is the regional one as ingested. A grid covers its
cells' footprint, i.e. half a spacing beyond the outermost cell centres; in that border strip the
bilinear weights are clamped to the outermost centres (the cell value, no extrapolation).

The hot loops are numba kernels over plain arrays; :meth:`FieldSampler.grid_arrays` and
:meth:`FieldSampler.mesh_arrays` expose those arrays so that other numba kernels can call
``grid_bilinear_point`` / ``mesh_barycentric_point`` directly without Python.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
import xarray as xr

from ..errors import InputError
from ..registry import Registry
from .snapshot import DRY_DEPTH, is_mesh

__all__ = [
    "FieldSampler", "FieldSample", "GridArrays", "MeshArrays", "SAMPLING_METHODS", "uniform_snapshot",
    "grid_bilinear_point", "grid_neighbourhood_point", "mesh_barycentric_point", "mesh_locate",
]

#: Sampling methods by name; a plug-in is a class ``Method(sampler)`` with
#: ``sample(px, py, radius) -> (bed, depth, u, v, inside)`` over 1-D float64 arrays.
SAMPLING_METHODS: Registry = Registry("sampling method", "breachflow.sampling_methods")


@dataclass
class FieldSample:
    """Field values at sampled points, float64 arrays shaped like the positions, SI units."""

    bed: np.ndarray
    depth: np.ndarray
    surface: np.ndarray
    u: np.ndarray
    v: np.ndarray
    inside: np.ndarray  #: bool; False = outside the field (values there are NaN)

    @property
    def speed(self) -> np.ndarray:
        return np.hypot(self.u, self.v)


class GridArrays(NamedTuple):
    """Raw arrays of one grid time step, ascending cell-centre axes, indexed ``[j, i]`` = ``(y, x)``."""

    bed: np.ndarray
    depth: np.ndarray
    u: np.ndarray
    v: np.ndarray
    x0: float
    y0: float
    dx: float
    dy: float


class MeshArrays(NamedTuple):
    """Raw arrays of one mesh time step plus the bucket-grid triangle locator (CSR layout)."""

    node_x: np.ndarray
    node_y: np.ndarray
    triangles: np.ndarray  #: (n_tri, 3) int64 node indices (quads split in two)
    bed: np.ndarray
    depth: np.ndarray
    u: np.ndarray
    v: np.ndarray
    bucket_x0: float
    bucket_y0: float
    bucket_size: float
    bucket_nx: int
    bucket_ny: int
    bucket_start: np.ndarray  #: (nbx*nby + 1,) offsets into bucket_items
    bucket_items: np.ndarray  #: triangle indices per bucket


# --------------------------------------------------------------------------------------------------
# numba kernels: grids
# --------------------------------------------------------------------------------------------------

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
# numba kernels: triangle meshes with a bucket-grid point locator
# --------------------------------------------------------------------------------------------------

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
# bulk kernels over packed copies of the fields (one cache line holds all fields of a gridpoint)
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


# --------------------------------------------------------------------------------------------------
# Python API
# --------------------------------------------------------------------------------------------------

def _step(da: xr.DataArray, time_index: int | None) -> np.ndarray:
    if "time" in da.dims:
        nt = da.sizes["time"]
        k = nt - 1 if time_index is None else time_index
        if not -nt <= k < nt:
            raise InputError(f"time_index {time_index} out of range for {nt} time steps")
        da = da.isel(time=k)
    return np.ascontiguousarray(da.values, dtype=np.float64)


def _uniform_axis(c: np.ndarray, name: str) -> tuple[float, float]:
    if c.size == 1:
        return float(c[0]), 1.0
    d = np.diff(c)
    if not np.allclose(d, d[0], rtol=1e-6, atol=0) or d[0] <= 0:
        raise InputError(f"snapshot coordinate {name!r} must be uniformly spaced and ascending for sampling")
    return float(c[0]), float((c[-1] - c[0]) / (c.size - 1))


class FieldSampler:
    """Samples one time step of a grid or mesh snapshot at arrays of positions (see module doc).

    ``time_index=None`` takes the only (or, with several, the last) time step. *fallback* (a snapshot
    Dataset or a FieldSampler): the field sampled, with the same method, at points outside this one.
    """

    def __init__(self, snapshot: xr.Dataset, method: str = "bilinear", time_index: int | None = None, *,
                 fallback=None):
        self.kind = "mesh" if is_mesh(snapshot) else "grid"
        if fallback is not None and not isinstance(fallback, FieldSampler):
            if not isinstance(fallback, xr.Dataset):
                raise InputError(f"FieldSampler: fallback must be a snapshot Dataset or a FieldSampler, got {type(fallback).__name__}")
            fallback = FieldSampler(fallback, method)
        self.fallback = fallback
        self.time_index = time_index
        if self.kind == "grid":
            self._init_grid(snapshot, time_index)
        else:
            self._init_mesh(snapshot, time_index)
        self.method = str(method).lower()
        self._impl = SAMPLING_METHODS.get(method)(self)

    # -- construction -----------------------------------------------------------------------------
    def _init_grid(self, ds: xr.Dataset, time_index):
        for name in ("x", "y", "bed_elevation", "depth", "u", "v"):
            if name not in ds.variables:
                raise InputError(f"snapshot has no variable {name!r}; not a breachflow snapshot")
        x = np.asarray(ds["x"].values, dtype=float)
        y = np.asarray(ds["y"].values, dtype=float)
        fields = [np.asarray(ds["bed_elevation"].transpose("y", "x").values, dtype=float)]
        fields += [_step(ds[n].transpose(..., "y", "x"), time_index) for n in ("depth", "u", "v")]
        if x.size > 1 and x[1] < x[0]:
            x = x[::-1]
            fields = [f[:, ::-1] for f in fields]
        if y.size > 1 and y[1] < y[0]:
            y = y[::-1]
            fields = [f[::-1, :] for f in fields]
        x0, dx = _uniform_axis(x, "x")
        y0, dy = _uniform_axis(y, "y")
        bed, depth, u, v = (np.ascontiguousarray(f) for f in fields)
        self._grid = GridArrays(bed, depth, u, v, x0, y0, dx, dy)
        self.s_max = max(dx if x.size > 1 else 0.0, dy if y.size > 1 else 0.0) or max(dx, dy)
        self.extent = (x0 - dx / 2, x0 + (x.size - 0.5) * dx, y0 - dy / 2, y0 + (y.size - 0.5) * dy)

    def _init_mesh(self, ds: xr.Dataset, time_index):
        from .snapshot import mesh_triangles

        topo = next(n for n, v in ds.variables.items() if v.attrs.get("cf_role") == "mesh_topology")
        xname, yname = ds[topo].attrs["node_coordinates"].split()
        nx_ = np.ascontiguousarray(ds[xname].values, dtype=np.float64)
        ny_ = np.ascontiguousarray(ds[yname].values, dtype=np.float64)
        tri = mesh_triangles(ds)
        bed = np.ascontiguousarray(ds["bed_elevation"].values, dtype=np.float64)
        depth, u, v = (_step(ds[n], time_index) for n in ("depth", "u", "v"))
        if tri.shape[0] == 0:
            raise InputError("mesh snapshot has no triangles to sample")
        used = np.unique(tri)
        xmin, xmax = nx_[used].min(), nx_[used].max()
        ymin, ymax = ny_[used].min(), ny_[used].max()
        ex = tri[:, [1, 2, 0]]
        edge = np.hypot(nx_[tri] - nx_[ex], ny_[tri] - ny_[ex])
        self.s_max = float(edge.max())
        # buckets of half the median edge length: a few triangles (bounding boxes) per bucket
        size = 0.5 * float(np.median(edge)) or 1.0
        span = max(xmax - xmin, ymax - ymin)
        size = max(size, span / 4096.0)  # cap the bucket count for very graded meshes
        nbx = max(int(np.ceil((xmax - xmin) / size)), 1)
        nby = max(int(np.ceil((ymax - ymin) / size)), 1)
        bstart, bitems = _build_buckets(nx_, ny_, tri, xmin, ymin, size, nbx, nby)
        self._mesh = MeshArrays(nx_, ny_, tri, bed, depth, u, v, float(xmin), float(ymin), size, nbx, nby,
                                bstart, bitems)
        self._node_buckets = None
        self.extent = (float(xmin), float(xmax), float(ymin), float(ymax))

    def node_buckets(self):
        """CSR node lists on the triangle bucket grid (built on first use by the neighbourhood method)."""
        if self._node_buckets is None:
            m = self._mesh
            self._node_buckets = _bucket_nodes(m.node_x, m.node_y, m.bucket_x0, m.bucket_y0, m.bucket_size,
                                               m.bucket_nx, m.bucket_ny)
        return self._node_buckets

    #: below this many points the sampling order is the input order (sorting would not pay off)
    SORT_THRESHOLD = 20_000

    def locality_order(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Processing order of the points: on meshes, large batches are sorted by bucket so that the
        kernels read triangles and nodes nearly sequentially instead of at random (2-3x faster for
        scattered points; on grids the direct indexing gains nothing from it). Results do not depend
        on the order."""
        n = px.size
        if n < self.SORT_THRESHOLD or self.kind == "grid":
            return np.arange(n, dtype=np.int64)
        m = self._mesh
        return _bucket_order(px, py, m.bucket_x0, m.bucket_y0, m.bucket_size, m.bucket_nx, m.bucket_ny)

    # -- access for numba callers -----------------------------------------------------------------
    def grid_arrays(self) -> GridArrays:
        """Plain arrays + origin/spacing of the grid step (for ``grid_bilinear_point`` etc.)."""
        if self.kind != "grid":
            raise InputError("grid_arrays(): this snapshot is a mesh; use mesh_arrays()")
        return self._grid

    def mesh_arrays(self) -> MeshArrays:
        """Plain arrays + bucket locator of the mesh step (for ``mesh_barycentric_point``)."""
        if self.kind != "mesh":
            raise InputError("mesh_arrays(): this snapshot is a grid; use grid_arrays()")
        return self._mesh

    # -- sampling ---------------------------------------------------------------------------------
    def sample(self, px, py, radius=None) -> FieldSample:
        """Field at positions (m); *radius* (m, scalar or per point) is used by ``neighbourhood``."""
        px = np.asarray(px, dtype=np.float64)
        py = np.asarray(py, dtype=np.float64)
        try:
            shape = np.broadcast_shapes(px.shape, py.shape)
        except ValueError:
            raise InputError(f"sample(): px {px.shape} and py {py.shape} do not broadcast") from None
        fx = np.ascontiguousarray(np.broadcast_to(px, shape).ravel())
        fy = np.ascontiguousarray(np.broadcast_to(py, shape).ravel())
        if radius is None:
            fr = np.zeros(fx.size)
        else:
            r = np.asarray(radius, dtype=np.float64)
            if np.any(~np.isfinite(r)) or np.any(r < 0):
                raise InputError("sample(): radius must be finite and >= 0 (m)")
            fr = np.ascontiguousarray(np.broadcast_to(r, shape).ravel())
        bed, depth, u, v, inside = self._impl.sample(fx, fy, fr)
        if self.fallback is not None and not inside.all():
            out = np.flatnonzero(~inside)
            f = self.fallback.sample(fx[out], fy[out], fr[out])
            for a, b in ((bed, f.bed), (depth, f.depth), (u, f.u), (v, f.v), (inside, f.inside)):
                a[out] = b
        surface = bed + depth
        return FieldSample(*(a.reshape(shape) for a in (bed, depth, surface, u, v, inside)))

    __call__ = sample


def _outputs(n):
    return (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_))


def _spatially_renumbered(m: MeshArrays):
    """Packed node data and a copy of the mesh with triangles and nodes renumbered in bucket order, so
    that neighbouring triangles (and their nodes) are neighbours in memory; the field is unchanged."""
    cx = m.node_x[m.triangles].mean(axis=1)
    cy = m.node_y[m.triangles].mean(axis=1)
    tri = m.triangles[_bucket_order(cx, cy, m.bucket_x0, m.bucket_y0, m.bucket_size, m.bucket_nx, m.bucket_ny)]
    used, first = np.unique(tri.ravel(), return_index=True)
    node_order = used[np.argsort(first, kind="stable")]
    new_index = np.full(m.node_x.size, -1, dtype=np.int64)
    new_index[node_order] = np.arange(node_order.size)
    tri = np.ascontiguousarray(new_index[tri])
    pack = np.ascontiguousarray(np.column_stack([a[node_order] for a in (m.node_x, m.node_y, m.bed, m.depth, m.u, m.v)]))
    bstart, bitems = _build_buckets(pack[:, 0].copy(), pack[:, 1].copy(), tri, m.bucket_x0, m.bucket_y0, m.bucket_size,
                                    m.bucket_nx, m.bucket_ny)
    return pack, m._replace(triangles=tri, bucket_start=bstart, bucket_items=bitems)


@SAMPLING_METHODS.register("bilinear")
class LinearInterpolation:
    """Bilinear on grids, barycentric on triangle meshes (bulk kernels over a packed copy of the fields)."""

    def __init__(self, sampler: FieldSampler):
        self.s = sampler
        if sampler.kind == "grid":
            g = sampler._grid
            self.pack = np.ascontiguousarray(np.stack([g.bed, g.depth, g.u, g.v], axis=-1))
        else:
            self.pack, self.mesh = _spatially_renumbered(sampler._mesh)

    def sample(self, px, py, radius):
        ob, oh, ou, ov, ins = out = _outputs(px.size)
        if self.s.kind == "grid":
            g = self.s._grid
            _grid_bilinear_packed(self.pack, g.x0, g.y0, g.dx, g.dy, px, py, ob, oh, ou, ov, ins)
        else:
            m = self.mesh
            _mesh_barycentric_packed(self.pack, m.triangles, m.bucket_x0, m.bucket_y0, m.bucket_size, m.bucket_nx,
                                     m.bucket_ny, m.bucket_start, m.bucket_items, px, py,
                                     self.s.locality_order(px, py), ob, oh, ou, ov, ins)
        return out


SAMPLING_METHODS.register("barycentric", LinearInterpolation)
SAMPLING_METHODS.register("linear", LinearInterpolation)


@SAMPLING_METHODS.register("neighbourhood")
class NeighbourhoodAverage:
    """Report Fig 4.4: mean over gridpoints within ``max(radius, s_max)`` of the particle centre."""

    def __init__(self, sampler: FieldSampler):
        self.s = sampler

    def sample(self, px, py, radius):
        ob, oh, ou, ov, ins = out = _outputs(px.size)
        if self.s.kind == "grid":
            _grid_neighbourhood_many(*self.s._grid, px, py, radius, self.s.s_max, self.s.locality_order(px, py),
                                     ob, oh, ou, ov, ins)
        else:
            nstart, nitems = self.s.node_buckets()
            _mesh_neighbourhood_many(*self.s._mesh, nstart, nitems, px, py, radius, self.s.s_max,
                                     self.s.locality_order(px, py), ob, oh, ou, ov, ins)
        return out


SAMPLING_METHODS.register("neighborhood", NeighbourhoodAverage)


def uniform_snapshot(depth, u=0.0, v=0.0, bed=0.0, extent=(-50.0, 50.0, -50.0, 50.0), spacing=1.0,
                     **kwargs) -> xr.Dataset:
    """A valid grid snapshot of still / uniform water for tests and examples.

    Cell centres run from ``x0`` to ``x1`` and ``y0`` to ``y1`` (inclusive, *spacing* apart), so the whole
    *extent* is inside the field. Values may carry units (``"2 m"``, ``"1 ft/s"``); bare numbers are SI.
    They may also be arrays broadcastable to ``(ny, nx)``. Extra keyword arguments go to
    :func:`~breachflow.hydro.snapshot.grid_snapshot`.
    """
    from ..units import to_si
    from .snapshot import grid_snapshot

    x0, x1, y0, y1 = (to_si(e, name="extent", kind="length", default_unit="m") for e in extent)
    ds_ = to_si(spacing, name="spacing", kind="length", default_unit="m", positive=True)
    dxs, dys = (float(ds_), float(ds_)) if np.ndim(ds_) == 0 else (float(ds_[0]), float(ds_[1]))
    if x1 < x0 or y1 < y0:
        raise InputError(f"extent {extent!r} must be (x0, x1, y0, y1) with x1 >= x0 and y1 >= y0")
    nx = int(round((x1 - x0) / dxs)) + 1
    ny = int(round((y1 - y0) / dys)) + 1
    x = x0 + dxs * np.arange(nx)
    y = y0 + dys * np.arange(ny)
    shape = (ny, nx)
    h = np.broadcast_to(to_si(depth, name="depth", kind="length", default_unit="m", nonnegative=True), shape)
    uu = np.broadcast_to(to_si(u, name="u", kind="speed", default_unit="m/s"), shape)
    vv = np.broadcast_to(to_si(v, name="v", kind="speed", default_unit="m/s"), shape)
    b = np.broadcast_to(to_si(bed, name="bed", kind="length", default_unit="m"), shape)
    kwargs.setdefault("source", "breachflow.hydro.sampling.uniform_snapshot")
    return grid_snapshot(x, y, b, h, uu, vv, **kwargs)
