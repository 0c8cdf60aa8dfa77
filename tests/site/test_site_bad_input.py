"""Bad site input: a clear error naming the file and the value, and nothing written (issue 13)."""
import json

import pytest

from breachflow.cycle.main import run_closure
from breachflow.errors import BreachflowError

from .conftest import SITE, site_toml

pytest.importorskip("rasterio")


def _fails(tmp_path, match, **kw):
    path = site_toml(tmp_path, **kw)
    out = tmp_path / "run"
    with pytest.raises(BreachflowError, match=match):
        run_closure(path, out, plots=False)
    assert not out.exists(), "nothing may be written for bad input"


def test_terrain_not_covering_the_breach(tmp_path):
    # the levee line starts 5 m west of the DEM: a breach at chainage 3 m lies outside it
    _fails(tmp_path, r"terrain\.tif: the terrain \(x 676000\.0…676240\.0.*does not cover the breach \(no elevation at \(6759",
           replace={"breach_at": '"3 m"', "breach_length": '"4 m"'})


def test_breach_longer_than_the_levee(tmp_path):
    _fails(tmp_path, r"site\.toml: \[site\] breach_length = 500 m is longer than the levee .*levee\.geojson \(25\d\.\d m\)",
           replace={"breach_length": '"500 m"'})


def test_breach_running_off_the_end_of_the_levee(tmp_path):
    _fails(tmp_path, r"site\.toml: \[site\] breach_at = 250 m with breach_length = 12 m runs off the levee", replace={"breach_at": '"250 m"'})


def test_levee_that_does_not_cross_the_terrain(tmp_path):
    _fails(tmp_path, r"site\.toml: \[site\] levee_coords: the levee line \(x 600000\.0…600300\.0, y 3372100\.0…3372100\.0\) does not "
                     r"cross the terrain .*terrain\.tif",
           drop=("levee",), extra_site="levee_coords = [[600000.0, 3372100.0], [600300.0, 3372100.0]]")


def test_crs_mismatch_between_terrain_and_levee(tmp_path):
    doc = json.loads((SITE / "levee.geojson").read_text())
    doc["crs"]["properties"]["name"] = "urn:ogc:def:crs:EPSG::32615"  # WGS 84 / UTM 15N, not NAD83
    (tmp_path / "levee32615.geojson").write_text(json.dumps(doc))
    _fails(tmp_path, r"CRS mismatch: the terrain .*terrain\.tif is in NAD83 / UTM zone 15N \(EPSG:26915\) but the levee "
                     r".*levee32615\.geojson is in WGS 84 / UTM zone 15N \(EPSG:32615\)",
           replace={"levee": f'"{tmp_path / "levee32615.geojson"}"'})


def test_crs_given_in_the_scenario_contradicting_the_terrain(tmp_path):
    _fails(tmp_path, r"terrain\.tif: the terrain's CRS \(NAD83 / UTM zone 15N\) differs from \[site\] crs = 'EPSG:32616'",
           extra_site='crs = "EPSG:32616"')


def test_flood_level_below_the_breach_bottom(tmp_path):
    _fails(tmp_path, r"site\.toml: \[site\] flood_level: flood level 1\.500 m is not above the breach bottom 2\.000 m",
           replace={"flood_level": '"1.5 m"'})


def test_missing_terrain_file_names_file_and_line(tmp_path):
    _fails(tmp_path, r"site\.toml:\d+: \[site\] terrain: file not found: .*nowhere\.tif",
           replace={"terrain": '"nowhere.tif"'})


def test_stage_hydrograph_below_the_breach_bottom_names_the_csv(tmp_path):
    (tmp_path / "stage.csv").write_text("time [h], stage [ft]\n0, 4.0\n1, 5.0\n")
    _fails(tmp_path, r"stage\.csv: flood level 1\.524 m is not above the breach bottom 2\.000 m",
           drop=("flood_level",), extra_site=f'flood_stage = "{tmp_path / "stage.csv"}"')
