"""Breach growth (eqs 2.2–2.8), maximum length (2.9–2.11), breach discharge (docs/theory.md, *Breach growth*, *Breach discharge*)."""
import math

import numpy as np
import pytest
import xarray as xr
from scipy.optimize import brentq

from breachflow import InputError
from breachflow.errors import BreachflowWarning
from breachflow.scenario import (LeveeGeometry, WEIR_COEFFICIENT_RANGE, breach_discharge, breach_length,
                                 growth_equations, max_breach_length, max_length_equations, weir_discharge)

LEVEE = LeveeGeometry(height=3.0, crown_width=3.0, flood_slope=3.0, protected_slope=3.0)  # Fig 2.15, h_L 3 m


def test_registries_hold_every_report_equation():
    numbers = {growth_equations.get(n).equation for n in growth_equations}
    assert {"2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8"} <= numbers
    assert {max_length_equations.get(n).equation for n in max_length_equations} == {"2.9", "2.10", "2.11"}
    for n in growth_equations:
        meta = growth_equations.get(n).describe()
        assert meta["source"] and meta["applies_to"] and meta["formula"]


def test_growth_equations_against_table_2_8_formulas():
    t = 2.5  # hours
    h = 3.0
    a_l = 3.0 * (3.0 + 3.0 * 3.0)  # h (b + h (m_F + m_P) / 2) = 36 m2
    k = 0.8039 * 1.0 ** 2 + 0.003 * 1.0
    expected = {
        "2.2": 63075 * t ** 2.747 / a_l,
        "2.3": k * (4.02 * h + 45.7) * t,
        "2.4": 91 * t,
        "2.5": 4 * h * t,
        "2.6": (4 * h + 61) * t,
        "2.7": 13.4 * t ** 0.51,
        "2.8": 37.2 * t ** 0.51,
    }
    for number, value in expected.items():
        da = breach_length(number, "150 min", levee=LEVEE)
        assert float(da) == pytest.approx(value, rel=1e-12), number
        assert da.attrs["units"] == "m" and da.attrs["equation"] == number
    # eq 2.2 is the eroded volume (t_D / 0.0179)^(1/0.364) spread over A_L
    assert float(breach_length("2.2", "1 h", levee=LEVEE)) == pytest.approx((1 / 0.0179) ** (1 / 0.364) / a_l, rel=2e-3)


def test_maximum_lengths_match_the_reports_quoted_ranges():
    # report §2.6: eqs 2.9 and 2.11 give 30 m and 51 m for a 10-ft levee, 46 m and 160 m for a 15-ft levee
    ten, fifteen = max_breach_length("all", "10 ft"), max_breach_length("all", "15 ft")
    assert float(ten.sel(equation="macdonald_langridge_monopolis")) == pytest.approx(30, abs=0.5)
    assert float(ten.sel(equation="nagy")) == pytest.approx(51, abs=0.5)
    assert float(fifteen.sel(equation="macdonald_langridge_monopolis")) == pytest.approx(46, abs=0.5)
    assert float(fifteen.sel(equation="nagy")) == pytest.approx(160, abs=0.5)
    assert float(max_breach_length("2.10", "4 m")) == pytest.approx(2.5 * 4 + 54.9)
    assert float(max_breach_length("2.11", "1 m")) == pytest.approx(5.19 * math.e ** 0.75)  # e, not 2.7812


def test_growth_curves_capped_by_a_chosen_maximum():
    times = xr.DataArray(np.linspace(0, 8, 33), dims="development_time", attrs={"units": "h"})
    free = breach_length("all", times, levee=LEVEE)
    capped = breach_length("all", times, levee=LEVEE, max_length="nagy")
    cap = 5.19 * math.exp(0.75 * 3.0)
    assert capped.attrs["max_length_m"] == pytest.approx(cap)
    np.testing.assert_allclose(capped.values, np.minimum(free.values, cap))
    assert bool((capped.diff("development_time") >= 0).all())
    assert float(breach_length("usbr", "8 h", max_length="100 m")) == 100.0
    assert capped.dims == ("equation", "development_time") and capped.development_time.attrs["units"] == "s"


def test_growth_errors_and_warnings():
    with pytest.raises(InputError, match="levee"):
        breach_length("2.2", "1 h")
    with pytest.raises(InputError, match="unknown breach growth equation"):
        breach_length("froehlich", "1 h", levee=LEVEE)
    with pytest.raises(InputError, match="development_time"):
        breach_length("2.4", "-1 h")
    wide = LeveeGeometry(height=3.0, crown_width=10.0, flood_slope=5.0, protected_slope=5.0)
    with pytest.warns(BreachflowWarning, match="h_W/W_b"):
        breach_length("pugh", "1 h", levee=wide)


