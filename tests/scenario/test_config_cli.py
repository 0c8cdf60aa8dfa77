"""Scenario TOML (units, strict keys, extensible sections), the CLI commands and the Table 2.6 pipeline."""
import runpy
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from breachflow import ParseError
from breachflow.cli import app
from breachflow.scenario import closure_window, load_scenario, parse_scenario, register_section, run_scenario
from breachflow.scenario.config import sections

H = 3600.0
GOOD = """\
[scenario]
name = "test"

[flood]
surge_height = "9.2 ft"
fall_rate = ["40 cm/hr", "6 cm/hr"]

[polder]
area = "800 ha"
inundation_depth = "90 cm"

[breach]
length = "30 m"
mean_velocity = "3 m/s"
growth = ["2.7", "verheij_sand"]
max_length = "2.11"
development_time = ["1 h", "4 h"]
"""


def test_scenario_file_with_units_and_sweeps(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    result = run_scenario(path)
    ds = result.window
    assert ds.closure_window.dims == ("fall_rate",)
    h_w = 9.2 * 0.3048
    r_p = h_w * 30 * 3 / 8e6 * H
    np.testing.assert_allclose(ds.balance_time.values / H, [h_w / (0.4 + r_p), h_w / (0.06 + r_p)], rtol=1e-12)
    assert result.growth.sel(equation="verheij_clay").values[1] == pytest.approx(13.4 * 4 ** 0.51)
    assert result.growth.attrs["max_length_m"] == pytest.approx(5.19 * np.exp(0.75 * h_w))


@pytest.mark.parametrize("text, line, message", [
    (GOOD.replace('area = "800 ha"', 'areaa = "800 ha"'), 9, "unknown key; did you mean 'area'"),
    (GOOD.replace('area = "800 ha"', 'area = "800 m/s"'), 9, r"\[polder\] area: .*\[length\] \*\* 2"),
    (GOOD.replace('inundation_depth = "90 cm"', 'inundation_depth = 0.9'), 10, "bare number"),
    (GOOD + "\n[polderr]\nx = 1\n", 19, r"unknown section \[polderr\]"),
    (GOOD.replace('max_length = "2.11"', 'max_length = "2.99"'), 16, "neither a maximum-length equation"),
    (GOOD.replace('surge_height = "9.2 ft"', 'surge_height = "nan ft"'), 5, "not finite"),
    (GOOD.replace('[polder]', '[polder'), 8, "invalid TOML"),
])
def test_scenario_errors_name_file_and_line(tmp_path, text, line, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ParseError, match=message) as err:
        load_scenario(path)
    assert err.value.line == line and err.value.path == str(path)


def test_later_subsystems_can_add_sections():
    @dataclass
    class Demo:
        resolution: float

        @classmethod
        def from_table(cls, table, ctx):
            ctx.check_keys(table, {"resolution"})
            return cls(ctx.quantity(table, "resolution", "length", required=True, positive=True))

    register_section("test_demo_section", Demo)
    try:
        s = parse_scenario('[test_demo_section]\nresolution = "2 ft"\n')
        assert s["test_demo_section"].resolution == pytest.approx(0.6096)
        with pytest.raises(ParseError, match="unknown key"):
            parse_scenario('[test_demo_section]\nresolution = "2 ft"\nspeed = 3\n')
    finally:
        sections._items.pop("test_demo_section")


def test_measured_hydrograph_and_wind_in_a_scenario(tmp_path):
    (tmp_path / "stage.csv").write_text("time [h], stage [ft]\n" + "\n".join(
        f"{t}, {max(2.8 - 0.4 * abs(t), 0) / 0.3048}" for t in range(-6, 13)) + "\n")
    (tmp_path / "wind.csv").write_text("time [h], speed [mph]\n-6, 60\n0, 60\n6, 0\n12, 0\n")
    (tmp_path / "s.toml").write_text(
        '[flood]\nhydrograph = "stage.csv"\n[polder]\narea = "800 ha"\ninundation_depth = "90 cm"\n'
        '[breach]\ndischarge = "7062.9 cfs"\n[wind]\nrecord = "wind.csv"\nlimit = "land"\n')
    ds = run_scenario(tmp_path / "s.toml").window
    assert float(ds.balance_time) / H == pytest.approx(2.8 / (0.4 + 7062.9 * 0.3048 ** 3 / 8e6 * H), rel=1e-9)
    mph = 0.44704
    assert float(ds.work_start_delay) / H == pytest.approx(6 * (1 - 13 / (60 * mph)), rel=1e-9)


runner = CliRunner()


def test_cli_model_problem_prints_table_2_5(tmp_path):
    out = tmp_path / "mp.nc"
    res = runner.invoke(app, ["model-problem", "--output", str(out)], terminal_width=160)
    assert res.exit_code == 0, res.output
    for text in ("5.71 h", "18.7 h", "10 h", "51.4 cm", "90 cm", "breach balance", "polder inundation", "Nagy"):
        assert text in res.output
    ds = xr.open_dataset(out)
    assert ds.closure_window.dims == ("case",) and ds.closure_window.attrs["units"] == "s"
    ds.close()


def test_cli_window_and_growth_write_plots(tmp_path):
    png = tmp_path / "w.png"
    res = runner.invoke(app, ["window", "--surge-height", "9.2 ft", "--fall-rate", "40 cm/hr", "--polder-area",
                              "1977 acre", "--inundation-depth", "90 cm", "--discharge", "7060 cfs",
                              "--plot", str(png)], terminal_width=160)
    assert res.exit_code == 0, res.output
    assert "5.7" in res.output and png.stat().st_size > 10_000
    res = runner.invoke(app, ["window", "--preset", "katrina", "--polder-area", "-3 ha", "--inundation-depth", "1 m",
                              "--discharge", "100 m^3/s"])
    assert res.exit_code != 0 and "--polder-area" in str(res.exception)  # the CLI flag, not the keyword (issue 15)
    png = tmp_path / "g.png"
    res = runner.invoke(app, ["growth", "--levee-height", "10 ft", "--max-length", "nagy", "--plot", str(png)],
                        terminal_width=160)
    assert res.exit_code == 0, res.output
    assert "Verheij" in res.output and png.stat().st_size > 10_000


def test_cli_run_scenario_file(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    res = runner.invoke(app, ["run", str(path)], terminal_width=160)
    assert res.exit_code == 0, res.output
    assert "Breach closure window" in res.output and "Verheij" in res.output


def test_table_2_6_pipeline_writes_netcdf_and_figure(tmp_path):
    script = Path(__file__).resolve().parents[2] / "pipelines" / "table_2_6.py"
    module = runpy.run_path(str(script))
    assert module["main"]([str(tmp_path)]) == 0
    ds = xr.open_dataset(tmp_path / "table_2_6.nc")
    assert ds.closure_window.size == 72 and ds.balance_reached.dtype == np.int8
    ref = closure_window(surge_height="3.5 m", fall_rate="0.02 m/h", breach_length="12 m", polder_area="4000 ha",
                         inundation_depth="1.5 m")
    cell = ds.sel(surge_height=3.5, fall_rate=0.02 / H, breach_length=12.0, polder_area=4e7, inundation_depth=1.5)
    assert float(cell.closure_window) == pytest.approx(float(ref.closure_window), rel=1e-12)
    ds.close()
    assert (tmp_path / "table_2_6.png").stat().st_size > 20_000
