"""The hydrodynamic snapshot Dataset: one definition of its variables, attributes and schema.

Structured grids use dims ``(y, x)`` (optionally ``(time, y, x)``) with cell-centre coordinates in
metres; the schema is ``data_schemas/snapshot_grid.json``. Everything is SI. Dry cells have
``depth == 0``, ``wet == False`` and zero velocity.
"""
from __future__ import annotations

from datetime import datetime, timezone

import numpy as np
import xarray as xr

from ..schemas import validate

#: CF attributes of every snapshot variable (standard names only where the CF table has one).
VARIABLE_ATTRS: dict[str, dict] = {
    "x": {"standard_name": "projection_x_coordinate", "long_name": "x coordinate of cell centre", "units": "m", "axis": "X"},
    "y": {"standard_name": "projection_y_coordinate", "long_name": "y coordinate of cell centre", "units": "m", "axis": "Y"},
    "bed_elevation": {"long_name": "bed elevation above datum", "units": "m", "positive": "up"},
    "depth": {"standard_name": "sea_floor_depth_below_sea_surface", "long_name": "water depth", "units": "m"},
    "water_surface": {"standard_name": "water_surface_height_above_reference_datum", "long_name": "water-surface elevation above datum", "units": "m"},
    "u": {"standard_name": "barotropic_sea_water_x_velocity", "long_name": "depth-averaged velocity, x component", "units": "m s-1"},
    "v": {"standard_name": "barotropic_sea_water_y_velocity", "long_name": "depth-averaged velocity, y component", "units": "m s-1"},
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
    ds = xr.Dataset(
        {k: (d, a, dict(VARIABLE_ATTRS[k])) for k, (d, a) in data.items()},
        coords={k: (d, a, dict(VARIABLE_ATTRS.get(k, {}))) for k, (d, a) in coords.items()},
    )
    for name, (d, a, attrs) in (extra or {}).items():
        ds[name] = (d, a, attrs)
    ds.attrs.update(
        Conventions="CF-1.10",
        title="breachflow hydrodynamic snapshot",
        source=source or "breachflow",
        source_files=";".join(map(str, source_files)),
        history=f"{datetime.now(timezone.utc).isoformat(timespec='seconds')} written by breachflow",
    )
    if crs_wkt:
        set_crs(ds, crs_wkt)
    return validate(ds, "snapshot_grid") if check else ds


def set_crs(ds: xr.Dataset, crs_wkt: str) -> xr.Dataset:
    """Attach a CF ``grid_mapping`` variable ``crs`` (WKT in ``crs_wkt``) and point every field at it."""
    ds["crs"] = xr.DataArray(np.int32(0), attrs={"crs_wkt": crs_wkt, "spatial_ref": crs_wkt, "long_name": "coordinate reference system"})
    for name, da in ds.data_vars.items():
        if name != "crs" and {"x", "y"} <= set(da.dims):
            da.attrs["grid_mapping"] = "crs"
    return ds
