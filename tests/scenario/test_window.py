"""Closure window (docs/theory.md, *Closure window*): Table 2.5, the Table 2.6 grid, invariants, units, bad input."""
import numpy as np
import pytest
import xarray as xr

from breachflow import InputError, UnitError, ureg
from breachflow.scenario import closure_window, flood_preset, flood_presets, run_scenario
from breachflow.scenario.calculator import model_problem_paths

H = 3600.0
MODEL = dict(polder_area="800 ha", inundation_depth="90 cm", surge_height="2.8 m", breach_discharge="200 m^3/s")


# --- Table 2.5 (report values; t_I corrected to 10.0 h as in docs/theory.md, *Closure window*) -----------------------------------
@pytest.mark.parametrize("rate, t_q, t_i, t_b, depth_cm, governing", [
    ("0.4 m/hr", 5.7, 10.0, 5.7, 51, 0),    # hurricane
    ("0.06 m/hr", 18.7, 10.0, 10.0, 90, 1),  # riverine
])
def test_table_2_5(rate, t_q, t_i, t_b, depth_cm, governing):
    ds = closure_window(fall_rate=rate, rise_rate=rate, pump_capacity="0 m^3/s", **MODEL)
    # the report's note (1): 200 m3/s / 8.0e6 m2 = 9.0 cm/hr
    assert float(ds.polder_rise_rate) * H == pytest.approx(0.09, rel=1e-12)
    # published figures are rounded to 0.1 h and 1 cm
    assert float(ds.balance_time) / H == pytest.approx(t_q, abs=0.05)
    assert float(ds.inundation_time) / H == pytest.approx(t_i, abs=0.05)
    assert float(ds.closure_window) / H == pytest.approx(t_b, abs=0.05)
    assert float(ds.depth_at_window_end) * 100 == pytest.approx(depth_cm, abs=0.5)
    assert int(ds.governing) == governing
    assert ds.closure_window.attrs["units"] == "s" and "long_name" in ds.closure_window.attrs


def test_model_problem_scenario_files_give_table_2_5():
    hurricane, riverine = (run_scenario(p).window for p in model_problem_paths())
    assert float(hurricane.closure_window) / H == pytest.approx(2.8 / 0.49, rel=1e-12)
    assert float(riverine.closure_window) / H == pytest.approx(0.9 / 0.09, rel=1e-12)
    assert float(riverine.balance_time) / H == pytest.approx(2.8 / 0.15, rel=1e-12)


# --- Table 2.6 grid in one vectorised call -------------------------------------------------------------
def _axis(name, values, unit):
    return xr.DataArray(values, dims=name, coords={name: values}, attrs={"units": unit})


def test_table_2_6_grid_matches_spec_definition():
    surge, fall, length, area, depth = [1.0, 3.5], [0.30, 0.02], [75.0, 25.0, 12.0], [100.0, 500.0, 4000.0], [0.5, 1.5]
    ds = closure_window(surge_height=_axis("surge_height", surge, "m"), fall_rate=_axis("fall_rate", fall, "m/h"),
                        breach_length=_axis("breach_length", length, "m"), mean_velocity="3 m/s",
                        polder_area=_axis("polder_area", area, "ha"),
                        inundation_depth=_axis("inundation_depth", depth, "m"))
    assert ds.closure_window.size == 2 * 2 * 3 * 3 * 2
    np.testing.assert_allclose(ds.polder_area.values, np.array(area) * 1e4)  # coordinates converted too
    # independent evaluation of docs/theory.md, *Closure window* in hours, loop by loop
    for h in surge:
        for f in fall:
            for b in length:
                for a in area:
                    for d in depth:
                        r_p = h * b * 3.0 / (a * 1e4) * 3600.0  # m/h
                        t_q, t_i = h / (f + r_p), d / r_p
                        sel = ds.sel(surge_height=h, fall_rate=f / 3600, breach_length=b, polder_area=a * 1e4,
                                     inundation_depth=d)
                        assert float(sel.balance_time) / H == pytest.approx(t_q, rel=1e-12)
                        assert float(sel.inundation_time) / H == pytest.approx(t_i, rel=1e-12)
                        assert float(sel.closure_window) / H == pytest.approx(min(t_q, t_i), rel=1e-12)
                        assert int(sel.governing) == (0 if t_q <= t_i else 1)
    # a hand-worked cell: h_W 3.5 m, 0.30 m/h, B 75 m, 100 ha: Q = 787.5 m3/s, r_P = 2.835 m/h
    cell = ds.sel(surge_height=3.5, fall_rate=0.3 / 3600, breach_length=75.0, polder_area=1e6, inundation_depth=0.5)
    assert float(cell.closure_window) / H == pytest.approx(0.5 / 2.835, rel=1e-12)


