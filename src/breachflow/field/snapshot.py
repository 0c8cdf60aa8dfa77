"""The hydrodynamic snapshot Dataset: one definition of its variables, attributes and schema.

Structured grids use dims ``(y, x)`` (optionally ``(time, y, x)``) with cell-centre coordinates in
metres; the schema is ``data_schemas/snapshot_grid.json``. Unstructured meshes follow the UGRID 1.0
conventions (a ``mesh2d`` topology variable, node coordinates, ``face_node_connectivity`` with
``start_index``), values at nodes, dims ``(node,)`` or ``(time, node)``; schema ``snapshot_mesh.json``.
Everything is SI. Dry cells / nodes have ``depth == 0``, ``wet == False`` and zero velocity; the water
surface is ``bed_elevation + depth``.

:func:`check_plausibility` flags physically implausible fields (usually a unit mix-up) naming the
variable, location and value; :func:`write_snapshot` writes atomically to NetCDF after validation and
:func:`read_snapshot` reads back and validates.
"""
from __future__ import annotations

import os
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import BreachflowWarning, ImplausibleValueError, InputError, SchemaError
from ..schemas import validate

#: CF attributes of every snapshot variable (standard names only where the CF table has one).
VARIABLE_ATTRS: dict[str, dict] = {
    "x": {"standard_name": "projection_x_coordinate", "long_name": "x coordinate of cell centre", "units": "m", "axis": "X"},
    "y": {"standard_name": "projection_y_coordinate", "long_name": "y coordinate of cell centre", "units": "m", "axis": "Y"},
    "bed_elevation": {"long_name": "bed elevation above datum", "units": "m", "positive": "up"},
    "depth": {"standard_name": "sea_floor_depth_below_sea_surface", "long_name": "water depth", "units": "m"},
    "water_surface": {"standard_name": "water_surface_height_above_reference_datum", "long_name": "water-surface elevation above datum", "units": "m"},
    "u": {"standard_name": "barotropic_sea_water_x_velocity", "long_name": "x component of depth-averaged velocity", "units": "m s-1"},
    "v": {"standard_name": "barotropic_sea_water_y_velocity", "long_name": "y component of depth-averaged velocity", "units": "m s-1"},
    "wet": {"long_name": "wet cell mask (depth above the dry threshold)", "units": "1", "flag_values": np.array([0, 1], dtype="i1"), "flag_meanings": "dry wet"},
    "obstacle": {"long_name": "no-flow obstacle cell mask (placed masses, structures)", "units": "1", "flag_values": np.array([0, 1], dtype="i1"), "flag_meanings": "open blocked"},
}

#: Depth below which a cell counts as dry (m).
DRY_DEPTH = 1e-6


def grid_snapshot(
    x,
    y,
    bed_elevation,
    depth,
    u,
    v,
    *,
    obstacle=None,
    time=None,
    crs_wkt: str | None = None,
    source: str = "",
    source_files=(),
    extra: dict | None = None,
    check: bool = True,
) -> xr.Dataset:
    """Build a schema-valid grid snapshot from SI arrays shaped ``(ny, nx)`` or ``(nt, ny, nx)``.

    ``x``/``y`` are 1-D cell-centre coordinates (m). Velocity is zeroed where dry. ``extra`` adds
    further variables (e.g. derived fields) as ``name: (dims, data, attrs)``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    depth = np.asarray(depth, dtype=float)
    dims = ("y", "x") if depth.ndim == 2 else ("time", "y", "x")
    bed = np.broadcast_to(np.asarray(bed_elevation, dtype=float), depth.shape[-2:])
    wet = depth > DRY_DEPTH
    u = np.where(wet, np.asarray(u, dtype=float), 0.0)
    v = np.where(wet, np.asarray(v, dtype=float), 0.0)
    data = {
        "bed_elevation": (("y", "x"), np.array(bed)),
        "depth": (dims, np.where(wet, depth, np.maximum(depth, 0.0))),
        "water_surface": (dims, bed + np.maximum(depth, 0.0)),
        "u": (dims, u),
        "v": (dims, v),
        "wet": (dims, wet.astype("i1")),
    }
    if obstacle is not None:
        data["obstacle"] = (("y", "x"), np.asarray(obstacle, dtype="i1"))
    coords = {"x": ("x", x), "y": ("y", y)}
    if time is not None:
        coords["time"] = ("time", np.asarray(time))
        time_attrs = _time_attrs(coords["time"][1])
    ds = xr.Dataset(
        {k: (d, a, dict(VARIABLE_ATTRS[k])) for k, (d, a) in data.items()},
        coords={k: (d, a, dict(VARIABLE_ATTRS.get(k, {}))) for k, (d, a) in coords.items()},
    )
    if time is not None:
        ds["time"].attrs.update(time_attrs)
    for name, (d, a, attrs) in (extra or {}).items():
        ds[name] = (d, a, attrs)
    _global_attrs(ds, source, source_files)
    if crs_wkt:
        set_crs(ds, crs_wkt)
    return validate(ds, "snapshot_grid") if check else ds


def _time_attrs(t: np.ndarray) -> dict:
    """CF attributes of a numeric model-time axis (seconds); datetimes are left to xarray's encoder."""
    if np.issubdtype(np.asarray(t).dtype, np.number):  # no reference date: not a CF time axis, a plain quantity
        return {"long_name": "model time since the start of the run", "units": "s"}
    return {"long_name": "time", "axis": "T"}


