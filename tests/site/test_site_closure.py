"""The example site closes its breach (CI-sized) and writes cycle files on the map (issue 13)."""
import json

import numpy as np
import pytest
import xarray as xr
from pyproj import CRS

from breachflow.cycle.main import run_closure

from .conftest import ROOT, site_toml

pytest.importorskip("rasterio")


def test_example_site_closes_its_breach_ci_sized(tmp_path):
    """``examples/site/site.toml`` at 1.5 m cells (the README's command uses 1 m): the breach closes, the
    cycle files carry EPSG:26915 and real coordinates around the levee, the manifest reports the site."""
    path = site_toml(tmp_path, {"resolution": '"1.5 m"'})
    res = run_closure(path, tmp_path / "run", plots=False)
    assert res.closed, [r.governing for r in res.reports]
    assert res.reports[0].breach_discharge > 10.0  # water really went through the breach before closing
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    site = man["metadata"]["site"]
    assert site["flood_side"].endswith("(south)") and site["crs"].endswith("(EPSG:26915)")
    assert man["metadata"]["initial"]["breach_discharge"] > 30.0
    with xr.open_dataset(tmp_path / "run" / "cycle_0001.nc") as ds:
        assert CRS.from_wkt(ds["crs"].attrs["crs_wkt"]).to_epsg() == 26915
        assert ds["depth"].attrs["grid_mapping"] == "crs"
        # the breach centre (676120, 3372100) is inside the grid, which lies inside the DEM
        assert 676000 < ds.x.min() < 676120 < ds.x.max() < 676240
        assert 3371980 < ds.y.min() < 3372100 < ds.y.max() < 3372180
        assert ds.attrs["site_breach_centre"] == "676120.000 3372100.000"
        # the placed masses are in the breach, in real coordinates
        px = ds["particle_x"].values
        px = px[np.isfinite(px)]  # padded to the run's particle capacity
        assert px.size == 5 and np.all(np.abs(px - 676120.0) < 8.0)
    import importlib.util

    spec = importlib.util.spec_from_file_location("cf_check", ROOT / "tools" / "cf_check.py")
    cf = importlib.util.module_from_spec(spec)
    import sys

    sys.modules.setdefault("cf_check", cf)
    spec.loader.exec_module(cf)
    info = cf.gdal_info(tmp_path / "run" / "cycle_0001.nc")
    if info is None:
        pytest.skip("gdalinfo not installed (Debian gdal-bin): GIS placement not checked")
    assert info["crs"] == "NAD83 / UTM zone 15N"
    with xr.open_dataset(tmp_path / "run" / "cycle_0001.nc") as ds:
        assert info["origin"] == pytest.approx((float(ds.x[0]) - 0.75, float(ds.y[-1]) + 0.75))