# --- invariants --------------------------------------------------------------------------------------
def test_window_is_min_of_balance_and_inundation_and_monotonic_in_polder_area():
    rng = np.random.default_rng(3)
    area = _axis("polder_area", np.sort(rng.uniform(10, 5000, 40)), "ha")
    ds = closure_window(surge_height=_axis("surge_height", rng.uniform(0.5, 5, 7), "m"),
                        fall_rate=_axis("fall_rate", rng.uniform(0.005, 0.6, 5), "m/h"),
                        polder_area=area, inundation_depth=_axis("inundation_depth", [0.3, 1.0, 2.5], "m"),
                        breach_discharge=_axis("breach_discharge", rng.uniform(20, 800, 4), "m^3/s"),
                        pump_capacity="5 m^3/s")
    tq, ti = xr.broadcast(ds.balance_time, ds.inundation_time)
    np.testing.assert_array_equal(ds.closure_window.transpose(*tq.dims).values, np.minimum(tq, ti).values)
    for var in ("balance_time", "inundation_time", "closure_window"):
        diffs = ds[var].diff("polder_area")
        assert bool((diffs >= 0).all()), var


def test_units_round_trip_feet_cfs_acres():
    si = closure_window(fall_rate="0.4 m/hr", **MODEL)
    ft = 0.3048
    acre = float(ureg.Quantity(1, "acre").to("m^2").magnitude)  # the registry gives numpy scalars (pint-xarray needs force_ndarray_like)
    us = closure_window(surge_height=f"{2.8 / ft!r} ft", fall_rate=f"{0.4 / ft!r} ft/hr",
                        polder_area=f"{8e6 / acre!r} acre", inundation_depth=f"{0.9 / ft!r} ft",
                        breach_discharge=f"{200 / ft ** 3!r} cfs")
    for var in ("balance_time", "inundation_time", "closure_window", "depth_at_window_end", "polder_rise_rate"):
        assert float(us[var]) == pytest.approx(float(si[var]), rel=1e-12)
    q = closure_window(fall_rate=ureg.Quantity(0.4, "m/hr"), **MODEL)
    assert float(q.closure_window) == pytest.approx(float(si.closure_window), rel=1e-12)


def test_pumping_and_breach_before_and_after_the_crest():
    ds = closure_window(fall_rate="0.4 m/hr", pump_capacity="50 m^3/s", **MODEL)
    r_p = 150 / 8e6 * H
    assert float(ds.balance_time) / H == pytest.approx(2.8 / (0.4 + r_p), rel=1e-12)
    assert float(ds.inundation_time) / H == pytest.approx(0.9 / r_p, rel=1e-12)
    # brute-force crossing of the two stage lines on a fine grid for breaches before/after the crest
    for t0, rise, rp in ((-2.0, 0.1, 0.09), (1.5, 0.4, 0.09), (-3.0, 0.05, 0.5)):
        ds = closure_window(polder_area="800 ha", inundation_depth="5 m", surge_height="2.8 m",
                            fall_rate="0.4 m/hr", rise_rate=f"{rise} m/hr", breach_time=f"{t0} h",
                            breach_discharge=f"{rp * 8e6 / H} m^3/s")
        t = np.linspace(t0, 30, 3_000_001)
        z_f = np.where(t < 0, 2.8 + rise * t, 2.8 - 0.4 * t)
        z_p = rp * (t - t0)
        first = t[np.argmax(z_f - z_p <= 0)]
        assert float(ds.balance_time) / H == pytest.approx(first - t0, abs=2e-5)