def _global_attrs(ds: xr.Dataset, source: str, source_files) -> None:
    ds.attrs.update(
        Conventions="CF-1.8 UGRID-1.0" if is_mesh(ds) else "CF-1.8",
        title="breachflow hydrodynamic snapshot",
        source=source or "breachflow",
        source_files=";".join(map(str, source_files)),
        history=f"{datetime.now(timezone.utc).isoformat(timespec='seconds')} written by breachflow",
    )


def set_crs(ds: xr.Dataset, crs_wkt: str) -> xr.Dataset:
    """Attach a CF ``grid_mapping`` variable ``crs`` and point every field at it.

    The CF grid-mapping attributes (``grid_mapping_name`` and its parameters) come from pyproj's
    ``CRS.to_cf()``; ``crs_wkt`` and GDAL's ``spatial_ref`` carry the full WKT.
    """
    attrs = {}
    try:
        from pyproj import CRS

        attrs = {k: v for k, v in CRS.from_user_input(crs_wkt).to_cf().items() if k != "crs_wkt"}
    except Exception:  # not a CRS pyproj knows (e.g. a local engineering CS): WKT only
        attrs = {}
    attrs.update(crs_wkt=crs_wkt, spatial_ref=crs_wkt, long_name="coordinate reference system")
    ds["crs"] = xr.DataArray(np.int32(0), attrs=attrs)
    for name, da in ds.data_vars.items():
        if name != "crs" and ({"x", "y"} <= set(da.dims) or "mesh" in da.attrs):
            da.attrs["grid_mapping"] = "crs"
    return ds


# --------------------------------------------------------------------------------------------------
# Unstructured (UGRID 1.0) mesh snapshots
# --------------------------------------------------------------------------------------------------

#: Name of the UGRID mesh topology variable and of the mesh dimensions.
MESH_TOPOLOGY = "mesh2d"
NODE_DIM, FACE_DIM, MAX_FACE_NODES_DIM = "node", "face", "max_face_nodes"

MESH_ATTRS: dict[str, dict] = {
    "mesh2d_node_x": {"standard_name": "projection_x_coordinate", "long_name": "x coordinate of mesh node", "units": "m"},
    "mesh2d_node_y": {"standard_name": "projection_y_coordinate", "long_name": "y coordinate of mesh node", "units": "m"},
    "mesh2d_face_nodes": {"cf_role": "face_node_connectivity", "long_name": "nodes of each face, counter-clockwise", "start_index": np.int32(0)},
    "mesh2d_node_id": {"long_name": "node id in the source file"},
    "mesh2d_face_id": {"long_name": "element id in the source file"},
    "material": {"long_name": "material id of the element in the source file"},
    "face_active": {"long_name": "element status in the source file (0 inactive, 1 active)", "flag_values": np.array([0, 1], dtype="i1"), "flag_meanings": "inactive active"},
}


def _topology_attrs() -> dict:
    return {
        "cf_role": "mesh_topology",
        "long_name": "topology of the 2-D unstructured mesh",
        "topology_dimension": np.int32(2),
        "node_coordinates": "mesh2d_node_x mesh2d_node_y",
        "face_node_connectivity": "mesh2d_face_nodes",
        "face_dimension": FACE_DIM,
    }


