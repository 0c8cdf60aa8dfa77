"""Cycle files of a site opened as GIS users open them (issue 13): GDAL's NetCDF driver through rasterio
and rioxarray, and ``gdalinfo``.

A site whose levee is not east–west runs on a grid turned about the breach centre
(:mod:`breachflow.site.frame`): its cycle files carry the cell centres' map coordinates (``map_x``,
``map_y``) and GDAL's ``GeoTransform`` with rotation terms on the ``crs`` variable. GDAL must put
every cell where ``map_x``/``map_y`` say; a north-up site (levee east–west) must read as a plain
north-up raster on the 1-D ``x``/``y``. The cycle files come from ``breachflow run`` on the example
site (``examples/site/make_site.py --angle``) at 3 m cells, one cycle.
"""
import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.main import run_closure

SITE = Path(__file__).resolve().parents[2] / "examples" / "site"

rasterio = pytest.importorskip("rasterio")


def _make_site():
    spec = importlib.util.spec_from_file_location("make_site", SITE / "make_site.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_site", mod)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module", params=[23.0, 0.0, 137.0], ids=["turned23", "north_up", "turned137"])
def cycle_file(request, tmp_path_factory):
    """``cycle_0001.nc`` of the example site turned by the parameter (degrees), 3 m cells, one cycle."""
    angle = request.param
    d = tmp_path_factory.mktemp(f"site{angle:g}")
    tif, geo = _make_site().write(d, angle)
    text = (SITE / "site.toml").read_text()
    text = (text.replace('"terrain.tif"', f'"{tif}"').replace('"levee.geojson"', f'"{geo}"')
            .replace('resolution = "1 m"', 'resolution = "3 m"').replace("max_cycles = 24", "max_cycles = 1"))
    assert 'resolution = "3 m"' in text and "max_cycles = 1" in text
    (d / "site.toml").write_text(text)
    run_closure(d / "site.toml", d / "run", plots=False)
    return angle, d / "run" / "cycle_0001.nc"


def _centres(T, rows, cols):
    """Map coordinates of pixel centres (row, col) through an affine transform (GDAL's geotransform)."""
    c, r = np.asarray(cols) + 0.5, np.asarray(rows) + 0.5
    return T.c + T.a * c + T.b * r, T.f + T.d * c + T.e * r


def _expected_map(ds):
    """The map coordinates breachflow writes for every stored cell [j, i]: map_x/map_y on a turned grid,
    the 1-D x/y on a north-up one."""
    if "map_x" in ds:
        return ds["map_x"].values, ds["map_y"].values
    return np.meshgrid(ds["x"].values, ds["y"].values)


def _stored_index(ds, angle, rows, cols):
    """(j, i) in the file of GDAL pixel (row, col): GDAL shows a north-up grid north row first (the file
    stores y ascending); a turned grid keeps the stored row order (its GeoTransform's row 0 is the first
    stored row)."""
    ny = ds.sizes["y"]
    return (np.asarray(rows) if angle != 0.0 else ny - 1 - np.asarray(rows)), np.asarray(cols)


def test_rasterio_puts_every_cell_where_breachflow_says(cycle_file):
    """rasterio (GDAL NetCDF driver) on ``NETCDF:cycle_0001.nc:depth``: the CRS is the site's (EPSG:26915),
    the affine transform maps each pixel centre to the map coordinates breachflow wrote for that cell
    (within 1e-6 of a cell), and the values read are the file's cell values at those cells."""
    angle, path = cycle_file
    with xr.open_dataset(path) as ds:
        ds = ds.isel(cycle=0).load()
    with rasterio.open(f"NETCDF:{path}:depth") as src:
        T, crs, band, shape = src.transform, src.crs, src.read(1), (src.height, src.width)
    assert crs.to_epsg() == 26915
    assert shape == (ds.sizes["y"], ds.sizes["x"])
    turned = angle != 0.0
    assert (T.b != 0 and T.d != 0) == turned  # rotation terms only on a turned grid
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    X, Y = _centres(T, rows, cols)
    MX, MY = _expected_map(ds)
    j, i = _stored_index(ds, angle, rows, cols)
    cell = float(ds.x[1] - ds.x[0])
    np.testing.assert_allclose(X, MX[j, i], rtol=0, atol=1e-6 * cell)
    np.testing.assert_allclose(Y, MY[j, i], rtol=0, atol=1e-6 * cell)
    np.testing.assert_array_equal(np.isnan(band), np.isnan(ds["depth"].values[j, i]))
    np.testing.assert_allclose(band, ds["depth"].values[j, i], equal_nan=True)
    if turned:  # the grid runs along the turned levee: its x axis at the frame's angle on the map
        ang = np.degrees(np.arctan2(T.d, T.a))
        assert ang == pytest.approx(ds.attrs["grid_rotation_deg"], abs=1e-9)
    # the breach centre (the site's, in map coordinates) lies inside the raster's footprint
    xc, yc = map(float, ds.attrs["site_breach_centre"].split())
    col, row = np.linalg.solve([[T.a, T.b], [T.d, T.e]], [xc - T.c, yc - T.f])
    assert 0 < col < shape[1] and 0 < row < shape[0]


