"""The sampling methods, chosen by name from :data:`~breachflow.field.sampling.SAMPLING_METHODS`:
``bilinear`` (aliases ``barycentric``, ``linear``; bulk kernels over a packed copy of the fields, a mesh
renumbered in bucket order) and ``neighbourhood`` (alias ``neighborhood``; the report's Fig 4.4 mean)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...registry import Registry
from .arrays import MeshArrays
from .grid_kernels import _grid_bilinear_packed, _grid_neighbourhood_many
from .mesh_kernels import _bucket_order, _build_buckets, _mesh_barycentric_packed, _mesh_neighbourhood_many

if TYPE_CHECKING:
    from . import FieldSampler

#: Sampling methods by name; a plug-in is a class ``Method(sampler)`` with
#: ``sample(px, py, radius) -> (bed, depth, u, v, inside)`` over 1-D float64 arrays.
SAMPLING_METHODS: Registry = Registry("sampling method", "breachflow.sampling_methods", default="bilinear")


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
        # read-only positions (views of an xarray dataset) would be a signature of their own, compiled at run time
        px, py = (p if p.flags.writeable else p.copy() for p in (px, py))
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