def is_mesh(ds: xr.Dataset) -> bool:
    """True for a UGRID mesh snapshot (it has a ``cf_role = mesh_topology`` variable)."""
    return any(v.attrs.get("cf_role") == "mesh_topology" for v in ds.variables.values())


def mesh_snapshot(
    node_x,
    node_y,
    faces,
    bed_elevation,
    depth,
    u,
    v,
    *,
    time=None,
    crs_wkt: str | None = None,
    source: str = "",
    source_files=(),
    node_ids=None,
    face_ids=None,
    face_material=None,
    face_active=None,
    extra: dict | None = None,
    check: bool = True,
    copy: bool = True,
) -> xr.Dataset:
    """Build a schema-valid UGRID mesh snapshot from SI arrays at nodes, ``(n_node,)`` or ``(nt, n_node)``.

    ``faces`` is ``(n_face, 3 or 4)`` of 0-based node indices, ``-1`` padding triangles in a mixed
    mesh. ``face_active`` (``(n_face,)`` or ``(nt, n_face)``, 0/1) marks elements the source model
    switched off: nodes touching no active element are dry. Depth ≤ ``DRY_DEPTH`` (including the
    negative depths of ADH dry nodes) is dry: depth 0, velocity 0; ``water_surface = bed + depth``.
    ``copy=False`` lets the function zero dry velocities in the given float64 ``u``/``v`` arrays in
    place (readers use it to keep peak memory near the size of the data).
    """
    node_x = np.asarray(node_x, dtype=float)
    node_y = np.asarray(node_y, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] not in (3, 4):
        raise InputError(f"faces must be (n_face, 3|4) node indices, got shape {faces.shape}")
    n = node_x.size
    if faces.size and (faces.max() >= n or faces[:, :3].min() < 0 or faces.min() < -1):
        raise InputError(f"faces reference node indices outside 0..{n - 1}")
    depth = np.asarray(depth, dtype=float)
    nodes_dims = (NODE_DIM,) if depth.ndim == 1 else ("time", NODE_DIM)
    bed = np.broadcast_to(np.asarray(bed_elevation, dtype=float), (n,))
    wet = depth > DRY_DEPTH
    if face_active is not None:
        face_active = np.asarray(face_active, dtype="i1")
        wet &= _nodes_touching_active(faces, face_active, n)
    dep = np.where(wet, depth, 0.0)
    if copy:
        u = np.where(wet, np.asarray(u, dtype=float), 0.0)
        v = np.where(wet, np.asarray(v, dtype=float), 0.0)
    else:
        u = np.asarray(u, dtype=float)
        v = np.asarray(v, dtype=float)
        np.putmask(u, ~wet, 0.0)
        np.putmask(v, ~wet, 0.0)
    node_attrs = {"mesh": MESH_TOPOLOGY, "location": "node"}
    data = {
        "bed_elevation": ((NODE_DIM,), np.array(bed)),
        "depth": (nodes_dims, dep),
        "water_surface": (nodes_dims, bed + dep),
        "u": (nodes_dims, u),
        "v": (nodes_dims, v),
        "wet": (nodes_dims, wet.astype("i1")),
    }
    ds = xr.Dataset({k: (d, a, {**VARIABLE_ATTRS[k], **node_attrs}) for k, (d, a) in data.items()})
    ds[MESH_TOPOLOGY] = xr.DataArray(np.int32(0), attrs=_topology_attrs())
    ds = ds.assign_coords(
        mesh2d_node_x=(NODE_DIM, node_x, dict(MESH_ATTRS["mesh2d_node_x"])),
        mesh2d_node_y=(NODE_DIM, node_y, dict(MESH_ATTRS["mesh2d_node_y"])),
    )
    ds["mesh2d_face_nodes"] = ((FACE_DIM, MAX_FACE_NODES_DIM), faces.astype(np.int32), dict(MESH_ATTRS["mesh2d_face_nodes"]))
    if (faces < 0).any():
        ds["mesh2d_face_nodes"].encoding["_FillValue"] = np.int32(-1)
    face_attrs = {"mesh": MESH_TOPOLOGY, "location": "face"}
    if node_ids is not None:
        ds["mesh2d_node_id"] = ((NODE_DIM,), np.asarray(node_ids, dtype=np.int64), {**MESH_ATTRS["mesh2d_node_id"], **node_attrs})
    if face_ids is not None:
        ds["mesh2d_face_id"] = ((FACE_DIM,), np.asarray(face_ids, dtype=np.int64), {**MESH_ATTRS["mesh2d_face_id"], **face_attrs})
    if face_material is not None:
        ds["material"] = ((FACE_DIM,), np.asarray(face_material, dtype=np.int32), {**MESH_ATTRS["material"], **face_attrs})
    if face_active is not None:
        fdims = (FACE_DIM,) if face_active.ndim == 1 else ("time", FACE_DIM)
        ds["face_active"] = (fdims, face_active, {**MESH_ATTRS["face_active"], **face_attrs})
    if time is not None:
        t = np.asarray(time)
        ds = ds.assign_coords(time=("time", t, _time_attrs(t)))
    for name, (d, a, attrs) in (extra or {}).items():
        ds[name] = (d, a, attrs)
    _global_attrs(ds, source, source_files)
    if crs_wkt:
        set_crs(ds, crs_wkt)
        ds[MESH_TOPOLOGY].attrs.pop("grid_mapping", None)
    return validate(ds, "snapshot_mesh") if check else ds


