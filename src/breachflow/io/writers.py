"""Writers: a snapshot back into the text formats the readers take (users hand our results to their
ADH / SMS / HEC-RAS / GIS workflow; tests build "ingested" inputs from our own SWE results).

``write_adh(snapshot, prefix)``   ``PREFIX.3dm`` (bed z at nodes), ``PREFIX_dep.dat``, ``PREFIX_vel.dat``
                                  and ``PREFIX.bc`` (``MP G`` telling the length unit); as ADH writes them
                                  (+ ``PREFIX.prj`` with a CRS)
``write_esri(snapshot, prefix)``  ``PREFIX_depth.asc``, ``_wse.asc``, ``_terrain.asc``, ``_vx.asc``,
                                  ``_vy.asc`` (+ ``.prj`` when the snapshot has a CRS); one time step
``write_sdf(snapshot, path)``     a HEC-RAS GIS export (``RASExport.sdf``): cross sections cut through the
                                  field, see :mod:`breachflow.io.sdf_writer`

Values are written in the file unit *units* (``"m"`` or ``"ft"``; velocities in unit/s) with the text
precision of the tools (``%16.8e`` in ``.dat`` files, 12 significant digits for coordinates). All
files of one call are written to temporary files first and renamed together at the end, so an error
leaves no half-written set.
"""
from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from ..field.snapshot import is_mesh, mesh_face_nodes, node_coordinates


def _unit_factor(units) -> float:
    from ..units import ureg

    try:
        q = ureg.Quantity(1.0, str(units))
        f = float(q.to("m").magnitude)
    except Exception:
        raise InputError(f"units={units!r}: not a length unit (use 'm' or 'ft')") from None
    return 1.0 / f


def prj_text(crs_wkt: str, units: str) -> str:
    """``.prj`` text of the snapshot CRS (metre axes) with the axes in the files' length unit *units*, so
    a reader checks and reads the coordinates in the unit they are written in."""
    from pyproj import CRS
    from pyproj.crs import ProjectedCRS
    from pyproj.crs.coordinate_system import Cartesian2DCS
    from pyproj.crs.enums import Cartesian2DCSAxis

    k = _unit_factor(units)
    c = CRS.from_user_input(crs_wkt)
    if abs(k - 1.0) < 1e-12:
        return c.to_wkt()
    if not c.is_projected:
        raise InputError(f"units={units!r}: the snapshot's CRS {c.name!r} is not projected; write in metres")
    axis = {3.2808398950131235: Cartesian2DCSAxis.EASTING_NORTHING_FT,
            3.280833333333333: Cartesian2DCSAxis.EASTING_NORTHING_US_FT}
    hit = [a for f, a in axis.items() if abs(f - k) < 1e-9 * k]
    if not hit:
        raise InputError(f"units={units!r}: a CRS can be written only in m, ft or survey_foot")
    return ProjectedCRS(conversion=c.coordinate_operation, geodetic_crs=c.geodetic_crs,
                        cartesian_cs=Cartesian2DCS(hit[0]), name=c.name).to_wkt()


def _write_all(files: dict) -> list[Path]:
    """Write ``{path: text or iterable of text chunks}`` atomically as a set (temporary files renamed only
    when all succeeded); chunks keep the memory of large meshes near one time step's text."""
    from ..atomic import atomic_path

    with contextlib.ExitStack() as stack:
        for path, text in files.items():
            tmp = stack.enter_context(atomic_path(path))
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                for chunk in ([text] if isinstance(text, str) else text):
                    fh.write(chunk)
    return list(files)


CHUNK_ROWS = 100_000


def _times(ds: xr.Dataset):
    """(times in seconds since the first/reference time, RT_JULIAN or None) for the ``time`` axis."""
    if "time" not in ds["depth"].dims:
        return np.zeros(1), None
    t = ds["time"].values
    if np.issubdtype(t.dtype, np.datetime64):
        t0 = t[0].astype("datetime64[ms]")
        secs = (t.astype("datetime64[ms]") - t0).astype(np.int64) / 1e3
        jd = t0.astype(np.int64) / 1e3 / 86400.0 + 2440587.5
        return secs, jd
    return np.asarray(t, dtype=float), None


def _step_values(da: xr.DataArray) -> np.ndarray:
    a = np.asarray(da.values, dtype=float)
    return a[None] if "time" not in da.dims else a


