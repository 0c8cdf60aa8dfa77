"""Per-cycle figures of a closure run are CF variables along ``cycle`` (cycle files, combine archive), and
a run's own files are accepted by ``breachflow inspect`` / ``export``.

Every figure checked here is recomputed from the cycle's own fields and particles (gap speeds from the
grid row at the levee line, the mass in place from the diameters, the max-speed criterion from the
velocity field), not compared with numbers the code printed earlier.
"""
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.scenario.config import parse_scenario

from ._scenes import tiny_closure

SCENARIO = tiny_closure("per-cycle figures", max_cycles=3, crs="EPSG:32615", density="2650 kg/m^3",
                        max_speed='{ threshold = "0.01 m/s", region = "domain" }')

#: the per-cycle global attributes of the files written before the figures became variables
OLD_ATTRS = ("gap_max_speed_m_s", "breach_discharge_m3_s", "masses_placed", "closure_achieved", "operation_time_s",
             "gap_speed_m_s", "tonnage_lost_t", "criterion_max_speed", "cycle", "verdict")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("percycle") / "run"
    run = ClosureRun(closure_setup(parse_scenario(SCENARIO)), out, SCENARIO)
    run.run()
    assert run.rundir.completed_cycles() == [1, 2, 3]
    return out


def _gap_row(ds):
    x0, x1, y = (float(v) for v in ds.attrs["breach_section"].split())
    j = int(np.argmin(np.abs(ds.y.values - y)))
    sel = (ds.x.values >= x0) & (ds.x.values <= x1) & (ds.wet.values[j] > 0)
    if "obstacle" in ds:
        sel &= ds.obstacle.values[j] == 0
    return j, sel


def _gap_section(ds):
    """Depth and speed on the levee line itself: per column of the gap (open in the row nearest it), the depth
    and unit discharges linearly between the two rows around the line (only an open one beside a closed one)."""
    x0, x1, y = (float(v) for v in ds.attrs["breach_section"].split())
    j, sel = _gap_row(ds)
    ys = ds.y.values
    k = j + 1 if ys[j] < y else j - 1
    w = (y - ys[j]) / (ys[k] - ys[j])
    ok_k = ds.wet.values[k] > 0
    if "obstacle" in ds:
        ok_k &= ds.obstacle.values[k] == 0
    wk = np.where(ok_k, w, 0.0)[sel]
    wj = 1.0 - w
    wj, wk = wj / (wj + wk), wk / (wj + wk)
    h = wj * ds.depth.values[j, sel] + wk * ds.depth.values[k, sel]
    qu = wj * (ds.depth * ds.u).values[j, sel] + wk * (ds.depth * ds.u).values[k, sel]
    qv = wj * (ds.depth * ds.v).values[j, sel] + wk * (ds.depth * ds.v).values[k, sel]
    wet = h > 0
    return h[wet], np.hypot(qu, qv)[wet] / h[wet]


def test_open_mfdataset_gives_each_figure_per_cycle(run_dir):
    with xr.open_mfdataset(str(run_dir / "cycle_*.nc"), data_vars="all") as ds:
        ds = ds.load()
    assert ds.cycle.values.tolist() == [1, 2, 3]
    for name in ("breach_discharge", "seepage_discharge", "gap_max_speed", "gap_mean_speed", "max_speed",
                 "masses_placed", "mass_in_place", "mass_lost", "mass_placed_cycle", "closure_achieved",
                 "criterion_max_speed", "criterion_max_speed_threshold", "criterion_max_speed_met",
                 "governing_criterion"):
        assert ds[name].dims == ("cycle",), name
    for name, units in (("breach_discharge", "m3 s-1"), ("gap_max_speed", "m s-1"), ("mass_in_place", "kg"),
                        ("criterion_max_speed", "m s-1"), ("criterion_max_speed_threshold", "m s-1")):
        assert ds[name].attrs["units"] == units and ds[name].attrs["long_name"], name
    assert ds["gap_max_speed"].attrs["standard_name"] == "flood_water_speed"
    assert not set(OLD_ATTRS) & set(ds.attrs), set(OLD_ATTRS) & set(ds.attrs)
    for k, g in enumerate(ds.cycle.values):
        one = ds.sel(cycle=g)
        h, speed = _gap_section(one)
        assert float(one.gap_max_speed) == pytest.approx(speed.max() if speed.size else 0.0, rel=1e-12)
        mean = np.sum(h * speed) / np.sum(h) if speed.size and np.sum(h) > 0 else 0.0
        assert float(one.gap_mean_speed) == pytest.approx(mean, rel=1e-12)
        # 2 masses a cycle; the mass in place: rho pi d^3 / 6 over the masses inside the domain
        placed = one.particle_placed_cycle.values > 0
        assert int(one.masses_placed) == placed.sum() == 2 * (k + 1)
        act = one.particle_active.values == 1
        d = one.particle_diameter.values[act]
        assert float(one.mass_in_place) == pytest.approx(np.sum(2650.0 * np.pi * d**3 / 6), rel=1e-9)
        assert float(one.mass_placed_cycle) == pytest.approx(
            np.sum(2650.0 * np.pi * one.particle_diameter.values[one.particle_placed_cycle.values == g] ** 3 / 6), rel=1e-9)
        # criterion max_speed (region "domain"): the largest speed over the wet cells, against 0.01 m/s
        wet = one.wet.values > 0
        if "obstacle" in one:
            wet &= one.obstacle.values == 0
        vmax = np.hypot(one.u.values, one.v.values)[wet].max()
        assert float(one.max_speed) == pytest.approx(vmax, rel=1e-9)
        assert float(one.criterion_max_speed) == pytest.approx(vmax, rel=1e-9)
        assert float(one.criterion_max_speed_threshold) == pytest.approx(0.01)
        assert int(one.criterion_max_speed_met) == int(vmax <= 0.01)