def _nodes_touching_active(faces: np.ndarray, active: np.ndarray, n_node: int) -> np.ndarray:
    """Boolean ``(n_node,)`` or ``(nt, n_node)``: node belongs to at least one active element."""
    act = np.atleast_2d(active).astype(bool)
    out = np.zeros((act.shape[0], n_node), dtype=bool)
    for k in range(act.shape[0]):
        f = faces[act[k]]
        f = f[f >= 0]
        out[k, f] = True
    return out[0] if active.ndim == 1 else out


def mesh_face_nodes(ds: xr.Dataset) -> np.ndarray:
    """Face-node connectivity as 0-based int64, ``-1`` where a face has fewer nodes (UGRID start_index / fill)."""
    topo = ds[_topology_name(ds)]
    cname = topo.attrs["face_node_connectivity"]
    da = ds[cname]
    raw = np.asarray(da.values)
    fill = da.encoding.get("_FillValue", da.attrs.get("_FillValue"))
    if np.issubdtype(raw.dtype, np.floating):
        missing = ~np.isfinite(raw)
        raw = np.where(missing, -1, raw)
    else:
        missing = raw == fill if fill is not None else np.zeros(raw.shape, bool)
    start = int(da.attrs.get("start_index", 0))
    out = raw.astype(np.int64) - start
    out[missing] = -1
    return out


def mesh_triangles(ds: xr.Dataset) -> np.ndarray:
    """``(n_tri, 3)`` int64 triangles of a mesh snapshot; quads are split along their 0–2 diagonal."""
    faces = mesh_face_nodes(ds)
    tri = faces[:, :3]
    if faces.shape[1] > 3:
        quad = faces[:, 3] >= 0
        tri = np.concatenate([tri, faces[quad][:, [0, 2, 3]]])
    return np.ascontiguousarray(tri, dtype=np.int64)


def _topology_name(ds: xr.Dataset) -> str:
    for name, var in ds.variables.items():
        if var.attrs.get("cf_role") == "mesh_topology":
            return str(name)
    raise InputError("dataset has no UGRID mesh_topology variable")


