"""`breachflow run` checks its verdict by default: the check's runs, check.nc, the manifest, resume and
--no-check, on a shortened embedded default scenario (2 cycles at 2 m cells)."""
import json

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.cycle.main import default_scenario_text
from breachflow.scenario.toml import scenario_with

runner = CliRunner()


def short_scenario(tmp_path, **check):
    text = scenario_with(default_scenario_text(), {"hydro.resolution": "2 m", "criteria.max_cycles": 2,
                                                   "check.seeds": 2, "check.refine_seeds": 0,
                                                   **{f"check.{k}": v for k, v in check.items()}})
    path = tmp_path / "short.toml"
    path.write_text(text)
    return path


@pytest.mark.slow
def test_run_reports_the_check_writes_check_nc_and_resumes(tmp_path):
    scen = short_scenario(tmp_path, flow_mean_windows=0)  # the open breach's single accepted states
    out = tmp_path / "run"
    res = runner.invoke(app, ["run", str(scen), "--out", str(out), "--no-plots"], terminal_width=300)
    assert res.exit_code == 0, res.output
    assert "verdict check" in res.output and "P(closure)" in res.output
    ds = xr.open_dataset(out / "check.nc")
    # the run itself, one more seed at 2 m, the open breach at 1 m
    assert ds.sizes["run"] == 3
    assert list(ds["seed"].values[:2]) == [1, 2] and list(ds["cell_size"].values) == [2.0, 2.0, 1.0]
    assert int(ds["this_run"].sum()) == 1 and ds["closure_achieved"].values[2] == -1
    man = json.loads((out / "manifest.json").read_text())
    check = man["metadata"]["check"]
    assert check["statement"] == ds.attrs["statement"]
    closed = [r["outcome"] == "closed" for r in check["runs"][:2]]
    assert check["p_closure"] == pytest.approx(sum(closed) / 2)
    own = check["runs"][0]
    assert own["open_breach_discharge_m3_s"] == pytest.approx(man["metadata"]["initial"]["breach_discharge"])
    if not all(closed):
        assert not check["statement"].startswith("closed")
    fine = check["runs"][2]
    assert check["flow_difference"]["breach discharge"] == pytest.approx(
        fine["open_breach_discharge_m3_s"] / own["open_breach_discharge_m3_s"] - 1)
    member = next((out / "check" / "seeds" / "members").iterdir()) / "result.json"
    stamp = member.stat().st_mtime_ns
    # resume: nothing to do for the run, the check's member and open-breach solve are reused
    res2 = runner.invoke(app, ["run", "--out", str(out), "--resume", "--no-plots"], terminal_width=300)
    assert res2.exit_code == 0, res2.output
    assert member.stat().st_mtime_ns == stamp
    ds2 = xr.open_dataset(out / "check.nc")
    assert ds2.attrs["statement"] == ds.attrs["statement"]
    np.testing.assert_array_equal(ds2["open_breach_discharge"].values, ds["open_breach_discharge"].values)


@pytest.mark.slow
def test_the_check_compares_the_open_breach_as_time_means_by_default(tmp_path):
    scen = short_scenario(tmp_path)
    out = tmp_path / "run"
    res = runner.invoke(app, ["run", str(scen), "--out", str(out), "--no-plots"], terminal_width=300)
    assert res.exit_code == 0, res.output
    ds = xr.open_dataset(out / "check.nc")
    # the run itself, one more seed at 2 m, the open breach marched at 2 m and on the nested 1 m grid
    assert list(ds["cell_size"].values) == [2.0, 2.0, 2.0, 1.0]
    assert list(ds["closure_achieved"].values[2:]) == [-1, -1]
    interval = ds["open_flow_mean_interval"].values
    assert interval[0] == 0 and interval[2] > 0 and interval[3] > 0
    assert np.all(ds["open_breach_discharge_error"].values[2:] > 0)
    man = json.loads((out / "manifest.json").read_text())
    check = man["metadata"]["check"]
    coarse, fine = check["runs"][2], check["runs"][3]
    d = fine["open_breach_discharge_m3_s"] / coarse["open_breach_discharge_m3_s"] - 1
    assert check["flow_difference"]["breach discharge"] == pytest.approx(d)
    assert check["flow_difference_error"]["breach discharge"] > 0
    assert check["flow_mean_interval_s"] == [coarse["open_flow_mean_interval_s"], fine["open_flow_mean_interval_s"]]
    judged = abs(d) + 2 * check["flow_difference_error"]["breach discharge"] > check["tolerance"]
    assert ("breach discharge" in check["statement"].split("grid-converged")[-1]) == judged
    assert "time means over" in res.output


@pytest.mark.slow
def test_no_check_skips_it(tmp_path):
    scen = short_scenario(tmp_path)
    out = tmp_path / "run"
    res = runner.invoke(app, ["run", str(scen), "--out", str(out), "--no-plots", "--no-check"], terminal_width=300)
    assert res.exit_code == 0, res.output
    assert "verdict check" not in res.output and not (out / "check.nc").exists()
