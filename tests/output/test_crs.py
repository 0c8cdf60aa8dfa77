"""CRS of what breachflow writes (issue 15): ``--crs EPSG:nnnn`` stored as WKT GDAL/pyproj read, a CRS
whose units disagree with the data's is an error, the CF/GDAL check flags an unreadable CRS, and closure
runs have a definite default CRS."""
import importlib.util
import sys
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr
from pyproj import CRS, Transformer
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.cycle.config import closure_setup
from breachflow.errors import InputError, ParseError
from breachflow.field.crs import LOCAL_CRS, resolve_crs
from breachflow.io import open_snapshot
from breachflow.scenario.config import parse_scenario

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "hydro_io" / "data"
ADH = [DATA / n for n in ("adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc")]  # metres (MP G 9.81)
runner = CliRunner()


def _cf_check_module():
    spec = importlib.util.spec_from_file_location("breachflow_tools_cf_check_crs", ROOT / "tools" / "cf_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def test_ingest_crs_epsg_is_stored_as_wkt_that_pyproj_and_gdal_read(tmp_path):
    out = tmp_path / "snap.nc"
    res = runner.invoke(app, ["ingest", *map(str, ADH), "-o", str(out), "--crs", "EPSG:32615"], terminal_width=200)
    assert res.exit_code == 0, res.output
    with xr.open_dataset(out) as ds:
        wkt = ds.crs.attrs["crs_wkt"]
        assert ds.crs.attrs["spatial_ref"] == wkt and ds.depth.attrs["grid_mapping"] == "crs"
    assert CRS.from_wkt(wkt) == CRS.from_epsg(32615)
    assert _cf_check_module().crs_problems(out) == []


@pytest.mark.parametrize("crs, match", [
    ("EPSG:3452", "US survey foot .* coordinates are in m"),  # NAD83 / Louisiana South (ftUS) on a mesh in metres
    ("EPSG:4326", "angular"),                                  # lon/lat on projected metres
    ("EPSG:999999", "cannot interpret"),
    ("not a crs", "cannot interpret"),
])
def test_ingest_refuses_a_crs_that_disagrees_with_the_data_or_cannot_be_read(tmp_path, crs, match):
    with pytest.raises(InputError, match=match):
        open_snapshot(ADH, crs=crs)
    out = tmp_path / "snap.nc"
    res = runner.invoke(app, ["ingest", *map(str, ADH), "-o", str(out), "--crs", crs], terminal_width=200)
    assert res.exit_code != 0 and not out.exists()
    assert isinstance(res.exception, InputError) and "crs" in str(res.exception)


def test_a_crs_in_feet_for_data_in_feet_lands_where_the_feet_put_it():
    """HEC-RAS export in US survey feet with NAD83 / Louisiana South (ftUS): the stored coordinates are
    metres, the stored CRS the same projection with metre axes, so every node maps to the same lon/lat."""
    with pytest.warns(Warning, match="overrides the file's UNITS"):
        ds = open_snapshot(DATA / "RASExport.sdf", units="survey_foot", crs="EPSG:3452")
    stored = CRS.from_wkt(ds.crs.attrs["crs_wkt"])
    assert [a.unit_name for a in stored.axis_info] == ["metre", "metre"]
    ftus = 1200.0 / 3937.0
    x, y = ds.mesh2d_node_x.values, ds.mesh2d_node_y.values
    lon_s, lat_s = Transformer.from_crs(stored, "EPSG:4326", always_xy=True).transform(x, y)
    lon_g, lat_g = Transformer.from_crs("EPSG:3452", "EPSG:4326", always_xy=True).transform(x / ftus, y / ftus)
    np.testing.assert_allclose(lon_s, lon_g, atol=1e-10)
    np.testing.assert_allclose(lat_s, lat_g, atol=1e-10)
    # international feet are not US survey feet (2 ppm: metres off at state-plane offsets)
    with pytest.raises(InputError, match="survey_foot"):
        open_snapshot(DATA / "RASExport.sdf", crs="EPSG:3452")  # the file's UNITS: US CUSTOMARY = ft


def test_site_crs_in_feet_or_degrees_is_a_scenario_error_naming_the_line():
    text = '[scenario]\nname = "x"\n[site]\npreset = "demo_breach"\ncrs = "EPSG:3452"\n'
    with pytest.raises(ParseError, match=r"\[site\] crs: .*US survey foot") as exc:
        parse_scenario(text)
    assert exc.value.line == 5
    with pytest.raises(ParseError, match="angular"):
        parse_scenario(text.replace("EPSG:3452", "EPSG:4326"))


def test_closure_runs_default_to_the_documented_local_crs():
    dom = closure_setup(parse_scenario('[scenario]\nname = "x"\n')).domain
    crs = CRS.from_wkt(dom.crs_wkt)
    assert crs.is_projected and crs == CRS.from_user_input(resolve_crs(LOCAL_CRS))
    # x = y = 0 (the breach centre) is the documented origin: 30.0168 N, 90.1213 W
    lon, lat = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(0.0, 0.0)
    assert (lon, lat) == pytest.approx((-90.1213, 30.0168), abs=1e-9)
    # 100 m east is 100 m east (scale factor 1 at the origin)
    lon1, lat1 = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(100.0, 0.0)
    from pyproj import Geod

    assert Geod(ellps="WGS84").inv(lon, lat, lon1, lat1)[2] == pytest.approx(100.0, rel=1e-6)


def test_the_check_flags_a_requested_crs_nobody_can_read(tmp_path):
    """What ``--crs EPSG:32615`` used to store: the text "EPSG:32615" as crs_wkt, which GDAL ignores."""
    ds = open_snapshot(ADH, crs="EPSG:32615")
    path = tmp_path / "bad.nc"
    ds.to_netcdf(path)
    mod = _cf_check_module()
    assert mod.crs_problems(path) == []
    with netCDF4.Dataset(path, "a") as nc:
        nc.variables["crs"].setncattr("crs_wkt", "EPSG:32615")
    problems = mod.crs_problems(path)
    assert problems and "crs_wkt is not WKT" in problems[0]