def node_coordinates(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    xname, yname = ds[_topology_name(ds)].attrs["node_coordinates"].split()
    return np.asarray(ds[xname].values, dtype=float), np.asarray(ds[yname].values, dtype=float)


def schema_name(ds: xr.Dataset) -> str:
    return "snapshot_mesh" if is_mesh(ds) else "snapshot_grid"


def validate_snapshot(ds: xr.Dataset, *, source: str | None = None) -> xr.Dataset:
    """Validate a grid or mesh snapshot against its schema (plus mesh connectivity checks)."""
    validate(ds, schema_name(ds), source=source)
    if is_mesh(ds):
        faces = mesh_face_nodes(ds)
        n = ds.sizes[NODE_DIM]
        if faces.size and (faces.max() >= n or faces[:, :3].min() < 0):
            raise SchemaError(f"{source or 'mesh'}: mesh2d_face_nodes references nodes outside 0..{n - 1}")
    return ds


# --------------------------------------------------------------------------------------------------
# Plausibility
# --------------------------------------------------------------------------------------------------

#: (warn above, error above) in SI for each checked quantity; a unit mix-up (ft read as m, cm/s as
#: m/s) is the usual cause. Breach flows reach a few m/s; levee-scale depths are tens of metres.
PLAUSIBLE_LIMITS = {
    "depth": (50.0, 200.0),          # m
    "speed": (10.0, 20.0),           # m/s
    "bed_elevation": (5000.0, 9000.0),  # |z| in m
    "negative_depth": (1.0, 50.0),   # m below the bed: dry convention tolerated above this
}


def describe_location(ds: xr.Dataset, flat_index: int, dims: tuple, shape: tuple) -> str:
    """Human text of where element *flat_index* of an array with *dims* lies (time step, node/cell, x, y)."""
    idx = dict(zip(dims, np.unravel_index(int(flat_index), shape)))
    parts = []
    if "time" in idx:
        tval = ds["time"].values[idx["time"]] if "time" in ds.variables else idx["time"]
        parts.append(f"time step {idx['time']} (t={tval})")
    if NODE_DIM in idx:
        i = idx[NODE_DIM]
        nid = f" (id {int(ds['mesh2d_node_id'].values[i])})" if "mesh2d_node_id" in ds.variables else ""
        x, y = node_coordinates(ds)
        parts.append(f"node {i}{nid} at x={x[i]:.6g} m, y={y[i]:.6g} m")
    elif "x" in idx and "y" in idx:
        parts.append(f"cell (row {idx['y']}, col {idx['x']}) at x={float(ds['x'].values[idx['x']]):.6g} m, "
                     f"y={float(ds['y'].values[idx['y']]):.6g} m")
    return ", ".join(parts)


def flag_implausible(ds: xr.Dataset, name: str, values, dims: tuple, limits: tuple[float, float],
                     *, what: str, unit: str, mode: str = "raise", hint: str = "check the units",
                     transform=None, locate=None, key: str | None = None) -> None:
    """Warn (or raise :class:`~breachflow.errors.ImplausibleValueError`, an ``InputError``, in ``mode="raise"``) if ``values`` exceed *limits* = (warn, error).

    *values* is an array or a tuple of same-shaped arrays combined by *transform* (e.g. ``np.hypot``);
    the work is done one leading-axis slice at a time so no full-size temporaries are made.
    *locate* (from a reader) maps ``(key, {dim: index})`` of the worst value to ``(path, line, note)`` in
    the source file, or None; the message then starts with ``path:line:`` like a :class:`~breachflow.errors.ParseError`.
    """
    if mode == "off":
        return
    parts = values if isinstance(values, tuple) else (values,)
    shape = np.shape(parts[0])
    if not np.prod(shape):
        return
    transform = transform or (lambda a: np.asarray(a, dtype=float))
    rows = shape[0] if len(shape) > 1 else 1
    worst, k = -np.inf, 0
    for r in range(rows):
        sl = tuple(p[r] if len(shape) > 1 else p for p in parts)
        vals = transform(*sl)
        vals = np.where(np.isfinite(vals), vals, -np.inf)
        j = int(np.argmax(vals))
        if vals.flat[j] > worst:
            worst, k = float(vals.flat[j]), r * (vals.size if len(shape) > 1 else 0) + j
    warn_at, error_at = limits
    if not np.isfinite(worst) or worst <= warn_at:
        return
    where = describe_location(ds, k, dims, shape)
    msg = f"{name}: implausible {what} {worst:.4g} {unit} at {where}"
    path = line = None
    if locate is not None:
        loc = locate(key or name, dict(zip(dims, (int(i) for i in np.unravel_index(int(k), shape)))))
        if loc is not None:
            path, line, note = loc
            msg = (f"{path}:{line}: " if line is not None else f"{path}: ") + msg + (f" ({note})" if note else "")
    if worst > error_at and mode == "raise":
        raise ImplausibleValueError(f"{msg} (above {error_at:g} {unit}; {hint})", path=path, line=line)
    warnings.warn(f"{msg} (above {warn_at:g} {unit}; {hint})", BreachflowWarning, stacklevel=3)


def check_plausibility(ds: xr.Dataset, *, mode: str = "raise", raw_depth=None, locate=None) -> xr.Dataset:
    """Check depth, speed and bed elevation of a snapshot against :data:`~breachflow.field.snapshot.PLAUSIBLE_LIMITS`.

    ``mode``: ``"raise"`` (error above the hard limit, warning above the soft one), ``"warn"`` (only
    warnings) or ``"off"``. ``raw_depth`` (same dims as ``depth``) are the depths as read, before the
    dry convention clipped negative values: dry nodes deeper than the tolerance below the bed are flagged.
    ``locate(key, index)`` (key ``depth | speed | bed_elevation | negative_depth``) lets a reader name
    the file and line of the offending value (see :func:`~breachflow.field.snapshot.flag_implausible`).
    """
    if mode not in ("raise", "warn", "off"):
        raise InputError(f"plausibility mode must be 'raise', 'warn' or 'off', not {mode!r}")
    dims = ds["depth"].dims
    kw = dict(mode=mode, locate=locate)
    flag_implausible(ds, "depth", ds["depth"].values, dims, PLAUSIBLE_LIMITS["depth"], what="water depth", unit="m", key="depth", **kw)
    flag_implausible(ds, "u, v", (ds["u"].values, ds["v"].values), ds["u"].dims, PLAUSIBLE_LIMITS["speed"],
                     what="speed", unit="m/s", transform=np.hypot, key="speed", **kw)
    bed = ds["bed_elevation"]
    flag_implausible(ds, "bed_elevation", bed.values, bed.dims, PLAUSIBLE_LIMITS["bed_elevation"],
                     what="|bed elevation|", unit="m", transform=np.abs, key="bed_elevation", **kw)
    if raw_depth is not None:
        flag_implausible(ds, "depth", np.asarray(raw_depth, dtype=float), dims, PLAUSIBLE_LIMITS["negative_depth"],
                         what="negative depth (below the bed, beyond the dry convention) of minus", unit="m",
                         hint="check the file's depth column and units", transform=np.negative, key="negative_depth", **kw)
    return ds


# --------------------------------------------------------------------------------------------------
# NetCDF I/O
# --------------------------------------------------------------------------------------------------

def write_snapshot(ds: xr.Dataset, path, *, compress: bool = True) -> Path:
    """Validate *ds* and write it to NetCDF-4 at *path* atomically (temporary file + ``os.replace``)."""
    path = Path(path)
    validate_snapshot(ds, source=str(path))
    encoding = {}
    for name, var in ds.variables.items():
        enc = {}
        if compress and var.ndim >= 1 and var.size > 1024 and var.dtype.kind in "fiu":
            enc.update(zlib=True, complevel=1, shuffle=True)
        if var.dtype.kind in "iu" and "_FillValue" not in var.encoding and name not in ("time",):
            enc["_FillValue"] = None
        if var.dtype.kind == "f" and name in ("x", "y", "time", "mesh2d_node_x", "mesh2d_node_y"):
            enc["_FillValue"] = None
        if var.dtype.kind in "OUS":
            # text as a CF char array (CF §2.2), not a NetCDF-4 vlen string: older CF tools and
            # cfchecker read only char; xarray decodes it back to str through _Encoding
            enc.update(dtype="S1", char_dim_name=f"{name}_strlen", _Encoding="utf-8")
        if enc:
            encoding[name] = enc
    from ..atomic import atomic_write_netcdf

    # atomic, with the user's umask permissions, provenance attributes, and a full disk named as such
    atomic_write_netcdf(ds, path, format="NETCDF4", encoding=encoding)
    return path


def read_snapshot(path, *, check: bool = True) -> xr.Dataset:
    """Read a snapshot written by :func:`write_snapshot` (grid or mesh), load it and validate it."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"snapshot file {str(path)!r} does not exist")
    try:
        with xr.open_dataset(path, engine="netcdf4") as f:
            ds = f.load()
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read as NetCDF ({exc})") from None
    if is_mesh(ds):
        cname = ds[_topology_name(ds)].attrs["face_node_connectivity"]
        faces = mesh_face_nodes(ds) + int(ds[cname].attrs.get("start_index", 0))
        attrs = dict(ds[cname].attrs)
        ds[cname] = (ds[cname].dims, faces.astype(np.int32), attrs)
        if (faces < 0).any():
            ds[cname].encoding["_FillValue"] = np.int32(-1)
    return validate_snapshot(ds, source=str(path)) if check else ds
