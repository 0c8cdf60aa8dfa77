"""The ``[bed]`` section: parsing and its errors, the rough terrain and the near-bed forces reaching the DEM of a
closure run, and the per-cycle scour estimate of an erodible bed (summary and map)."""
import json

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.main import run_closure
from breachflow.errors import InputError, ParseError
from breachflow.fluid.nearbed import PEAK_FACTOR
from breachflow.scenario.config import parse_scenario

from .test_snapshot_frozen import BASE, _snapshot


def scenario(bed: str, snap="x.nc", solver="swe"):
    text = BASE.replace("{solver}", solver).replace("{snap}", str(snap))
    if solver == "swe":
        text = text.replace(f'snapshots = ["{snap}"]', "")
    return text + "\n[bed]\n" + bed


def test_bed_section_parses_to_the_settings():
    s = closure_setup(parse_scenario(scenario('grain_size = "0.3 m"\nerodible = true')))
    b = s.dem.bed
    assert b.roughness.kind == "natural" and b.roughness.grain_size == 0.3 and b.erodible
    assert b.near_bed[2] == PEAK_FACTOR
    s = closure_setup(parse_scenario(scenario('kind = "protection"\ngrain_size = "1 m"\nthickness = "2 m"\n'
                                              'near_bed = false')))
    assert s.dem.bed.roughness.kind == "protection" and s.dem.bed.near_bed is None
    assert closure_setup(parse_scenario(BASE.replace("{solver}", "swe").replace('snapshots = ["{snap}"]', ""))
                         ).dem.bed is None


@pytest.mark.parametrize("bed,key", [('kind = "gravel"\ngrain_size = "1 m"', "kind"),
                                     ("erodible = true", "erodible"),
                                     ('grain_size = "1 m"\nscour_time = "1 hr"', "scour_time"),
                                     ('grain_size = "1 m"\nlift_coefficient = -1', "lift_coefficient"),
                                     ('grain_size = "1 m"\nwidth = 3', "width")])
def test_bad_bed_keys_name_the_key(bed, key):
    with pytest.raises((InputError, ParseError), match=rf"\[bed\].*{key}|{key}.*\[bed\]"):
        closure_setup(parse_scenario(scenario(bed)))


def test_a_run_on_an_erodible_bed_reports_its_scour(tmp_path):
    path, ds = _snapshot(tmp_path)
    sc = tmp_path / "bed.toml"
    sc.write_text(scenario('grain_size = "0.2 mm"\nerodible = true', path, "snapshot_frozen"))
    with pytest.warns(Warning):
        run_closure(sc, tmp_path / "run", plots=False)
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    summ = man["cycles"][0]["summary"]
    assert summ["scour_depth"] > 0.0 and np.isfinite(summ["scour_x"]) and np.isfinite(summ["scour_y"])
    cyc = sorted((tmp_path / "run").glob("cycle_*.nc"))[0]
    with xr.open_dataset(cyc) as c:
        m = c["scour_depth"].isel(cycle=0)
        assert float(m.max()) == pytest.approx(summ["scour_depth"], rel=1e-12)
        j, i = np.unravel_index(int(np.argmax(m.values)), m.shape)
        assert float(c["x"][i]) == summ["scour_x"] and float(c["y"][j]) == summ["scour_y"]