def test_gdalinfo_corner_coordinates(cycle_file):
    """``gdalinfo -json`` (Debian gdal-bin) on the cycle file: its geotransform is rasterio's and its
    corner coordinates (to gdalinfo's 1 mm) are the outer corners of the grid's corner cells: map of the grid corners
    ``(x0 − dx/2, y0 − dy/2)`` … through the frame (turned grid) or the 1-D axes (north-up)."""
    if not shutil.which("gdalinfo"):
        pytest.skip("gdalinfo (Debian gdal-bin) not installed; `python3 tasks.py test` installs it as root")
    angle, path = cycle_file
    out = subprocess.run(["gdalinfo", "-json", f"NETCDF:{path}:depth"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    info = json.loads(out.stdout)
    with xr.open_dataset(path) as ds:
        x, y = ds["x"].values, ds["y"].values
        rot = float(ds.attrs.get("grid_rotation_deg", 0.0))
        centre = tuple(map(float, ds.attrs["site_breach_centre"].split()))
    dx, dy = x[1] - x[0], y[1] - y[0]
    west, east, south, north = x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2
    # grid corners → map, independently of breachflow's frame code: the turn about the breach centre
    c, s = np.cos(np.radians(rot)), np.sin(np.radians(rot))

    def to_map(gx, gy):
        return [centre[0] + c * (gx - centre[0]) - s * (gy - centre[1]), centre[1] + s * (gx - centre[0]) + c * (gy - centre[1])]

    cc = info["cornerCoordinates"]  # gdalinfo rounds them to 1 mm
    # pixel (0, 0) is the first stored row on a turned grid, the northern row of a north-up one
    first, last = (south, north) if angle != 0.0 else (north, south)
    want = {"upperLeft": to_map(west, first), "upperRight": to_map(east, first),
            "lowerLeft": to_map(west, last), "lowerRight": to_map(east, last),
            "center": to_map(0.5 * (west + east), 0.5 * (south + north))}
    for key, xy in want.items():
        np.testing.assert_allclose(cc[key], xy, rtol=0, atol=1e-3, err_msg=key)
    with rasterio.open(f"NETCDF:{path}:depth") as src:
        T = src.transform
    np.testing.assert_allclose(info["geoTransform"], [T.c, T.a, T.b, T.f, T.d, T.e], rtol=0, atol=1e-6)
    assert "26915" in json.dumps(info["coordinateSystem"])


def test_rioxarray_reads_the_cycle_file_on_the_map(cycle_file):
    """rioxarray, both ways users open a NetCDF raster: ``rioxarray.open_rasterio("NETCDF:file:depth")``
    (GDAL; default arguments) and ``xr.open_dataset(file)["depth"].rio``: the site's CRS and the same
    transform as rasterio's, so ``rio.reproject``/``rio.to_raster`` put the grid on the map."""
    rioxarray = pytest.importorskip("rioxarray")
    angle, path = cycle_file
    with rasterio.open(f"NETCDF:{path}:depth") as src:
        T = src.transform
    da = rioxarray.open_rasterio(f"NETCDF:{path}:depth")
    assert da.rio.crs.to_epsg() == 26915
    np.testing.assert_allclose(tuple(da.rio.transform())[:6], tuple(T)[:6], rtol=0, atol=1e-6)
    with xr.open_dataset(path, decode_coords="all") as ds:
        d = ds["depth"].isel(cycle=0)
        assert d.rio.crs.to_epsg() == 26915
        np.testing.assert_allclose(tuple(d.rio.transform())[:6], tuple(T if angle != 0.0 else
                                   _flip_rows(T, ds.sizes["y"]))[:6], rtol=0, atol=1e-6)


def _flip_rows(T, ny):
    """The transform of the same grid with its rows in stored (south-first) order: xarray keeps y ascending."""
    from affine import Affine

    return Affine(T.a, T.b, T.c + ny * T.b, T.d, -T.e, T.f + ny * T.e)


#: How GIS tools pair two grids into one vector: QGIS's mesh layers (its mesh data abstraction library, reading
#: NetCDF through GDAL) join two bands whose names contain an "x"/"u" and a "y"/"v" component phrase and that are
#: the same once it is removed, and draw them as arrows along the map axes.
_COMPONENT = re.compile(r"^(?:(?P<axis>[xyuv])[- ]component(?: of)?|(?P<start>[xyuv])-)\s*(?P<rest>.*)$", re.I)
_ANYWHERE = re.compile(r"[xyuv][- ]component", re.I)


def test_gis_tools_pair_the_map_velocity_into_arrows(cycle_file):
    """The one velocity a GIS draws as arrows is along the map axes: on a north-up grid ``u``/``v``, on a
    turned grid ``u_east``/``v_north`` — whose values are the grid components turned by the frame's angle
    (east = u cos a − v sin a, north = u sin a + v cos a) — and the grid-axis ``u``/``v`` of a turned grid are
    not named as a pair (QGIS would draw them turned by the grid's angle)."""
    angle, path = cycle_file
    with xr.open_dataset(path) as ds:
        ds = ds.isel(cycle=0).load()
    pairs: dict[str, dict[str, str]] = {}
    for name, var in ds.data_vars.items():
        if var.dims[-2:] != ("y", "x"):
            continue
        long_name = str(var.attrs.get("long_name", ""))
        m = _COMPONENT.match(long_name)
        if m is None:
            assert not _ANYWHERE.search(long_name), f"{name}: {long_name!r} names a component a GIS would misread"
            continue
        axis = (m["axis"] or m["start"]).lower().replace("u", "x").replace("v", "y")
        pairs.setdefault(m["rest"].strip(), {})[axis] = name
    assert len(pairs) == 1, pairs
    (vector,) = pairs.values()
    turned = angle != 0.0
    assert vector == ({"x": "u_east", "y": "v_north"} if turned else {"x": "u", "y": "v"})
    if turned:
        a = np.radians(ds.attrs["grid_rotation_deg"])
        u, v = ds["u"].values, ds["v"].values
        np.testing.assert_allclose(ds["u_east"].values, u * np.cos(a) - v * np.sin(a), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds["v_north"].values, u * np.sin(a) + v * np.cos(a), rtol=0, atol=1e-12)


def test_open_north_up_puts_every_cell_at_its_map_position(cycle_file):
    """:func:`breachflow.io.north_up.open_north_up` (GDAL's warper): a north-up raster in the site's CRS
    covering the whole grid; the pixel that holds each cell's map centre (``map_x``/``map_y``, or the 1-D
    axes north-up) carries that cell's value, exactly, at pixels of the cell size / √2 (a turned grid) and at
    the default pixel, the cell size (a north-up grid: its own cells)."""
    from pyproj import CRS

    from breachflow.io.north_up import open_north_up

    angle, path = cycle_file
    with xr.open_dataset(path) as ds:
        ds = ds.isel(cycle=0).load()
    cell = float(ds.x[1] - ds.x[0])
    MX, MY = _expected_map(ds)
    for res in ([None, 0.99 * cell / np.sqrt(2)] if angle == 0.0 else [0.99 * cell / np.sqrt(2)]):
        da = open_north_up(path, "depth", resolution=res)
        assert da.dims == ("cycle", "y", "x") and da.sizes["cycle"] == 1
        assert CRS.from_wkt(da["crs"].attrs["crs_wkt"]).to_epsg() == 26915 and da.attrs["grid_mapping"] == "crs"
        x, y = da.x.values, da.y.values
        px, py = x[1] - x[0], y[1] - y[0]
        assert px > 0 and py < 0 and px == pytest.approx(res or cell) and -py == pytest.approx(res or cell)
        col = np.floor((MX - (x[0] - px / 2)) / px).astype(int)
        row = np.floor((MY - (y[0] - py / 2)) / py).astype(int)
        assert col.min() >= 0 and row.min() >= 0 and col.max() < x.size and row.max() < y.size
        got = da.values[0][row, col]
        want = ds["depth"].values
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
        np.testing.assert_array_equal(got[~np.isnan(want)], want[~np.isnan(want)])


def test_open_north_up_names_what_it_cannot_read(cycle_file, tmp_path):
    from breachflow.errors import InputError
    from breachflow.io.north_up import open_north_up

    _, path = cycle_file
    with pytest.raises(InputError, match="'particle_x' is not a map grid.*depth"):
        open_north_up(path, "particle_x")
    with pytest.raises(InputError, match="no such file"):
        open_north_up(tmp_path / "missing.nc", "depth")
    with pytest.raises(InputError, match="resampling 'closest'"):
        open_north_up(path, "depth", resampling="closest")
    with pytest.raises(InputError, match="resolution"):
        open_north_up(path, "depth", resolution=0.0)
