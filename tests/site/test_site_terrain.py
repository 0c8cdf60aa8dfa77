"""Site terrain, levee geometry, breach cut and domain (issue 13), against closed forms."""
import json

import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.swe.domain import levee_bed
from breachflow.scenario.geometry import BreachGeometry
from breachflow.cycle.config import demo_breach
from breachflow.site import SiteSpec, build_site, load_levee, load_terrain

from .conftest import SITE

rasterio = pytest.importorskip("rasterio")
from rasterio.transform import from_origin  # noqa: E402

E0, N0 = 500100.0, 4100200.0


def _write_tif(path, z, x0, ytop, pixel, *, crs="EPSG:32615", unit=None):
    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float64",
                       crs=crs, transform=from_origin(x0, ytop, pixel, pixel), nodata=-9999.0) as dst:
        dst.write(z, 1)
        if unit:
            dst.set_band_unit(1, unit)


def _plane(X, Y):
    return 3.0 + 0.01 * (X - E0) - 0.02 * (Y - N0)


@pytest.mark.parametrize("unit,scale", [(None, 1.0), ("m", 1.0), ("ft", 0.3048), ("US survey foot", 1200 / 3937)])
def test_geotiff_plane_sampled_exactly_and_feet_converted_once(tmp_path, unit, scale):
    pix = 2.0
    xc = E0 + (np.arange(30) + 0.5) * pix
    yc = N0 + 40 - (np.arange(20) + 0.5) * pix
    X, Y = np.meshgrid(xc, yc)
    _write_tif(tmp_path / "p.tif", _plane(X, Y), E0, N0 + 40, pix, unit=unit)
    t = load_terrain(tmp_path / "p.tif")
    assert np.all(np.diff(t.y) > 0) and np.all(np.diff(t.x) > 0)
    rng = np.random.default_rng(3)
    px, py = rng.uniform(E0 + 1, E0 + 59, 50), rng.uniform(N0 + 1, N0 + 39, 50)
    # bilinear interpolation of a plane is exact
    np.testing.assert_allclose(t.sample(px, py), scale * _plane(px, py), rtol=1e-12, atol=1e-9)
    assert "UTM zone 15N" in t.crs_wkt


def test_declared_unit_contradicting_the_scenario_is_an_error(tmp_path):
    z = np.ones((4, 4))
    _write_tif(tmp_path / "ft.tif", z, E0, N0 + 4, 1.0, unit="ft")
    with pytest.raises(InputError, match=r"ft\.tif.*declares vertical unit 'ft'.*terrain_units = 'm'"):
        load_terrain(tmp_path / "ft.tif", vertical_units="m")


def test_esri_ascii_with_prj_and_netcdf_dem_agree_with_geotiff(tmp_path):
    pix = 2.0
    xc = E0 + (np.arange(12) + 0.5) * pix
    yc = N0 + 20 - (np.arange(10) + 0.5) * pix
    X, Y = np.meshgrid(xc, yc)
    z = _plane(X, Y)
    asc = tmp_path / "d.asc"
    asc.write_text(f"ncols 12\nnrows 10\nxllcorner {E0}\nyllcorner {N0}\ncellsize {pix}\nNODATA_value -9999\n"
                   + "\n".join(" ".join(f"{v:.6f}" for v in row) for row in z) + "\n")
    from pyproj import CRS

    (tmp_path / "d.prj").write_text(CRS.from_epsg(32615).to_wkt("WKT1_ESRI"))
    import xarray as xr

    nc = tmp_path / "d.nc"
    ds = xr.Dataset({"elevation": (("y", "x"), z[::-1] / 0.3048, {"units": "ft", "grid_mapping": "crs"}),
                     "crs": ((), 0, {"crs_wkt": CRS.from_epsg(32615).to_wkt()})}, coords={"x": xc, "y": yc[::-1]})
    ds.to_netcdf(nc)
    ta, tn = load_terrain(asc), load_terrain(nc)
    for t in (ta, tn):
        np.testing.assert_allclose(t.sample(X[2:-2, 2:-2], Y[2:-2, 2:-2]), z[2:-2, 2:-2], atol=1e-5)
        assert CRS.from_wkt(t.crs_wkt).to_epsg() == 32615


def _demo_dem(tmp_path, pixel=0.5):
    """The demo scene's intact levee (no breach) as a GeoTIFF in UTM, levee centreline along y = N0."""
    scene = demo_breach()
    intact = BreachGeometry(length=1e-3, depth=1e-3, wall_slope=0.0)
    from dataclasses import replace

    sc = replace(scene, breach=intact)
    nx, ny = 160, 200
    xc = E0 - 40 + (np.arange(nx) + 0.5) * pixel
    yc = N0 + 50 - (np.arange(ny) + 0.5) * pixel
    X, Y = np.meshgrid(xc, yc)
    z = levee_bed(sc, X - E0, Y - N0)
    _write_tif(tmp_path / "demo.tif", z, E0 - 40, N0 + 50, pixel)
    return scene, tmp_path / "demo.tif"


