"""``pipelines/closure_strategies.py`` on a small scene (CI-sized): every strategy runs, and the table is
what the run directories hold, checked against the cycle files themselves."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.scenario.toml import scenario_with

CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()
TINY = scenario_with(CI_CLOSURE, {"scenario.name": "tiny strategies", "placement.density": "2650 kg/m^3",
                                  "placement.rate": "30 1/hr", "placement.start": None, "placement.stop": None,
                                  "criteria.max_cycles": 5, "closure.seed": 2})


def _pipeline():
    path = Path(__file__).resolve().parents[2] / "pipelines" / "closure_strategies.py"
    spec = importlib.util.spec_from_file_location("closure_strategies_pipeline", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_closure_strategies_pipeline_on_a_tiny_scene(tmp_path, capsys):
    mod = _pipeline()
    scen = tmp_path / "tiny.toml"
    scen.write_text(TINY)
    out = tmp_path / "out"
    assert mod.main([str(out), "--scenarios", str(scen), "--strategies", "line", "vertical", "horizontal",
                     "--max-cycles", "2"]) == 0
    printed = capsys.readouterr().out
    assert "Closure strategies" in printed and "horizontal" in printed
    from breachflow.schemas import validate

    with xr.open_dataset(out / "closure_strategies.nc") as ds:
        validate(ds, "closure_strategies")
        assert ds.sizes["scenario"] == 1 and list(ds["strategy"].values) == ["line", "vertical", "horizontal"]
        for j, st in enumerate(ds["strategy"].values):
            rd = out / "tiny" / str(st) / "run"
            row = {n: ds[n].values[0, j] for n in ds.data_vars if ds[n].dims == ("scenario", "strategy")}
            # max_cycles = 2 (the override), 3 masses a cycle at 30 per hour
            assert row["cycles"] == 2 and row["masses"] == 6
            assert row["operation_time"] == pytest.approx(6 / 30 * 3600)
            with xr.open_dataset(rd / "cycle_0002.nc") as cyc:
                assert cyc.attrs["placement_strategy"] == st
                act = cyc.particle_active.values[0] == 1
                d = cyc.particle_diameter.values[0]
                # rock left in the breach area: sum of rho pi d^3 / 6 over the active masses
                assert row["tonnage"] == pytest.approx(np.sum(2650.0 * np.pi * d[act] ** 3 / 6), rel=1e-9)
                placed = cyc.particle_placed_cycle.values[0] > 0
                assert row["lost_masses"] == int((placed & ~act).sum())
                # the peak gap speed is at least the gap-section speed of the last cycle, recomputed from
                # its fields on the levee centreline (y = 0) across the 12 m breach: per column open in the
                # row nearest it, depth and unit discharges linearly between the two rows around y = 0
                ys = cyc.y.values
                j0 = int(np.argmin(np.abs(ys)))
                k0 = j0 + 1 if ys[j0] < 0.0 else j0 - 1
                w = (0.0 - ys[j0]) / (ys[k0] - ys[j0])

                def is_open(j):
                    ok = cyc.wet.values[0, j] > 0
                    return ok & (cyc.obstacle.values[0, j] == 0) if "obstacle" in cyc else ok

                sel = (np.abs(cyc.x.values) <= 6.0) & is_open(j0)
                wk = np.where(is_open(k0), w, 0.0)[sel]
                wj = (1.0 - w) / (1.0 - w + wk)
                wk = wk / (1.0 - w + wk)
                hh = cyc.depth.values[0]
                h = wj * hh[j0, sel] + wk * hh[k0, sel]
                qu = wj * (hh * cyc.u.values[0])[j0, sel] + wk * (hh * cyc.u.values[0])[k0, sel]
                qv = wj * (hh * cyc.v.values[0])[j0, sel] + wk * (hh * cyc.v.values[0])[k0, sel]
                speed = (np.hypot(qu, qv) / np.where(h > 0, h, np.inf))[h > 0]
                assert float(cyc["gap_max_speed"].values[0]) == pytest.approx(speed.max() if speed.size else 0.0)
                assert row["peak_gap_max_speed"] >= speed.max() - 1e-12
                assert row["peak_gap_max_speed"] >= row["peak_gap_mean_speed"] > 0
            # the evolution starts with the open breach, as many points as cycles + 1
            h = ds["gap_mean_speed"].values[0, j]
            assert np.isfinite(h[:3]).all() and ds["tonnage_placed"].values[0, j, 0] == 0.0
            assert np.nanmax(h[1:]) == pytest.approx(row["peak_gap_mean_speed"])  # over the cycles
            assert h[0] == pytest.approx(row["initial_gap_mean_speed"])  # the open breach
    csv = (out / "closure_strategies.csv").read_text().splitlines()
    assert len(csv) == 4 and csv[0].startswith("scenario,strategy,masses")
    assert (out / "closure_strategies.png").stat().st_size > 10_000
    # rerunning reads the finished runs back: the same table, no run repeated
    before = (out / "tiny" / "line" / "run" / "manifest.json").read_text()
    ds2 = mod.compare([str(scen)], ["line", "vertical", "horizontal"], out, max_cycles=2)
    with xr.open_dataset(out / "closure_strategies.nc") as ds:
        for n in ("masses", "tonnage", "peak_gap_mean_speed", "lost_masses", "model_cpu_time"):
            np.testing.assert_array_equal(ds2[n].values, ds[n].values)
    assert (out / "tiny" / "line" / "run" / "manifest.json").read_text() == before


def test_member_text_changes_only_the_strategy():
    import tomllib

    mod = _pipeline()
    a = tomllib.loads(TINY)
    b = tomllib.loads(mod.member_text(TINY, "vertical", max_cycles=4))
    assert b["placement"]["positions"] == "vertical" and b["criteria"]["max_cycles"] == 4
    b["placement"]["positions"], b["criteria"]["max_cycles"] = "line", 5
    assert a == b