# --- bad input ----------------------------------------------------------------------------------------
def test_bad_inputs_raise_errors_naming_the_parameter():
    with pytest.raises(InputError, match="polder_area"):
        closure_window(**{**MODEL, "polder_area": "-800 ha"}, fall_rate="0.4 m/hr")
    with pytest.raises(InputError, match="breach_discharge"):
        closure_window(**{**MODEL, "breach_discharge": "0 m^3/s"}, fall_rate="0.4 m/hr")
    with pytest.raises(InputError, match="surge_height.*not finite"):
        closure_window(**{**MODEL, "surge_height": "nan m"}, fall_rate="0.4 m/hr")
    with pytest.raises(InputError, match="fall_rate.*not finite"):
        closure_window(fall_rate=ureg.Quantity(float("nan"), "m/hr"), **MODEL)
    with pytest.raises(UnitError, match=r"polder_area.*\[length\] \*\* 2"):
        closure_window(**{**MODEL, "polder_area": "800 m/s"}, fall_rate="0.4 m/hr")
    with pytest.raises(InputError, match="fall_rate"):
        closure_window(**{**MODEL, "fall_rate": "-0.1 m/hr"})
    with pytest.raises(InputError, match="breach_time"):  # the water is already gone 8 h after the crest
        closure_window(fall_rate="0.4 m/hr", breach_time="8 h", **MODEL)


def test_fall_rate_zero_gives_an_explicit_no_balance_result():
    # pumps take all the inflow and the flood never falls: the stages never meet, no window limit
    ds = closure_window(fall_rate="0 m/hr", pump_capacity="200 m^3/s", **MODEL)
    assert not bool(ds.balance_reached) and not bool(ds.inundation_reached)
    assert int(ds.governing) == 2 and ds.governing.attrs["flag_meanings"].split()[2] == "no_limit_within_flood"
    assert np.isnan(float(ds.closure_window))  # flagged by `governing`, not silent
    # a flood that does not fall but ends after 12 h: the polder fills to h_W only after 31 h
    ds = closure_window(fall_rate="0 m/hr", flood_duration="12 h", **{**MODEL, "inundation_depth": "3 m"})
    assert not bool(ds.balance_reached) and int(ds.governing) == 2
    # without an end the polder does reach the flood level: t_Q = h_W / r_P
    ds = closure_window(fall_rate="0 m/hr", **MODEL)
    assert float(ds.balance_time) / H == pytest.approx(2.8 / 0.09, rel=1e-12)


# --- presets --------------------------------------------------------------------------------------------
def test_presets_reproduce_the_reports_tabulated_rates():
    hurricanes, rivers = flood_presets("hurricane"), flood_presets("riverine")
    assert len(hurricanes) == 10 and len(rivers) == 10
    for p in hurricanes:  # Table 2.3 prints rates in whole cm/h
        assert p.rise_rate * 3.6e5 == pytest.approx(p.extra["tabulated_rise_rate"], abs=1.0), p.key
        assert p.fall_rate * 3.6e5 == pytest.approx(p.extra["tabulated_fall_rate"], abs=1.0), p.key
    for p in rivers:  # Table 2.4 prints one decimal
        assert p.rise_rate * 3.6e5 == pytest.approx(p.extra["tabulated_rise_rate"], abs=0.1), p.key
        assert p.fall_rate * 3.6e5 == pytest.approx(p.extra["tabulated_fall_rate"], abs=0.1), p.key
    for p in hurricanes + rivers:  # bracketed ratios: rise rate / fall rate
        ratio = p.extra["tabulated_rise_rate"] / p.extra["tabulated_fall_rate"]
        assert ratio == pytest.approx(p.extra["tabulated_rise_to_fall_ratio"], abs=0.051 * max(1, ratio)), p.key
    katrina = flood_preset("Hurricane Katrina")
    assert katrina is flood_preset("katrina") and katrina.surge_height == 3.5
    assert katrina.fall_rate == pytest.approx(1.5 / 4 / H)
    ds = closure_window(preset="katrina", polder_area="800 ha", inundation_depth="90 cm", breach_discharge="200 m^3/s")
    r_p = 0.09
    assert float(ds.balance_time) / H == pytest.approx(3.5 / (1.5 / 4 + r_p), rel=1e-12)
    with pytest.raises(InputError, match="unknown flood preset"):
        flood_preset("hurricane zorro")
    with pytest.raises(InputError, match="surge_height"):
        closure_window(preset="ohio_1997", polder_area="800 ha", inundation_depth="90 cm", breach_discharge="200 m^3/s")


def test_window_datasets_match_their_schema():
    from breachflow.scenario import model_problem
    from breachflow.schemas import validate
    import xarray as _xr

    for r in model_problem():
        validate(r.window, "closure_window")
    grid = closure_window(surge_height=_xr.DataArray([1.0, 3.5], dims="surge_height", attrs={"units": "m"}),
                          fall_rate="0.3 m/hr", breach_length="75 m", polder_area="100 ha", inundation_depth="0.5 m")
    validate(grid, "closure_window")
