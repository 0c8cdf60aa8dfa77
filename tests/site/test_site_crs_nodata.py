"""Issue 27: a terrain without a CRS is refused unless the scenario states it ([site] crs), and NODATA / NaN
cells at the breach are reported as such (not as a terrain that "does not cover the breach")."""
import json

import numpy as np
import pytest

from breachflow.cycle.main import run_closure
from breachflow.errors import BreachflowError

from .conftest import SITE, site_toml

rasterio = pytest.importorskip("rasterio")


def _copy_dem(tmp_path, name, *, crs=True, nan_at=None, half=8.0):
    """terrain.tif copied to *name*: without its CRS, and/or NaN within *half* m of map point *nan_at*."""
    with rasterio.open(SITE / "terrain.tif") as src:
        z = src.read(1).astype("float32")
        profile = dict(src.profile)
        t = src.transform
    if nan_at is not None:
        cols = t.c + (np.arange(z.shape[1]) + 0.5) * t.a
        rows = t.f + (np.arange(z.shape[0]) + 0.5) * t.e
        X, Y = np.meshgrid(cols, rows)
        z[(np.abs(X - nan_at[0]) <= half) & (np.abs(Y - nan_at[1]) <= half)] = np.nan
    profile.update(dtype="float32", nodata=None)
    if not crs:
        profile.pop("crs", None)
    out = tmp_path / name
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(z, 1)
    return out


def _breach_point():
    """The breach centre (map coordinates): the levee line's point at chainage 125 m, measured here."""
    coords = np.asarray(json.loads((SITE / "levee.geojson").read_text())["features"][0]["geometry"]["coordinates"], float)
    seg = np.hypot(*np.diff(coords, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    k = int(np.searchsorted(s, 125.0) - 1)
    f = (125.0 - s[k]) / seg[k]
    return coords[k] + f * (coords[k + 1] - coords[k])


def test_a_terrain_without_a_crs_is_refused_unless_the_scenario_states_it(tmp_path):
    dem = _copy_dem(tmp_path, "nocrs.tif", crs=False)
    path = site_toml(tmp_path, replace={"terrain": f'"{dem}"'})
    out = tmp_path / "run"
    with pytest.raises(BreachflowError, match=r"nocrs\.tif: the terrain has no CRS .*\[site\] crs = \"EPSG:nnnn\""):
        run_closure(path, out, plots=False)
    assert not out.exists()
    # stated by the user: accepted (the setup builds; the outputs then carry that CRS)
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario import load_scenario

    stated = site_toml(tmp_path, replace={"terrain": f'"{dem}"'}, extra_site='crs = "EPSG:26915"')
    setup = closure_setup(load_scenario(stated))
    assert "26915" in setup.domain.crs_wkt or "UTM zone 15N" in setup.domain.crs_wkt


def test_nan_terrain_at_the_breach_is_named_as_such(tmp_path):
    dem = _copy_dem(tmp_path, "hole.tif", nan_at=_breach_point())
    path = site_toml(tmp_path, replace={"terrain": f'"{dem}"'})
    out = tmp_path / "run"
    with pytest.raises(BreachflowError) as info:
        run_closure(path, out, plots=False)
    msg = str(info.value)
    assert "hole.tif: the terrain has no elevation (NODATA / NaN cells) at the breach" in msg
    assert "does not cover" not in msg
    assert not out.exists()
