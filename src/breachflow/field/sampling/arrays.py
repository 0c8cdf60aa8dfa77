"""The raw arrays of one grid or mesh time step (:class:`~breachflow.field.sampling.GridArrays`,
:class:`~breachflow.field.sampling.MeshArrays`, with the mesh's bucket-grid triangle locator) that the
numba kernels take; :meth:`~breachflow.field.sampling.FieldSampler.grid_arrays` and
:meth:`~breachflow.field.sampling.FieldSampler.mesh_arrays` hand them to other kernels."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


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