def _fmt_block(values: np.ndarray):
    """One ``%16.8e`` row per node (ADH's format), in chunks of text; *values* is ``(n,)`` or ``(n, k)``."""
    v = np.atleast_2d(values.T).T if values.ndim == 1 else values
    fmt = " ".join(["%16.8e"] * v.shape[1]) + "\n"
    for a in range(0, v.shape[0], CHUNK_ROWS):
        part = v[a:a + CHUNK_ROWS]
        yield (fmt * part.shape[0]) % tuple(part.ravel().tolist())  # one C-level format per chunk


def adh_texts(snapshot: xr.Dataset, prefix, *, units: str = "m", name: str | None = None) -> dict:
    """The ``{path: text or generator of text chunks}`` of :func:`write_adh` (without writing)."""
    ds = snapshot
    if not is_mesh(ds):
        from .meshing import grid_to_mesh

        ds = grid_to_mesh(ds)
    prefix = Path(prefix)
    k = _unit_factor(units)
    x, y = node_coordinates(ds)
    faces = mesh_face_nodes(ds)
    bed = np.asarray(ds["bed_elevation"].values, dtype=float)
    n_node, n_face = x.size, faces.shape[0]
    mat = np.asarray(ds["material"].values, dtype=int) if "material" in ds.variables else np.ones(n_face, int)
    mat = np.where(mat >= 1, mat, 1)
    def mesh():  # elements before nodes, as ADH writes them; ids 1..n in the snapshot's node order
        yield f'MESH2D\nMESHNAME "{name or prefix.name}"\n'
        for a in range(0, n_face, CHUNK_ROWS):
            lines = []
            for e, row, m in zip(range(a, a + CHUNK_ROWS), faces[a:a + CHUNK_ROWS].tolist(), mat[a:a + CHUNK_ROWS].tolist()):
                f = [i + 1 for i in row if i >= 0]
                lines.append(f"{'E3T' if len(f) == 3 else 'E4Q'} {e + 1} {' '.join(map(str, f))} {m}")
            yield "\n".join(lines) + "\n"
        for a in range(0, n_node, CHUNK_ROWS):
            rows = zip(range(a + 1, a + CHUNK_ROWS + 1), (x[a:a + CHUNK_ROWS] * k).tolist(), (y[a:a + CHUNK_ROWS] * k).tolist(),
                       (bed[a:a + CHUNK_ROWS] * k).tolist())
            flat = [v for r in rows for v in r]
            yield ("ND %d %.12g %.12g %.12g\n" * (len(flat) // 4)) % tuple(flat)

    secs, jd = _times(ds)
    head = ["DATASET", 'OBJTYPE "mesh2d"']

    def dataset(kind, title, step):
        out = head + [kind] + (["VECTYPE 0"] if kind == "BEGVEC" else []) + [f"ND {n_node}", f"NC {n_face}", f'NAME "{title}"']
        if jd is not None:
            out.append(f"RT_JULIAN {jd:.8f}")
        out.append("TIMEUNITS SECONDS")
        yield "\n".join(out) + "\n"
        for i, t in enumerate(secs):
            yield f"TS 0 {t:16.8e}\n"
            yield from _fmt_block(step(i))
        yield "ENDDS\n"

    depth = _step_values(ds["depth"])
    u, v = _step_values(ds["u"]), _step_values(ds["v"])
    dep = dataset("BEGSCL", "Depth", lambda i: depth[i] * k)
    vel = dataset("BEGVEC", "Depth-Averaged Velocity", lambda i: np.column_stack([u[i] * k, v[i] * k, np.zeros(n_node)]))
    g = 9.81 if abs(k - 1.0) < 1e-12 else 9.80665 * k
    bc = "\n".join([
        "! ADH boundary-condition file written by breachflow: units and output times only (not a model setup)",
        "OP SW2",
        f"! G = {g:.6g} tells the length unit ({units}) to readers of these files",
        f"MP G {g:.6g}",
        "MP RHO 1000.0",
        f"TC T0 {secs[0]:.9g} 0",
        f"TC TF {secs[-1]:.9g} 0",
        "END",
    ]) + "\n"
    stem = prefix.name
    d = prefix.parent
    out = {d / f"{stem}.3dm": mesh(), d / f"{stem}_dep.dat": dep, d / f"{stem}_vel.dat": vel, d / f"{stem}.bc": bc}
    crs = ds["crs"].attrs.get("crs_wkt") if "crs" in ds.variables else None
    if crs:
        out[d / f"{stem}.prj"] = prj_text(crs, units) + "\n"
    return out


def write_adh(snapshot: xr.Dataset, prefix, *, units: str = "m", name: str | None = None) -> list[Path]:
    """Write *snapshot* as ADH/SMS text files ``PREFIX.3dm``, ``PREFIX_dep.dat``, ``PREFIX_vel.dat``,
    ``PREFIX.bc`` (and ``PREFIX.prj`` when the snapshot has a CRS, its axes in *units*) and return their
    paths (read back with ``open_snapshot(paths)``).

    A mesh snapshot is written on its own mesh; a grid snapshot on the mesh of its cell centres
    (:func:`~breachflow.io.meshing.grid_to_mesh`; use :func:`~breachflow.io.meshing.to_unaligned_mesh` first for a mesh
    not aligned with the grid). Dry nodes get depth 0 and velocity 0. Times are seconds (``TIMEUNITS
    SECONDS``) from the snapshot's time axis, with ``RT_JULIAN`` when it holds dates.
    """
    return _write_all(adh_texts(snapshot, prefix, units=units, name=name))


#: ESRI grid file suffix per snapshot role (the ``asc`` reader recognises these names)
ESRI_ROLES = {"depth": "depth", "water_surface": "wse", "bed": "terrain", "u": "vx", "v": "vy"}


def esri_texts(snapshot: xr.Dataset, prefix, *, units: str = "m", time_index: int = -1,
               nodata: float = -9999.0) -> dict:
    """The ``{path: text}`` of :func:`write_esri` (without writing)."""
    if is_mesh(snapshot):
        raise InputError("ESRI ASCII grids need a grid snapshot; this one is a mesh")
    k = _unit_factor(units)
    x = np.asarray(snapshot["x"].values, dtype=float)
    y = np.asarray(snapshot["y"].values, dtype=float)
    if x.size < 2 or y.size < 2:
        raise InputError("ESRI ASCII grids need at least 2 x 2 cells")
    dx, dy = np.diff(x), np.diff(y)
    if not (np.allclose(dx, dx[0], rtol=1e-9) and np.allclose(dy, dy[0], rtol=1e-9)) or dx[0] <= 0 or dy[0] <= 0:
        raise InputError("ESRI ASCII grids need uniformly spaced ascending x and y")
    dx, dy = dx[0], dy[0]

    def field(name):
        da = snapshot[name]
        if "time" in da.dims:
            da = da.isel(time=time_index)
        return np.asarray(da.transpose("y", "x").values, dtype=float)

    wet = field("depth") > 0.0
    grids = {"depth": np.where(wet, field("depth"), np.nan), "water_surface": np.where(wet, field("water_surface"), np.nan),
             "bed": field("bed_elevation"), "u": np.where(wet, field("u"), np.nan), "v": np.where(wet, field("v"), np.nan)}
    size = f"cellsize     {dx * k:.12g}" if abs(dx - dy) <= 1e-9 * dx else f"dx           {dx * k:.12g}\ndy           {dy * k:.12g}"
    header = (f"ncols        {x.size}\nnrows        {y.size}\nxllcorner    {(x[0] - dx / 2) * k:.12g}\n"
              f"yllcorner    {(y[0] - dy / 2) * k:.12g}\n{size}\nNODATA_value {nodata:g}\n")
    crs = snapshot["crs"].attrs.get("crs_wkt") if "crs" in snapshot.variables else None
    prefix = Path(prefix)
    out = {}
    for role, suffix in ESRI_ROLES.items():
        a = grids[role][::-1] * k  # first row = northern
        rows = "\n".join(" ".join(nodata_fmt(v, nodata) for v in r) for r in a)
        p = prefix.parent / f"{prefix.name}_{suffix}.asc"
        out[p] = header + rows + "\n"
        if crs:
            out[p.with_suffix(".prj")] = prj_text(crs, units) + "\n"
    return out


def nodata_fmt(v: float, nodata: float) -> str:
    return f"{nodata:g}" if not np.isfinite(v) else f"{v:.9g}"


def write_esri(snapshot: xr.Dataset, prefix, *, units: str = "m", time_index: int = -1,
               nodata: float = -9999.0) -> list[Path]:
    """Write one time step of a grid snapshot as ESRI ASCII grids ``PREFIX_{depth,wse,terrain,vx,vy}.asc``
    (as RAS Mapper maps converted with GDAL: dry cells are NODATA except in the terrain) and a ``.prj``
    beside each when the snapshot has a CRS. Returns the paths (read back with ``open_snapshot(paths,
    units=...)``; the reader tells the roles from these names)."""
    return _write_all(esri_texts(snapshot, prefix, units=units, time_index=time_index, nodata=nodata))
