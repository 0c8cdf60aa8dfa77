"""An ingested-model stand-in for tests: a grid snapshot re-sampled onto a triangulated mesh that is not
aligned with the grid (rotated, jittered nodes; Delaunay), triangles whose centroid lies in an
obstacle cell (the intact levee) left out as holes, as the report's ADH mesh has them."""
import numpy as np
from scipy.spatial import Delaunay

from breachflow.field.sampling import FieldSampler
from breachflow.field.snapshot import mesh_snapshot


def unaligned_mesh(grid, spacing: float, *, angle_deg: float = 17.0, jitter: float = 0.3, seed: int = 0):
    x, y = grid.x.values, grid.y.values
    dx = x[1] - x[0]
    x0, x1, y0, y1 = x[0] - dx / 2, x[-1] + dx / 2, y[0] - dx / 2, y[-1] + dx / 2
    rng = np.random.default_rng(seed)
    R = np.hypot(x1 - x0, y1 - y0)
    a, b = np.meshgrid(np.arange(-R, R, spacing), np.arange(-R, R, spacing * np.sqrt(3) / 2))
    a = a + (np.arange(a.shape[0])[:, None] % 2) * spacing / 2  # triangular lattice
    a = a + rng.uniform(-jitter, jitter, a.shape) * spacing
    b = b + rng.uniform(-jitter, jitter, b.shape) * spacing
    t = np.radians(angle_deg)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    px, py = cx + a * np.cos(t) - b * np.sin(t), cy + a * np.sin(t) + b * np.cos(t)
    keep = (px >= x0 + 1e-6) & (px <= x1 - 1e-6) & (py >= y0 + 1e-6) & (py <= y1 - 1e-6)
    px, py = px[keep], py[keep]
    # the grid's outline as nodes too, so the mesh covers the same extent
    ex = np.arange(x0, x1 + 1e-9, spacing)
    ey = np.arange(y0, y1 + 1e-9, spacing)
    px = np.concatenate([px, ex, ex, np.full(ey.size, x0), np.full(ey.size, x1)])
    py = np.concatenate([py, np.full(ex.size, y0), np.full(ex.size, y1), ey, ey])
    # the holes' outline as nodes (a mesh built to the levee, as ADH meshes are): corners of obstacle cells
    ob = grid["obstacle"].values.astype(bool) if "obstacle" in grid else np.zeros(grid.depth.shape, bool)
    if ob.any():
        jj, ii = np.nonzero(ob)
        cx_ = np.concatenate([x0 + ii * dx, x0 + (ii + 1) * dx, x0 + ii * dx, x0 + (ii + 1) * dx])
        cy_ = np.concatenate([y0 + jj * dx, y0 + jj * dx, y0 + (jj + 1) * dx, y0 + (jj + 1) * dx])
        corners = np.unique(np.round(np.c_[cx_, cy_], 6), axis=0)
        from scipy.spatial import cKDTree

        far = cKDTree(corners).query(np.c_[px, py])[0] > 0.35 * spacing
        px, py = np.concatenate([px[far], corners[:, 0]]), np.concatenate([py[far], corners[:, 1]])
    tri = Delaunay(np.c_[px, py]).simplices
    # holes: triangles whose centroid lies in an obstacle cell of the grid
    def cell(xq, yq):
        i = np.clip(((xq - x0) / dx).astype(int), 0, x.size - 1)
        j = np.clip(((yq - y0) / dx).astype(int), 0, y.size - 1)
        return ob[j, i]
    cxs, cys = px[tri].mean(axis=1), py[tri].mean(axis=1)
    bad = cell(cxs, cys)
    tri = tri[~bad]
    used = np.unique(tri)
    remap = -np.ones(px.size, int)
    remap[used] = np.arange(used.size)
    px, py, tri = px[used], py[used], remap[tri]
    # counter-clockwise
    area = (px[tri[:, 1]] - px[tri[:, 0]]) * (py[tri[:, 2]] - py[tri[:, 0]]) - (px[tri[:, 2]] - px[tri[:, 0]]) * (py[tri[:, 1]] - py[tri[:, 0]])
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    from breachflow.hydro.nested import fill_obstacles

    smp = FieldSampler(fill_obstacles(grid), "bilinear").sample(px, py)
    depth = np.nan_to_num(smp.depth)
    return mesh_snapshot(px, py, tri, np.nan_to_num(smp.bed), depth, np.nan_to_num(smp.u), np.nan_to_num(smp.v),
                         source="test: grid steady state on an unaligned triangulated mesh")
