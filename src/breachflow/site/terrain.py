"""Terrain models of a real site: GeoTIFF, ESRI ASCII grid or NetCDF grid of terrain elevations, with their CRS (issue 13).

:func:`load_terrain` reads the file once, converts the vertical unit to metres (``ft`` / ``US survey
foot`` → m, declared by the file's band unit or by the user; both given and different is an error) and
returns a :class:`Terrain`: cell-centre coordinates in the file's CRS (x increasing, y increasing),
elevation ``z`` shaped ``(ny, nx)`` (NaN where the file has no data), the CRS as WKT and the path.
GeoTIFF and ESRI ASCII go through rasterio (GDAL; an ``.asc`` takes its CRS from the ``.prj`` beside
it); NetCDF through xarray (1-D ``x``/``y`` coordinates, CRS from the ``grid_mapping`` variable's
``crs_wkt`` / ``spatial_ref``).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, ParseError

#: vertical units we recognise → metres per unit
VERTICAL_UNITS = {"m": 1.0, "metre": 1.0, "meter": 1.0, "metres": 1.0, "meters": 1.0,
                  "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "international foot": 0.3048,
                  "us survey foot": 1200.0 / 3937.0, "us_survey_foot": 1200.0 / 3937.0, "ftus": 1200.0 / 3937.0,
                  "us-ft": 1200.0 / 3937.0, "survey foot": 1200.0 / 3937.0}


@dataclass
class Terrain:
    """A terrain model in SI: ``x`` (nx,), ``y`` (ny,) cell centres (increasing), ``z`` (ny, nx) m (NaN = no data)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    crs_wkt: str | None
    path: Path
    vertical_unit: str = "m"

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) of the cell edges."""
        dx = abs(self.x[1] - self.x[0]) if self.x.size > 1 else 0.0
        dy = abs(self.y[1] - self.y[0]) if self.y.size > 1 else 0.0
        return (float(self.x[0] - dx / 2), float(self.x[-1] + dx / 2), float(self.y[0] - dy / 2), float(self.y[-1] + dy / 2))

    def sample(self, X, Y) -> np.ndarray:
        """Bilinear elevation at points (X, Y) (NaN outside the cell centres' hull or next to no-data)."""
        from scipy.interpolate import RegularGridInterpolator

        f = RegularGridInterpolator((self.y, self.x), self.z, bounds_error=False, fill_value=np.nan)
        X = np.asarray(X, float)
        return f(np.stack([np.asarray(Y, float).ravel(), X.ravel()], axis=-1)).reshape(X.shape)


def _vertical_scale(declared: str | None, user: str | None, path) -> tuple[float, str]:
    names = []
    for what, u in (("the file declares", declared), ("[site] terrain_units", user)):
        if u:
            key = u.strip().lower()
            if key not in VERTICAL_UNITS:
                raise InputError(f"{path}: vertical unit {u!r} ({what}) not recognised; use m, ft or US survey foot")
            names.append((what, key))
    if len(names) == 2 and VERTICAL_UNITS[names[0][1]] != VERTICAL_UNITS[names[1][1]]:
        raise InputError(f"{path}: the file declares vertical unit {declared!r} but [site] terrain_units = {user!r}")
    if not names:
        return 1.0, "m"
    return VERTICAL_UNITS[names[-1][1]], names[-1][1]


def load_terrain(path, *, crs: str | None = None, vertical_units: str | None = None, variable: str | None = None) -> Terrain:
    """Read a terrain model (``.tif``/``.tiff``, ``.asc``, ``.nc``) into a :class:`Terrain` (elevations in m).

    *crs* (WKT / ``EPSG:nnnn``) is used when the file has none and must agree with the file's when both
    are given; *vertical_units* likewise for the elevation unit; *variable* picks the NetCDF variable.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"terrain file not found: {path}")
    suffix = path.suffix.lower()
    if suffix in (".nc", ".nc4", ".cdf"):
        x, y, z, file_crs, declared = _read_netcdf(path, variable)
    else:
        x, y, z, file_crs, declared = _read_raster(path)
    if x.size < 2 or y.size < 2:
        raise InputError(f"{path}: a terrain needs at least 2 × 2 cells, got {x.size} × {y.size}")
    scale, unit = _vertical_scale(declared, vertical_units, path)
    z = z * scale
    crs_wkt = _agree_crs(file_crs, crs, path)
    if not np.isfinite(z).any():
        raise InputError(f"{path}: the terrain has no valid elevation")
    return Terrain(x=x, y=y, z=z, crs_wkt=crs_wkt, path=path, vertical_unit=unit)


def _agree_crs(file_crs, user_crs, path) -> str | None:
    from pyproj import CRS

    def parse(c, what):
        try:
            return CRS.from_user_input(c)
        except Exception as exc:
            raise InputError(f"{path}: cannot interpret the CRS {what} {str(c)[:80]!r} ({exc})") from None

    fc = parse(file_crs, "of the file") if file_crs else None
    uc = parse(user_crs, "given in [site] crs") if user_crs else None
    if fc is not None and uc is not None and not fc.equals(uc, ignore_axis_order=True):
        raise InputError(f"{path}: the terrain's CRS ({fc.name}) differs from [site] crs = {user_crs!r} ({uc.name})")
    c = fc or uc
    return None if c is None else c.to_wkt()


def _read_raster(path):
    try:
        import rasterio
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError(f"{path}: reading rasters needs rasterio (pip install rasterio)") from None
    try:
        src = rasterio.open(path)
    except Exception as exc:
        raise InputError(f"{path}: cannot read as a raster terrain model ({exc})") from None
    with src:
        _check_raster_size(path, src)
        t = src.transform
        if t.b != 0 or t.d != 0:
            raise InputError(f"{path}: rotated rasters are not supported (geotransform {tuple(t)[:6]})")
        z = src.read(1, masked=True).astype(float).filled(np.nan)
        nx, ny = src.width, src.height
        x = t.c + (np.arange(nx) + 0.5) * t.a
        y = t.f + (np.arange(ny) + 0.5) * t.e
        crs = src.crs.to_wkt() if src.crs else None
        declared = (src.units[0] or None) if src.units else None
        if declared is None:
            declared = src.tags(1).get("units") or src.tags().get("vertical_units")
    if x[1] < x[0]:
        x, z = x[::-1], z[:, ::-1]
    if y[1] < y[0]:
        y, z = y[::-1], z[::-1, :]
    return x, y, z, crs, declared


#: the most cells a terrain raster may have (float64: 8 bytes each, 4 GB)
MAX_RASTER_CELLS = 500_000_000


def _check_raster_size(path, src) -> None:
    """Refuse, before reading, a raster whose header announces more cells than fit in memory or, for an ESRI
    ASCII grid, more values than its file can hold (each value takes a character and a separator)."""
    nx, ny = int(src.width), int(src.height)
    cells = nx * ny
    line = None
    if (src.driver or "").upper() == "AAIGRID":
        with open(path, "rb") as fh:
            for k, raw in enumerate(fh.readlines(4096)[:12], start=1):
                if raw.strip().lower().startswith(b"ncols"):
                    line = k
                    break
        size = Path(path).stat().st_size
        if cells > (size + 1) // 2:
            raise ParseError(f"header ncols {nx:,} × nrows {ny:,} = {cells:,} values, but the file is only {size:,} "
                             f"bytes (at most {(size + 1) // 2:,} values); wrong ncols/nrows?", path=path, line=line)
    if cells > MAX_RASTER_CELLS:
        raise ParseError(f"the raster has {nx:,} × {ny:,} = {cells:,} cells, more than the {MAX_RASTER_CELLS:,} a "
                         f"terrain may have (clip it to the breach's surroundings, e.g. gdal_translate -projwin)",
                         path=path, line=line)


def _read_netcdf(path, variable):
    import xarray as xr

    try:
        ds = xr.open_dataset(path)
    except Exception as exc:
        raise InputError(f"{path}: cannot read as NetCDF ({exc})") from None
    with ds:
        names = [variable] if variable else [v for v in ds.data_vars if ds[v].ndim == 2]
        if not names or names[0] not in ds:
            raise InputError(f"{path}: no 2-D elevation variable{f' {variable!r}' if variable else ''} found")
        da = ds[names[0]]
        ydim, xdim = da.dims
        x = np.asarray(ds[xdim].values, float)
        y = np.asarray(ds[ydim].values, float)
        z = np.asarray(da.values, float)
        declared = da.attrs.get("units")
        crs = None
        gm = da.attrs.get("grid_mapping")
        if gm and gm in ds:
            crs = ds[gm].attrs.get("crs_wkt") or ds[gm].attrs.get("spatial_ref")
    if x[1] < x[0]:
        x, z = x[::-1], z[:, ::-1]
    if y[1] < y[0]:
        y, z = y[::-1], z[::-1, :]
    return x, y, z, crs, declared