def test_breach_cut_reproduces_the_scene_builders_trapezoid(tmp_path):
    """Cutting the demo breach into its intact levee DEM gives breach_domain's analytic bed (levee_bed)
    at every cell centre, for vertical and sloped walls. (Flat ground both sides and a polder that falls
    away: the terrain cannot tell the flood side, so it is given.)"""
    scene, tif = _demo_dem(tmp_path)
    for wall in (0.0, 1.0):
        br = BreachGeometry(length=12.0, depth=3.0, wall_slope=wall)
        from dataclasses import replace

        sc = replace(scene, breach=br)
        spec = SiteSpec(terrain=tif, levee_coords=[[E0 - 45, N0], [E0 + 45, N0]], breach_at=45.0, breach_length=12.0,
                        breach_bottom=0.0, breach_wall_slope=wall, flood_level=2.7, extent_along=14.0,
                        extent_flood=20.0, extent_protected=20.0, flood_side="right")
        site = build_site(spec, 0.5)
        d = site.domain
        X, Y = np.meshgrid(d.x, d.y)
        expected = levee_bed(sc, X - E0, Y - N0)
        # away from the 0.5 m DEM's own bilinear smoothing of the levee's slope breaks (crest edges, toes)
        np.testing.assert_allclose(d.bed, expected, atol=0.13)
        inside = (np.abs(X - E0) < 6.0 - wall * 3.0 - 0.3) & (np.abs(Y - N0) < 1.0)
        assert inside.any() and np.allclose(d.bed[inside], 0.0, atol=1e-9)
        assert site.breach.crest == pytest.approx(3.0, abs=1e-9)
        assert site.half_width == pytest.approx(7.5, abs=0.5)  # crown/2 + 3 m x slope 2
        assert site.report["flood_side"].endswith("(south)")


def test_example_site_domain_has_real_coordinates_and_flood_side(make_site, tmp_path):
    spec = SiteSpec(terrain=SITE / "terrain.tif", levee=SITE / "levee.geojson", breach_at=125.0, breach_length=12.0,
                    breach_bottom=2.0, breach_wall_slope=0.0, flood_level=4.7)
    site = build_site(spec, 1.0)
    d = site.domain
    assert site.centre == pytest.approx((676120.0, 3372100.0))
    assert d.x[0] > 676000 and d.y[0] > 3371980 and "UTM zone 15N" in d.crs_wkt
    assert d.boundaries["south"][0].kind == "level" and d.boundaries["north"][0].kind == "outflow"
    # breach cut to 2.0 m, intact crest around 5 m (+ noise) just outside it
    j = int(np.argmin(np.abs(d.y - 3372100.0)))
    assert np.all(d.bed[j, np.abs(d.x - 676120.0) < 5.5] == 2.0)
    assert np.all(d.bed[j, np.abs(d.x - 676120.0) > 7.0] > 4.8)
    # the same levee digitised the other way: the flood side is now the left, still south
    rev = json.loads((SITE / "levee.geojson").read_text())
    coords = rev["features"][0]["geometry"]["coordinates"][::-1]
    rev["features"][0]["geometry"]["coordinates"] = coords
    (tmp_path / "rev.geojson").write_text(json.dumps(rev))
    lev = load_levee(tmp_path / "rev.geojson")
    spec2 = SiteSpec(terrain=SITE / "terrain.tif", levee=tmp_path / "rev.geojson", breach_at=lev.length - 125.0,
                     breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0, flood_level=4.7)
    site2 = build_site(spec2, 1.0)
    assert site2.report["flood_side"] == "left of the levee line (south)"
    np.testing.assert_array_equal(site2.domain.bed, d.bed)


def test_committed_example_files_are_what_the_script_writes(make_site, tmp_path):
    tif, geo = make_site.write(tmp_path)
    a, b = load_terrain(tif), load_terrain(SITE / "terrain.tif")
    np.testing.assert_array_equal(a.z, b.z)
    assert a.crs_wkt == b.crs_wkt
    assert json.loads(geo.read_text()) == json.loads((SITE / "levee.geojson").read_text())
    # lidar-like: 1 cm steps, noise of a few cm on the flat polder
    assert np.allclose(np.round(a.z * 100), a.z * 100, atol=1e-3)
