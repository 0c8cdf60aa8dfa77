"""A map grid of a breachflow NetCDF file (a cycle file, a ``combine`` archive, a snapshot) as a north-up raster in
the file's CRS, for combining with other maps.

>>> depth = open_north_up("runs/site/cycle_0015.nc", "depth")      # doctest: +SKIP
>>> depth.sel(x=676120.0, y=3372100.0, method="nearest")            # doctest: +SKIP

A site whose levee is not east-west runs on a grid turned about the breach centre; its files carry GDAL's
``GeoTransform`` with rotation terms (docs/outputs.md). GDAL places such a grid exactly (``gdalwarp``, QGIS),
but tools that derive the raster's footprint from the 1-D ``x``/``y`` coordinates (the breach-aligned grid's)
do not: ``rioxarray``'s ``rio.reproject`` of a turned cycle file leaves part of the grid outside its output or
off its place. :func:`open_north_up` lets GDAL's warper do the job (``rasterio.vrt.WarpedVRT``, the automatic
warped VRT that QGIS also builds for a turned raster) rather than redoing it by hand: each output pixel takes
the value of the grid cell its centre lies in (``resampling="nearest"``, the default), so every value read is
a value the file holds. A north-up grid comes back on its own cells.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError


def open_north_up(path, variable: str, *, resolution: float | None = None, resampling: str = "nearest") -> xr.DataArray:
    """The map grid *variable* of the NetCDF file *path* on a north-up grid in the file's CRS.

    Returns a DataArray on ``(cycle, y, x)`` (``(y, x)`` when the variable has no cycle axis) with ``x``
    ascending, ``y`` descending (pixel centres, m in the CRS), the variable's attributes, and a scalar ``crs``
    coordinate holding the CRS as WKT (``crs_wkt``, ``spatial_ref``; the variable's ``grid_mapping`` names
    it, as CF and rioxarray read it). Pixels outside the turned grid's footprint are NaN for a floating-point
    grid (0 for the integer masks ``wet`` and ``obstacle``). *resolution* is the pixel size (m; default the
    grid's cell size): the raster covers the grid's whole footprint. On a turned grid with nearest
    resampling, a pixel no larger than the cell size over √2 puts every cell's centre in a pixel that holds
    that cell's value. *resampling* is one of GDAL's methods
    (``nearest``, ``bilinear``, ``cubic``, ...). Raises :class:`~breachflow.errors.InputError` when the file
    does not exist, the variable is not a map grid of it, or the method is unknown."""
    import rasterio
    from rasterio.enums import Resampling
    from rasterio.errors import RasterioIOError
    from rasterio.vrt import WarpedVRT

    path = Path(path)
    if not path.is_file():
        raise InputError(f"open_north_up: {path}: no such file")
    try:
        method = Resampling[resampling]
    except KeyError:
        names = ", ".join(m.name for m in Resampling)
        raise InputError(f"open_north_up: resampling {resampling!r} is not one of {names}") from None
    with xr.open_dataset(path) as ds:
        if variable not in ds.data_vars or ds[variable].dims[-2:] != ("y", "x"):
            grids = sorted(k for k, v in ds.data_vars.items() if v.dims[-2:] == ("y", "x"))
            raise InputError(f"open_north_up: {path}: {variable!r} is not a map grid of this file "
                             f"(its grids: {', '.join(grids) or 'none'})")
        attrs = {k: v for k, v in ds[variable].attrs.items() if k != "grid_mapping"}
        extra = ds[variable].dims[:-2]
        cycles = ds["cycle"].values if extra == ("cycle",) else None
    if len(extra) > 1 or (extra and cycles is None):
        raise InputError(f"open_north_up: {path}: {variable!r} has the axes {extra + ('y', 'x')}; "
                         "only (y, x) and (cycle, y, x) grids are read")
    try:
        src = rasterio.open(f"NETCDF:{path}:{variable}")
    except RasterioIOError as e:
        raise InputError(f"open_north_up: {path}: GDAL cannot open {variable!r} as a map grid ({e})") from None
    with src:
        if src.crs is None:
            raise InputError(f"open_north_up: {path}: {variable!r} has no CRS for GDAL (no grid mapping)")
        floating = np.issubdtype(np.dtype(src.dtypes[0]), np.floating)
        options = {"nodata": np.nan} if floating else {}
        G = src.transform
        size = float(resolution) if resolution is not None else float(np.hypot(G.a, G.d))
        if not np.isfinite(size) or size <= 0:
            raise InputError(f"open_north_up: resolution {resolution!r} must be a positive length in m")
        # the grid's footprint: its four outer corners through its (possibly turned) transform
        cx, cy = G * (np.array([0, src.width, src.width, 0]), np.array([0, 0, src.height, src.height]))
        left, top = float(np.min(cx)), float(np.max(cy))
        width = int(np.ceil((float(np.max(cx)) - left) / size - 1e-9))
        height = int(np.ceil((top - float(np.min(cy))) / size - 1e-9))
        grid = rasterio.Affine(size, 0.0, left, 0.0, -size, top)
        with WarpedVRT(src, resampling=method, transform=grid, width=width, height=height, **options) as vrt:
            data = vrt.read()
            T, crs = vrt.transform, vrt.crs
    x = T.c + (np.arange(data.shape[2]) + 0.5) * T.a
    y = T.f + (np.arange(data.shape[1]) + 0.5) * T.e
    wkt = crs.to_wkt()
    coords = {"x": ("x", x, {"standard_name": "projection_x_coordinate", "units": "m", "axis": "X"}),
              "y": ("y", y, {"standard_name": "projection_y_coordinate", "units": "m", "axis": "Y"}),
              "crs": ((), 0, {"crs_wkt": wkt, "spatial_ref": wkt})}
    if cycles is None:
        return xr.DataArray(data[0], dims=("y", "x"), coords=coords, name=variable,
                            attrs={**attrs, "grid_mapping": "crs"})
    coords["cycle"] = ("cycle", cycles)
    return xr.DataArray(data, dims=("cycle", "y", "x"), coords=coords, name=variable,
                        attrs={**attrs, "grid_mapping": "crs"})
