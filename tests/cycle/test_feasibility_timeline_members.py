"""The feasibility-in-time pipeline's members on a scenario file (the typical breach): method, start, the
strategy a method can work, the cycle cap and the coarser grid land in a scenario that parses."""
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "pipelines"))


@pytest.mark.parametrize("method, positions", [("split_barge", "vertical"), ("end_dumping", "horizontal")])
def test_members_on_the_typical_breach(method, positions):
    from closure_feasibility_timeline import member_text

    from breachflow.cycle.delivery import delivery_method
    from breachflow.scenario.config import parse_scenario

    text = member_text(method, 24.0, max_cycles=30, scenario=(ROOT / "examples" / "typical_breach.toml").read_text(),
                       resolution=8.0)
    d = tomllib.loads(text)
    assert d["closure"]["method"] == method and d["closure"]["start"] == "24 h"
    assert d["placement"]["positions"] == positions and positions in delivery_method(method).positions
    assert d["hydro"]["resolution"] == "8 m" and d["criteria"]["max_cycles"] == 30
    assert d["polder"]["area"] == "4900 ha"  # the rest from the file
    parse_scenario(text)


def test_the_window_of_a_start_does_not_depend_on_the_method():
    # two members at one start: the same breach left open (81.19 h), but the slow method's own closure let the
    # polder meet the flood at 54.15 h, before it finished; it misses its window, the window stays the open one
    from closure_feasibility_timeline import member_row

    def plan(balance_s, finish_s, fits):
        return {"closed": True, "placed_t": 1000.0, "finish_s": finish_s, "duration_s": finish_s - 48 * 3600.0,
                "window": {"open_breach_window_s": 292267.9, "balance_time_s": balance_s, "window_s": None,
                           "report_closure_window_s": None, "fits": fits},
                "leakage_end": {"breach_discharge_m3_s": 1.0}, "verdict": ""}

    fast = member_row("split_barge", 48.0, plan(None, 50 * 3600.0, True))
    slow = member_row("end_dumping", 48.0, plan(194958.6, 70 * 3600.0, False))
    assert fast["window_h"] == slow["window_h"] == pytest.approx(292267.9 / 3600.0)
    assert slow["run_balance_h"] == pytest.approx(54.155, abs=1e-3) and fast["run_balance_h"] is None
    assert fast["fits"] and not slow["fits"]


def test_a_row_carries_what_the_window_was_calibrated_on(tmp_path):
    from closure_feasibility_timeline import figure, member_row

    cal = {"time_s": 0.0, "weir_coefficient": 1.4027, "model_discharge_m3_s": 1792.7, "weir_discharge_m3_s": 1792.7}
    rows = []
    for start_h in (24.0, 36.0, 48.0):
        plan = {"closed": True, "placed_t": 9000.0, "finish_s": (start_h + 10) * 3600.0, "duration_s": 36000.0,
                "window": {"open_breach_window_s": 356605.7, "calibration": cal, "balance_time_s": None,
                           "window_s": 356605.7, "report_closure_window_s": None, "fits": True},
                "leakage_end": {"breach_discharge_m3_s": 2.0}, "verdict": ""}
        rows.append(member_row("split_barge", start_h, plan))
    assert {r["window_weir"] for r in rows} == {1.4027} and {r["window_calibrated_h"] for r in rows} == {0.0}
    assert figure(rows, tmp_path / "chart.png").stat().st_size > 0  # the chart takes the rows
