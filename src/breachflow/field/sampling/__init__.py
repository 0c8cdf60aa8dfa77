"""Sampling a hydrodynamic snapshot at particle positions (docs/theory.md, *Fluid forces on a mass*, report Fig 4.4).

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
at or below :data:`~breachflow.field.snapshot.DRY_DEPTH` the point is dry: depth 0 and u = v = 0.
Points outside the field get ``inside=False`` and NaN values (never extrapolated) unless the sampler has
a *fallback* field: ``FieldSampler(local, fallback=regional)`` samples *regional* (a snapshot or a
sampler, same method) where a point lies outside *local* — the nested solver's local grid inside the
ingested regional model (``solver = "nested"``, :mod:`breachflow.hydro.nested`): outside the local
box the field is the regional one as ingested. A grid covers its
cells' footprint, i.e. half a spacing beyond the outermost cell centres; in that border strip the
bilinear weights are clamped to the outermost centres (the cell value, no extrapolation).

The hot loops are numba kernels over plain arrays; :meth:`FieldSampler.grid_arrays` and
:meth:`FieldSampler.mesh_arrays` expose those arrays so that other numba kernels can call
``grid_bilinear_point`` / ``mesh_barycentric_point`` directly without Python.

Layout of the package (every public name is importable from here, where it is documented): this module
holds the public API (:class:`FieldSampler`, :class:`FieldSample`); :mod:`~breachflow.field.sampling.arrays`
the raw arrays of one time step that the kernels take; :mod:`~breachflow.field.sampling.grid_kernels` and
:mod:`~breachflow.field.sampling.mesh_kernels` the numba kernels of structured grids and of triangle meshes
with their bucket locator; :mod:`~breachflow.field.sampling.methods` the registry and its methods;
:mod:`~breachflow.field.sampling.uniform` :func:`uniform_snapshot`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...errors import InputError
from ...registry import Registry
from ..snapshot import is_mesh
from .arrays import GridArrays, MeshArrays
from .grid_kernels import grid_bilinear_point, grid_neighbourhood_point
from .mesh_kernels import _bucket_nodes, _bucket_order, _build_buckets, mesh_barycentric_point, mesh_locate
from .methods import SAMPLING_METHODS, LinearInterpolation, NeighbourhoodAverage
from .uniform import uniform_snapshot

__all__ = [
    "FieldSampler", "FieldSample", "GridArrays", "MeshArrays", "SAMPLING_METHODS", "uniform_snapshot",
    "grid_bilinear_point", "grid_neighbourhood_point", "mesh_barycentric_point", "mesh_locate",
]

# documented here, its public home (Sphinx reads a ``#:`` comment from the module that assigns the name)
#: Sampling methods by name; a plug-in is a class ``Method(sampler)`` with
#: ``sample(px, py, radius) -> (bed, depth, u, v, inside)`` over 1-D float64 arrays.
SAMPLING_METHODS: Registry = SAMPLING_METHODS


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

    def __init__(self, snapshot: xr.Dataset, method: str = SAMPLING_METHODS.default, time_index: int | None = None, *,
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
        from ..snapshot import mesh_triangles

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
