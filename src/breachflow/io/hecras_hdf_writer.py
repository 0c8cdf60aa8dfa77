"""Write a snapshot as a HEC-RAS 6 2-D results (plan) HDF file (``write_hecras_hdf``; needs ``h5py``,
``pip install breachflow[hecras]``): users hand our results back to RAS Mapper / rashdf workflows, and
tests build "ingested" HEC-RAS input from our own SWE results.

The layout is the one the ``hecras_hdf`` reader (:mod:`breachflow.io.hecras_hdf`) and rashdf read
(HEC-RAS 6 plan file, one 2-D flow area):

* root attributes ``File Type`` (``HEC-RAS Results``), ``Units System`` (``SI Units`` | ``US Customary``),
  ``Projection`` (WKT, axes in the file unit) when the snapshot has a CRS;
* ``Geometry/2D Flow Areas/Attributes`` (``Name``, ``Mann``, ``Cell Count``) and per area ``Cells Center
  Coordinate``, ``Cells Minimum Elevation`` (ghost cells beyond ``Cell Count``: NaN, as HEC-RAS writes),
  ``FacePoints Coordinate``, ``Faces FacePoint Indexes``, ``Faces Cell Indexes`` (the second cell of a
  perimeter face is its ghost cell), ``Faces NormalUnitVector and Length`` (normal from the first cell to
  the second), ``Cells Face and Orientation Info`` / ``Values``;
* ``Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series``: ``Time Date Stamp (ms)``
  (``01JAN2000 00:00:00:000``), ``Time`` (days), and per area ``Water Surface`` (time × cells + ghosts),
  ``Face Velocity`` (time × faces, the velocity component along the face normal) and, with
  ``cell_velocity=True``, ``Cell Velocity - Velocity X`` / ``Y``.

Cells: the snapshot's triangles (a grid snapshot is first put on the mesh of its cell centres,
:func:`~breachflow.io.meshing.grid_to_mesh`; use :func:`~breachflow.io.meshing.to_unaligned_mesh`
for a mesh not aligned with it), face points its nodes, faces its edges. Values are the linear
(barycentric) field of the snapshot: cell bed and depth at the centroid (mean of the three nodes, water
surface = bed + depth; a dry cell gets its bed), face velocity ``V_f = n_f · (u_p + u_q) / 2`` at the edge
midpoint. Mesh holes (a no-flow levee) stay holes: their edges are perimeter faces. Written to a temporary
file and renamed, so an error leaves nothing half-written.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from ..field.snapshot import is_mesh, mesh_face_nodes, node_coordinates
from .writers import _step_values, _times, _unit_factor, prj_text

AREAS = "Geometry/2D Flow Areas"
SERIES = "Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series"


def _import_h5py():
    try:
        import h5py
    except ImportError:
        raise InputError("writing HEC-RAS HDF files needs the optional package h5py: pip install 'breachflow[hecras]'") from None
    return h5py


def _edges(tri: np.ndarray):
    """Unique edges ``(p, q)`` of triangles *tri* and the one or two triangles on each (``-1``: none),
    the first being the triangle that has the edge anticlockwise as ``p → q``."""
    n = tri.shape[0]
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    owner = np.tile(np.arange(n), 3)
    key = np.sort(e, axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    cells = np.full((uniq.shape[0], 2), -1, dtype=np.int64)
    pts = np.zeros((uniq.shape[0], 2), dtype=np.int64)
    order = np.argsort(inv, kind="stable")
    for k in order:  # first owner takes slot 0 with its own orientation, the second slot 1
        f = inv[k]
        if cells[f, 0] < 0:
            cells[f, 0] = owner[k]
            pts[f] = e[k]
        elif cells[f, 1] < 0:
            cells[f, 1] = owner[k]
        else:
            raise InputError(f"mesh edge {tuple(uniq[f])} is shared by more than two triangles: not a valid mesh")
    return pts, cells


def _times_ras(ds: xr.Dataset):
    secs, jd = _times(ds)
    if jd is not None:
        t0 = np.datetime64(ds["time"].values[0], "ms")
    else:
        t0 = np.datetime64("2000-01-01T00:00:00", "ms")
    stamps = []
    for s in secs:
        t = (t0 + np.timedelta64(int(round(s * 1000.0)), "ms")).astype(object)
        stamps.append(t.strftime("%d%b%Y %H:%M:%S").upper() + f":{t.microsecond // 1000:03d}")
    return secs, stamps


def write_hecras_hdf(snapshot: xr.Dataset, path, *, units: str = "m", area_name: str = "breachflow",
                     manning: float = 0.025, cell_velocity: bool = False) -> Path:
    """Write *snapshot* (mesh or grid, every time step) as a HEC-RAS 6 plan HDF with one 2-D flow area
    *area_name* (see the module doc); lengths in *units* (``"m"`` → ``SI Units``, ``"ft"`` → ``US
    Customary``). Returns the path (read back with ``open_snapshot(path)``)."""
    h5py = _import_h5py()
    from ..atomic import atomic_path

    ds = snapshot
    if not is_mesh(ds):
        from .meshing import grid_to_mesh

        ds = grid_to_mesh(ds)
    k = _unit_factor(units)
    if abs(k - 1.0) < 1e-12:
        system, lunit, vunit = "SI Units", "m", "m/s"
    elif abs(k - 3.2808398950131235) < 1e-9:
        system, lunit, vunit = "US Customary", "ft", "ft/s"
    else:
        raise InputError(f"units={units!r}: a HEC-RAS HDF is written in m (SI Units) or ft (US Customary)")
    if len(area_name.encode()) > 16:
        raise InputError(f"area_name={area_name!r}: HEC-RAS 2-D flow area names have at most 16 characters")
    x, y = node_coordinates(ds)
    faces = mesh_face_nodes(ds)
    if faces.shape[1] != 3 or (faces < 0).any():
        raise InputError("write_hecras_hdf: the mesh must consist of triangles")
    tri = faces.astype(np.int64)
    n = tri.shape[0]
    bed_n = np.asarray(ds["bed_elevation"].values, dtype=float)
    depth_n, u_n, v_n = (_step_values(ds[v]) for v in ("depth", "u", "v"))
    nt = depth_n.shape[0]
    # cells: triangle centroids (barycentric values there = means of the three nodes)
    cx, cy = x[tri].mean(axis=1), y[tri].mean(axis=1)
    bed_c = bed_n[tri].mean(axis=1)
    depth_c = np.maximum(depth_n[:, tri].mean(axis=2), 0.0)
    ws = bed_c[None, :] + depth_c
    pts, cells = _edges(tri)
    nf = pts.shape[0]
    perim = cells[:, 1] < 0
    n_ghost = int(perim.sum())
    cells[perim, 1] = n + np.arange(n_ghost)
    dx, dy = x[pts[:, 1]] - x[pts[:, 0]], y[pts[:, 1]] - y[pts[:, 0]]
    length = np.hypot(dx, dy)
    # the first cell has the edge anticlockwise p -> q, so the outward normal (from it to the second) is (dy, -dx)
    normal = np.column_stack([dy, -dx]) / length[:, None]
    um = 0.5 * (u_n[:, pts[:, 0]] + u_n[:, pts[:, 1]])
    vm = 0.5 * (v_n[:, pts[:, 0]] + v_n[:, pts[:, 1]])
    face_v = um * normal[None, :, 0] + vm * normal[None, :, 1]
    # per cell its faces (orientation +1: the cell is the face's first cell)
    fidx = np.concatenate([np.arange(nf), np.arange(nf)[~perim]])
    fcell = np.concatenate([cells[:, 0], cells[~perim, 1]])
    orient = np.concatenate([np.ones(nf, np.int32), -np.ones(int((~perim).sum()), np.int32)])
    order = np.lexsort((fidx, fcell))
    fidx, fcell, orient = fidx[order], fcell[order], orient[order]
    count = np.bincount(fcell, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    secs, stamps = _times_ras(ds)
    path = Path(path)
    crs = ds["crs"].attrs.get("crs_wkt") if "crs" in ds.variables else None
    cell_u = u_n[:, tri].mean(axis=2) if cell_velocity else None
    cell_v = v_n[:, tri].mean(axis=2) if cell_velocity else None
    dry = depth_c <= 0.0
    ghost0 = np.zeros((nt, n_ghost))
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["File Type"] = np.bytes_(b"HEC-RAS Results")
            f.attrs["File Version"] = np.bytes_(b"HEC-RAS 6.x (written by breachflow)")
            f.attrs["Units System"] = np.bytes_(system.encode())
            if crs:
                f.attrs["Projection"] = np.bytes_(prj_text(crs, units).encode())
            attrs = np.array([(area_name.encode(), manning, n)],
                             dtype=[("Name", "S16"), ("Mann", "<f4"), ("Cell Count", "<i4")])
            f.create_dataset(f"{AREAS}/Attributes", data=attrs)
            g = f"{AREAS}/{area_name}"
            # ghost cells sit at the midpoint of their perimeter face, as HEC-RAS places them
            gx = 0.5 * (x[pts[perim, 0]] + x[pts[perim, 1]])
            gy = 0.5 * (y[pts[perim, 0]] + y[pts[perim, 1]])
            f[f"{g}/Cells Center Coordinate"] = np.column_stack([np.concatenate([cx, gx]), np.concatenate([cy, gy])]) * k
            f[f"{g}/Cells Minimum Elevation"] = (np.concatenate([bed_c, np.full(n_ghost, np.nan)]) * k).astype("f4")
            f[f"{g}/FacePoints Coordinate"] = np.column_stack([x, y]) * k
            f[f"{g}/Faces FacePoint Indexes"] = pts.astype(np.int32)
            f[f"{g}/Faces Cell Indexes"] = cells.astype(np.int32)
            f[f"{g}/Faces NormalUnitVector and Length"] = np.column_stack([normal, length * k]).astype("f4")
            f[f"{g}/Cells Face and Orientation Info"] = np.vstack(
                [np.column_stack([start, count]), np.zeros((n_ghost, 2), np.int64)]).astype(np.int32)
            f[f"{g}/Cells Face and Orientation Values"] = np.column_stack([fidx, orient]).astype(np.int32)
            f.create_dataset(f"{SERIES}/Time Date Stamp (ms)", data=np.array([s.encode() for s in stamps], dtype="S24"))
            t = f.create_dataset(f"{SERIES}/Time", data=(np.asarray(secs) / 86400.0))
            t.attrs["Units"] = np.bytes_(b"days")
            base = f"{SERIES}/2D Flow Areas/{area_name}"
            wsv = np.where(dry, bed_c[None, :], ws)
            for name, data, unit in (("Water Surface", np.concatenate([wsv, ghost0], axis=1) * k, lunit),
                                     ("Face Velocity", face_v * k, vunit)):
                d = f.create_dataset(f"{base}/{name}", data=data.astype("f4"), chunks=True)
                d.attrs["Units"] = np.bytes_(unit.encode())
            if cell_velocity:
                for name, data in (("Cell Velocity - Velocity X", cell_u), ("Cell Velocity - Velocity Y", cell_v)):
                    d = f.create_dataset(f"{base}/{name}", data=(np.concatenate([data, ghost0], axis=1) * k).astype("f4"),
                                         chunks=True)
                    d.attrs["Units"] = np.bytes_(vunit.encode())
    return path