def test_area_velocity_discharge_table_2_6_definition():
    assert breach_discharge("3.5 m", "75 m") == pytest.approx(3.5 * 75 * 3.0)
    assert breach_discharge("10 ft", "100 ft", "10 ft/s") == pytest.approx(10_000 * 0.3048 ** 3)


def _critical_flow(head, bottom, slope, g=9.80665):
    """Independent reference: critical flow in a trapezoid with specific energy `head`."""
    y = brentq(lambda y: y + y * (bottom + slope * y) / (2 * (bottom + 2 * slope * y)) - head, 1e-12, head)
    area, top = y * (bottom + slope * y), bottom + 2 * slope * y
    return math.sqrt(g * area ** 3 / top)


@pytest.mark.parametrize("bottom, slope, head", [(20.0, 0.0, 2.0), (20.0, 0.5, 2.0), (61.0, 0.0, 7.6),
                                                 (50.0, 0.5, 7.6), (10.0, 1.0, 3.0), (5.0, 1.0, 4.0)])
def test_weir_discharge_brackets_critical_flow(bottom, slope, head):
    exact = _critical_flow(head, bottom, slope)
    low = weir_discharge(f"{head} m", bottom_width=f"{bottom} m", wall_slope=slope, coefficient="3.0 ft**0.5/s")
    mid = weir_discharge(f"{head} m", bottom_width=f"{bottom} m", wall_slope=slope)
    assert low < mid
    # Fread's trapezoid form with the report's coefficient range is within 6 % of ideal critical flow
    assert mid == pytest.approx(exact, rel=0.06)
    if slope == 0:  # rectangular: the range 3.0-3.2 ft^0.5/s brackets (2/3)^1.5 sqrt(g) = 3.09 ft^0.5/s
        lo, hi = WEIR_COEFFICIENT_RANGE
        assert lo * bottom * head ** 1.5 < exact < hi * bottom * head ** 1.5


def test_weir_submergence_and_coefficient_warning():
    free = weir_discharge("2 m", bottom_width="20 m")
    assert weir_discharge("2 m", bottom_width="20 m", tailwater="1.2 m") == pytest.approx(free)  # ratio 0.6
    part = weir_discharge("2 m", bottom_width="20 m", tailwater="1.8 m")
    assert part == pytest.approx(free * (1 - 27.8 * (0.9 - 0.67) ** 3))
    with pytest.warns(BreachflowWarning, match="outside the report's range"):
        weir_discharge("2 m", bottom_width="20 m", coefficient="2.5 ft**0.5/s")


def test_growth_chart_y_axis_is_scaled_to_the_curves(tmp_path, monkeypatch):
    """The y axis fits the curves drawn (was fixed at 0-500 m: a 51 m cap filled a tenth of it), and a
    runaway curve (eq 2.2's exponential) leaves the chart instead of flattening the others."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from breachflow.scenario import plots
    from breachflow.scenario.geometry import LeveeGeometry

    seen = {}
    real_save = plots._save

    def keep(fig, path):
        seen["ylim"] = fig.axes[0].get_ylim()
        return real_save(fig, path)

    monkeypatch.setattr(plots, "_save", keep)
    plots.growth_chart(tmp_path / "capped.png", levees=[LeveeGeometry(3.048, 3.0, 3.0, 3.0)], max_length="nagy")
    top = seen["ylim"][1]
    cap = breach_length("2.4", "8 h", levee=LeveeGeometry(3.048, 3.0, 3.0, 3.0), max_length="nagy")
    assert float(cap) == pytest.approx(top / 1.1, rel=1e-6)  # 10 % above the cap every curve reaches
    plots.growth_chart(tmp_path / "all.png")
    # the default chart: the report's 3.0 m and 4.6 m levees; every curve grows, so its peak is at 8 h
    ends = [breach_length("all", "8 h", levee=lev) for lev in plots.FIGURE_2_15_LEVEES]
    peaks = np.maximum(ends[0].values, ends[1].values)
    names = list(ends[0]["equation"].values)
    want, runaway = plots.growth_y_max(peaks)
    assert seen["ylim"][1] == pytest.approx(want, rel=1e-9)
    assert [names[i] for i in runaway] == [n for n in names if "2.2" in str(n) or "macdonald" in str(n).lower()]
    others = np.delete(peaks, runaway)
    assert want == pytest.approx(1.1 * others.max()) and peaks[runaway].min() > want
    plt.close("all")
