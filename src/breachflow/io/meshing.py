"""Grid snapshot → triangle-mesh snapshot, for writing our own results in mesh formats (ADH/SMS).

:func:`to_unaligned_mesh` builds a Delaunay triangulation (``scipy.spatial.Delaunay``) of a jittered,
rotated lattice of nodes that is *not* aligned with the grid, plus nodes along the domain boundary, and
interpolates the snapshot to the nodes bilinearly (:class:`~breachflow.field.sampling.FieldSampler`
``"bilinear"``: ``f(x, y) = Σ w_k f_k`` over the four surrounding cell centres, exact for fields linear
in x and y). It stands in for the mesh of another model (ADH, SMS, HEC-RAS 2-D) when tests need an
"ingested" snapshot built from our own SWE results. :func:`grid_to_mesh` is the aligned counterpart:
nodes at the cell centres, two triangles per square of four centres, values copied exactly.

Both cover the rectangle of the cell centres (interpolation never extrapolates) and drop triangles
whose centroid lies in an ``obstacle`` cell (a no-flow levee becomes a hole in the mesh, as in a mesh
built for ADH).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from ..field.snapshot import is_mesh, mesh_snapshot


def _grid_axes(snapshot: xr.Dataset):
    if is_mesh(snapshot):
        raise InputError("expected a grid snapshot (dims y, x), got a mesh snapshot")
    x = np.asarray(snapshot["x"].values, dtype=float)
    y = np.asarray(snapshot["y"].values, dtype=float)
    if x.size < 2 or y.size < 2:
        raise InputError(f"grid snapshot needs at least 2 x 2 cells, has {x.size} x {y.size}")
    return x, y


def _steps(snapshot: xr.Dataset):
    return list(range(snapshot.sizes["time"])) if "time" in snapshot["depth"].dims else [None]


def _drop_obstacles(snapshot, px, py, tri, x, y):
    if "obstacle" not in snapshot.variables:
        return tri
    obs = np.asarray(snapshot["obstacle"].transpose("y", "x").values).astype(bool)
    if not obs.any():
        return tri
    cx, cy = px[tri].mean(axis=1), py[tri].mean(axis=1)
    i = np.clip(np.rint((cx - x[0]) / (x[1] - x[0])).astype(int), 0, x.size - 1)
    j = np.clip(np.rint((cy - y[0]) / (y[1] - y[0])).astype(int), 0, y.size - 1)
    return tri[~obs[j, i]]


def _build(snapshot, px, py, tri, *, source: str, attrs: dict) -> xr.Dataset:
    """Mesh snapshot with values sampled bilinearly at the nodes, for every time step."""
    from ..field.sampling import FieldSampler

    used = np.unique(tri)
    remap = np.full(px.size, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    px, py, tri = px[used], py[used], remap[tri]
    # anticlockwise (UGRID)
    a, b, c = tri.T
    area2 = (px[b] - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (py[b] - py[a])
    tri[area2 < 0] = tri[area2 < 0][:, ::-1]
    depth, u, v, bed = [], [], [], None
    for k in _steps(snapshot):
        s = FieldSampler(snapshot, "bilinear", time_index=k).sample(px, py)
        if not s.inside.all():  # pragma: no cover - nodes are inside the cell-centre rectangle by construction
            raise InputError("mesh node outside the grid snapshot")
        bed = s.bed
        depth.append(s.depth)
        u.append(s.u)
        v.append(s.v)
    timed = _steps(snapshot)[0] is not None
    pick = (lambda a: np.stack(a)) if timed else (lambda a: a[0])
    crs = snapshot["crs"].attrs.get("crs_wkt") if "crs" in snapshot.variables else None
    ds = mesh_snapshot(px, py, tri, bed, pick(depth), pick(u), pick(v),
                       time=snapshot["time"].values if timed else None, crs_wkt=crs, source=source,
                       node_ids=np.arange(1, px.size + 1), face_ids=np.arange(1, tri.shape[0] + 1),
                       face_material=np.ones(tri.shape[0], dtype=np.int32))
    ds.attrs.update(attrs)
    return ds


def to_unaligned_mesh(snapshot: xr.Dataset, n_nodes: int | None = None, seed: int = 0, *,
                      rotation: float | None = None, jitter: float = 0.25) -> xr.Dataset:
    """Triangulate a grid snapshot onto an unaligned triangle mesh of about *n_nodes* nodes.

    Interior nodes form a square lattice of spacing ``s = sqrt(A / n_nodes)`` rotated by *rotation*
    degrees (default: drawn from 10°–35° with *seed*) with each node moved by a uniform random offset of
    up to ``jitter · s`` per axis; boundary nodes are spaced about ``s`` along the rectangle of cell
    centres (corners included), so the triangulation covers that rectangle exactly. Values (bed, depth,
    u, v; every time step) are bilinear interpolations of the grid at the nodes. Default *n_nodes*: the
    number of grid cells. Deterministic for a given *seed*.
    """
    x, y = _grid_axes(snapshot)
    if n_nodes is None:
        n_nodes = x.size * y.size
    n_nodes = int(n_nodes)
    if n_nodes < 4:
        raise InputError(f"n_nodes={n_nodes}: need at least 4 nodes")
    if not 0.0 <= jitter < 0.5:
        raise InputError(f"jitter={jitter}: must be in [0, 0.5) lattice spacings")
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    theta = np.deg2rad(rng.uniform(10.0, 35.0) if rotation is None else float(rotation))
    x0, x1, y0, y1 = x[0], x[-1], y[0], y[-1]
    lx, ly = x1 - x0, y1 - y0
    s = np.sqrt(lx * ly / n_nodes)
    # boundary nodes (each side split into equal parts of about s)
    nbx, nby = max(int(np.ceil(lx / s)), 1), max(int(np.ceil(ly / s)), 1)
    tx, ty = np.linspace(x0, x1, nbx + 1), np.linspace(y0, y1, nby + 1)
    bx = np.concatenate([tx, tx, np.full(nby - 1, x0), np.full(nby - 1, x1)])
    by = np.concatenate([np.full(nbx + 1, y0), np.full(nbx + 1, y1), ty[1:-1], ty[1:-1]])
    # rotated, jittered lattice covering the rectangle; keep nodes at least s/2 inside the boundary
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    r = 0.5 * np.hypot(lx, ly) + s
    k = np.arange(-np.ceil(r / s), np.ceil(r / s) + 1) * s
    gx, gy = np.meshgrid(k, k)
    gx = gx.ravel() + rng.uniform(-jitter, jitter, gx.size) * s
    gy = gy.ravel() + rng.uniform(-jitter, jitter, gy.size) * s
    px = cx + gx * np.cos(theta) - gy * np.sin(theta)
    py = cy + gx * np.sin(theta) + gy * np.cos(theta)
    m = 0.5 * s
    keep = (px > x0 + m) & (px < x1 - m) & (py > y0 + m) & (py < y1 - m)
    px = np.concatenate([bx, px[keep]])
    py = np.concatenate([by, py[keep]])
    tri = Delaunay(np.column_stack([px, py])).simplices.astype(np.int64)
    a, b, c = tri.T
    area2 = (px[b] - px[a]) * (py[c] - py[a]) - (px[c] - px[a]) * (py[b] - py[a])
    tri = tri[np.abs(area2) > 1e-9 * s * s]
    tri = _drop_obstacles(snapshot, px, py, tri, x, y)
    return _build(snapshot, px, py, tri, source="breachflow grid snapshot interpolated onto an unaligned triangle mesh",
                  attrs=dict(mesh_generator="breachflow.io.to_unaligned_mesh", mesh_seed=int(seed),
                             mesh_rotation_deg=float(np.rad2deg(theta)), mesh_spacing_m=float(s),
                             mesh_interpolation="bilinear from the grid cell centres"))


def grid_to_mesh(snapshot: xr.Dataset) -> xr.Dataset:
    """The aligned mesh of a grid snapshot: nodes at the cell centres, two triangles per square of four
    centres (values copied, no interpolation); triangles in obstacle cells are dropped."""
    x, y = _grid_axes(snapshot)
    nx, ny = x.size, y.size
    gx, gy = np.meshgrid(x, y)
    px, py = gx.ravel(), gy.ravel()
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tri = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])]).astype(np.int64)
    tri = _drop_obstacles(snapshot, px, py, tri, x, y)
    return _build(snapshot, px, py, tri, source="breachflow grid snapshot on the mesh of its cell centres",
                  attrs=dict(mesh_generator="breachflow.io.grid_to_mesh", mesh_interpolation="none (nodes at cell centres)"))