def test_combine_archive_holds_the_figures_of_every_cycle(run_dir, tmp_path):
    from breachflow.io import RunDirectory

    out = RunDirectory(run_dir).combine(tmp_path / "archive.nc")
    with xr.open_dataset(out) as arc, xr.open_mfdataset(str(run_dir / "cycle_*.nc"), data_vars="all") as cyc:
        assert arc.cycle.values.tolist() == [1, 2, 3]
        for name in ("breach_discharge", "gap_max_speed", "masses_placed", "mass_in_place", "criterion_max_speed"):
            assert arc[name].dims == ("cycle",)
            np.testing.assert_array_equal(arc[name].values, cyc[name].values)
        assert arc["governing_criterion"].dims == ("cycle",)
        assert arc["crs"].dims == ()  # one grid mapping, not one per cycle
        assert not set(OLD_ATTRS) & set(arc.attrs)


@pytest.mark.parametrize("which", ["cycle", "archive"])
def test_inspect_and_export_take_the_runs_own_files(run_dir, tmp_path, which):
    from breachflow.io import RunDirectory

    path = run_dir / "cycle_0002.nc" if which == "cycle" else RunDirectory(run_dir).combine(tmp_path / "archive.nc")
    runner = CliRunner()
    res = runner.invoke(app, ["inspect", str(path)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["export", str(path), "--format", "esri", "-o", str(tmp_path / "grid")])
    assert res.exit_code == 0, res.output
    # the exported depth is the depth of the file's (last) cycle, read back from the ESRI grid (dry: NODATA)
    asc = tmp_path / "grid_depth.asc"
    with xr.open_dataset(path) as ds:
        depth, wet = ds.depth.values[-1], ds.wet.values[-1] > 0
    lines = asc.read_text().splitlines()
    header = {ln.split()[0].lower(): float(ln.split()[1]) for ln in lines[:6]}
    body = np.array([[float(v) for v in ln.split()] for ln in lines[6:] if ln.strip()])[::-1]  # rows run north to south
    assert body.shape == depth.shape and header["nodata_value"] == -9999.0
    np.testing.assert_allclose(body[wet], depth[wet], rtol=1e-6, atol=1e-6)
    if which == "archive":  # --cycle picks another cycle; a cycle the file lacks is a clear error
        res = runner.invoke(app, ["inspect", str(path), "--cycle", "1"])
        assert res.exit_code == 0, res.output
        res = runner.invoke(app, ["inspect", str(path), "--cycle", "9"])
        assert res.exit_code != 0 and "no cycle 9" in str(res.output) + str(res.exception)


def test_ensemble_result_carries_the_members_per_cycle_figures(run_dir, tmp_path):
    """A closure ensemble's result has cycle_<name> along (ensemble dims, cycle): member 0's closure run is
    the 3-cycle run of this module, member 1 failed (NaN / fill)."""
    from breachflow.ensemble.closure import ClosureRunner
    from breachflow.ensemble.cycles import add_per_cycle
    from breachflow.ensemble.dataset import build_dataset, open_result, write_result
    from breachflow.ensemble.spec import parse_spec

    spec = parse_spec('''
[ensemble]
name = "per cycle"
runner = "closure"
[ensemble.vary]
mass_size = { parameter = "placement.diameter", values = ["1 m", "2 m"] }
''')
    m0 = tmp_path / "m0"
    m0.mkdir()
    (m0 / "closure").symlink_to(run_dir, target_is_directory=True)
    records = [{"status": "ok", "results": {}, "seed": 1, "elapsed": 1.0, "cpu_time": 1.0, "key": "m0", "run_dir": str(m0)},
               {"status": "failed", "error_type": "RuntimeError", "error_message": "x", "seed": 2, "elapsed": 1.0,
                "cpu_time": 1.0, "key": "m1", "run_dir": str(tmp_path / "m1")}]
    ds = add_per_cycle(build_dataset(spec, records, ClosureRunner, out_dir=tmp_path), records, ClosureRunner)
    back = open_result(write_result(ds, tmp_path / "ensemble.nc"))
    with xr.open_mfdataset(str(run_dir / "cycle_*.nc"), data_vars="all") as cyc:
        for name in ("breach_discharge", "gap_mean_speed", "mass_in_place", "criterion_max_speed"):
            v = back["cycle_" + name]
            assert v.dims == ("mass_size", "cycle") and v.attrs["units"] == cyc[name].attrs["units"]
            np.testing.assert_array_equal(v.values[0], cyc[name].values)
            assert np.isnan(v.values[1]).all()
        np.testing.assert_array_equal(back["cycle_masses_placed"].values[0], [2, 4, 6])
    assert back.cycle.values.tolist() == [1, 2, 3]
