"""The closure window of the breach left open is the breach's, not the start's: its weir is calibrated once, on
the flow model's open breach at its full size, and every start of one breach gets the same window; the start's
own calibration (the polder level at the start) is untouched by it."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from breachflow.cycle.delivery import HOUR, delivery_method
from breachflow.cycle.timeline import FloodStage, Timeline
from breachflow.scenario.polder import Polder

FT = 0.3048
C_REPORT = 3.1 * FT ** 0.5  # the report's weir coefficient (m^0.5/s)
B, AREA, FLOOD = 10.0, 2e5, 2.0  # breach length (m), polder area (m2), flood level over the breach bottom (m)
CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def _model(head, tail):
    """A flow model with a law of its own: 0.7 of the ideal weir, Villemonte's submergence (1 - (h_t/H)^1.5)^0.385
    (not Fread's, which the timeline's weir uses: the mismatch changes with the tailwater)."""
    r = min(max(tail, 0.0) / head, 1.0)
    return 0.7 * C_REPORT * B * head ** 1.5 * (1.0 - r ** 1.5) ** 0.385


def _fread(r):
    """Fread's submergence factor, written out: 1 - 27.8 (r - 0.67)^3 above r = 0.67."""
    return 1.0 - 27.8 * (r - 0.67) ** 3 if r > 0.67 else 1.0


def _timeline(start_h, growth=None, stage=None):
    return Timeline(stage=stage or FloodStage.constant(FLOOD), polder=Polder(area=AREA, initial_level=0.0),
                    method=delivery_method("split_barge"), start=start_h * HOUR, bottom=0.0, length=B,
                    wall_slope=0.0, growth=growth)


def _run_start(tl, solves=None):
    """What a closure run does at its start: the pre-start phase, the window's weir, the start's first solve
    (or the window's, when the start is the reference) and the start's own calibration."""
    solves = [] if solves is None else solves

    def state_solve():
        solves.append((tl.time, tl.polder_level))
        return {"q": _model(tl.stage(tl.time) - tl.bottom, tl.polder_level - tl.bottom)}

    tl.begin()
    first = tl.calibrate_window(state_solve, lambda s: s["q"])
    snap = first if first is not None else state_solve()
    tl.calibrate(snap, lambda prev: state_solve(), lambda s: s["q"])
    return first


def _linear_growth(t):  # the breach reaches its 10 m 5 h after the breach
    return B * min(t / (5 * HOUR), 1.0)


@pytest.mark.parametrize("growth", [None, _linear_growth], ids=["full_breach", "growing_breach"])
def test_the_window_is_the_same_for_every_start(growth):
    starts = [0.0, 1.0, 2.5, 5.0, 8.0]
    windows, per_start = [], []
    for start_h in starts:
        tl = _timeline(start_h, growth)
        _run_start(tl)
        windows.append(tl.open_breach_window())
        windows.append(tl.open_breach_window(inundation_depth=1.0))
        tl.window_coefficient = None  # the window as it was: on the start's own calibration
        per_start.append(tl.open_breach_window())
    assert all(np.isfinite(windows))
    assert windows[0::2] == [windows[0]] * len(starts)  # identical, not merely close
    assert windows[1::2] == [windows[1]] * len(starts)
    # the start's own calibration gives each start its own window: what the window must not depend on
    assert max(per_start) / min(per_start) > 1.05


def test_the_window_against_the_flow_models_free_flow_and_a_separate_integration():
    # no growth law: the reference is the breach time, the polder dry: the coefficient is the model's free flow
    # over the ideal weir's, 0.7 C, in one solve; the balance and the inundation time then follow
    #   dz/dt = 0.7 C B H^1.5 k_s(z / H) / A   (H = 2 m over the crest, Fread's k_s)
    tl = _timeline(3.0)
    solves = []
    _run_start(tl, solves)
    cal = tl.window_calibration
    assert cal["time_s"] == 0.0 and cal["polder_level_m"] == 0.0 and cal["flood_level_m"] == FLOOD
    assert tl.window_coefficient == pytest.approx(0.7 * C_REPORT, rel=1e-12)
    assert cal["model_discharge_m3_s"] == pytest.approx(0.7 * C_REPORT * B * FLOOD ** 1.5, rel=1e-12)
    assert cal["weir_discharge_m3_s"] == pytest.approx(cal["model_discharge_m3_s"], rel=1e-12)
    assert solves[0] == (0.0, 0.0) and sum(1 for t, _ in solves if t == 0.0) == 1  # one solve at the reference
    q0 = 0.7 * C_REPORT * B * FLOOD ** 1.5
    t_inundation = AREA * 1.0 / q0  # 1 m: below 0.67 H the flow is free
    assert tl.open_breach_window(inundation_depth=1.0) == pytest.approx(t_inundation, rel=1e-3)
    z1 = 0.67 * FLOOD
    t_balance = AREA * z1 / q0 + quad(lambda z: AREA / (q0 * _fread(z / FLOOD)), z1, FLOOD, limit=200)[0]
    assert tl.open_breach_window() == pytest.approx(t_balance, rel=0.01)


def test_a_growing_breach_is_calibrated_at_its_full_size_with_its_polder_there():
    tl = _timeline(2.0, _linear_growth)
    assert tl.full_size_time() == pytest.approx(5 * HOUR, abs=1.0)
    assert _timeline(2.0).full_size_time() == 0.0
    solves = []
    first = _run_start(tl, solves)
    assert first is None  # the start (2 h) is not the reference (5 h): solved apart
    cal = tl.window_calibration
    t_r = cal["time_s"]
    assert t_r == pytest.approx(5 * HOUR, abs=1.0) and cal["breach_length_m"] == B
    # the reference's polder level: the weir of the growing breach, with the window's coefficient, integrated
    # separately (RK4, 10 s steps; free flow all the way: the polder stays below 0.67 H)
    c = tl.window_coefficient
    z, dt = 0.0, 10.0
    f = lambda t, z: c * B * min(t / (5 * HOUR), 1.0) * FLOOD ** 1.5 * _fread(z / FLOOD) / AREA
    n = int(round(t_r / dt))
    h = t_r / n
    for i in range(n):
        t = i * h
        k1 = f(t, z); k2 = f(t + h / 2, z + h / 2 * k1); k3 = f(t + h / 2, z + h / 2 * k2); k4 = f(t + h, z + h * k3)
        z += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert cal["polder_level_m"] == pytest.approx(z, rel=1e-3)
    # calibrated there: the weir within the tolerance of the model at that state
    q_model = _model(FLOOD, cal["polder_level_m"])
    assert cal["model_discharge_m3_s"] == pytest.approx(q_model, rel=1e-12)
    assert abs(cal["weir_discharge_m3_s"] / q_model - 1.0) <= tl.calibration_tolerance
    assert all(t == pytest.approx(t_r) for t, _ in solves[:len(cal["steps"])])
    # a start at the reference time hands the reference's first solve to the run
    tl5 = _timeline(tl.full_size_time() / HOUR, _linear_growth)
    assert _run_start(tl5) is not None


@pytest.mark.parametrize("start_h", [0.0, 1.0, 2.5])
def test_the_starts_own_polder_level_is_untouched(start_h):
    tl = _timeline(start_h)
    tl.begin()
    before = (tl.time, tl.polder_level, tl.discharge, list(tl.history), tl.weir_coefficient)
    tl.calibrate_window(lambda: {"q": _model(FLOOD, tl.polder_level)}, lambda s: s["q"])
    assert (tl.time, tl.polder_level, tl.discharge, list(tl.history), tl.weir_coefficient) == before
    _run_start(tl)
    # the run's start as without the window's calibration
    old = _timeline(start_h)
    old.begin()
    old.calibrate({"q": _model(FLOOD, old.polder_level)}, lambda prev: {"q": _model(FLOOD, old.polder_level)},
                  lambda s: s["q"])
    assert tl.polder_level == old.polder_level and tl.weir_coefficient == old.weir_coefficient
    # and the polder level at the start against a separate integration with the start's coefficient (Euler,
    # 1 s steps; the weir of the full breach, free below 0.67 H, Fread's factor above)
    c, z = tl.weir_coefficient, 0.0
    for _ in range(int(round(start_h * HOUR))):
        z += c * B * FLOOD ** 1.5 * _fread(z / FLOOD) / AREA
    assert tl.polder_level == pytest.approx(z, rel=1e-3, abs=1e-9)
    if start_h > 0:  # the window's coefficient is the free-flow one, the start's its own
        assert tl.window_coefficient != tl.weir_coefficient


def test_the_windows_coefficient_is_restored_on_resume_and_absent_without_calibration():
    tl = _timeline(2.0)
    _run_start(tl)
    w = tl.open_breach_window()
    again = _timeline(2.0)
    again.restore(tl.state())
    assert again.window_coefficient == tl.window_coefficient and again.open_breach_window() == w
    for kw in ({"prestart_discharge": 5.0}, {"calibrate_weir": False}):
        t2 = _timeline(2.0)
        for k, v in kw.items():
            setattr(t2, k, v)
        t2.begin()
        assert t2.calibrate_window(lambda: pytest.fail("no solve"), lambda s: s["q"]) is None
        assert t2.window_coefficient is None and t2.window_calibration == {}


def test_a_falling_flood_reference_is_at_the_full_size_not_the_start():
    # a falling flood: the reference state is taken at the full-size time's flood level, for every start
    stage = FloodStage(lambda t: max(FLOOD - 0.05 * t / HOUR, 0.0), "falling 5 cm/h")
    cals = []
    for start_h in (1.0, 6.0, 12.0):
        tl = _timeline(start_h, _linear_growth, stage)
        _run_start(tl)
        cals.append((tl.window_coefficient, tl.window_calibration["flood_level_m"], tl.open_breach_window()))
    assert cals == [cals[0]] * 3
    assert cals[0][1] == pytest.approx(FLOOD - 0.05 * 5.0, abs=1e-4)
    assert math.isfinite(cals[0][2])


@pytest.mark.parametrize("growth", [None, "verheij_sand"])
def test_closure_runs_at_two_starts_record_one_window(tmp_path, growth):
    """The CI demo breach in a 2 ha polder on the embedded solver, one cycle, started 0.05 and 0.2 h after the
    breach: the manifest records the window's calibration (at the breach time with the polder dry; with Verheij's
    growth in sand, at its full size 0.11 h after the breach, between the two starts, with the polder the weir
    integration gives there), the plan the same window for both."""
    import json

    from breachflow.cycle.main import run_closure
    from breachflow.scenario.toml import scenario_with

    plans, cals, start_levels = [], [], []
    for start_h in (0.05, 0.2):
        changes = {"closure.method": "split_barge", "closure.start": f"{start_h} h", "polder.area": "2 ha",
                   "criteria.max_cycles": 1}
        if growth:
            changes["breach.growth"] = growth
        text = scenario_with(CI_CLOSURE, changes)
        scen = tmp_path / f"s{start_h}.toml"
        scen.write_text(text)
        out = tmp_path / f"run{start_h}"
        run_closure(scen, out, overwrite=True, plots=False)
        man = json.loads((out / "manifest.json").read_text())
        cal = man["metadata"]["timeline_start"]["window_calibration"]
        cals.append(cal)
        plans.append(json.loads((out / "closure_plan.json").read_text()))
        ts = man["metadata"]["timeline_start"]
        assert ts["weir_calibration"][-1]["polder_level"] == ts["polder_level"]  # the start's own, at the start
        start_levels.append(ts["polder_level"])
        assert ts["window_coefficient"] == cal["weir_coefficient"]
    for cal in cals:
        assert cal["steps"][0]["weir_coefficient"] == pytest.approx(C_REPORT)
        if growth is None:
            assert cal["time_s"] == 0.0 and cal["polder_level_m"] == cal["steps"][0]["polder_level"]
            # the coefficient: the solver's breach discharge over the ideal weir's at the same state
            assert cal["weir_coefficient"] == pytest.approx(
                C_REPORT * cal["steps"][0]["model_discharge"] / cal["steps"][0]["weir_discharge"], rel=1e-12)
        else:  # between the two starts; the polder there has water in it and the weir agrees with the solver there
            assert 0.05 * 3600 < cal["time_s"] < 0.2 * 3600 and cal["polder_level_m"] > 0.3
            assert abs(cal["weir_discharge_m3_s"] / cal["model_discharge_m3_s"] - 1.0) <= 0.03
    assert cals[0]["weir_coefficient"] == cals[1]["weir_coefficient"]
    assert cals[0]["model_discharge_m3_s"] == cals[1]["model_discharge_m3_s"]
    assert start_levels[1] > start_levels[0]  # two different starts
    w = [p["window"]["open_breach_window_s"] for p in plans]
    assert w[0] is not None and w[0] == w[1]
    assert plans[0]["window"]["calibration"] == plans[1]["window"]["calibration"]
    assert "steps" not in plans[0]["window"]["calibration"]


def test_a_polder_full_before_the_breach_is_full_calibrates_on_the_full_breach_at_the_initial_level():
    # a 2 ha polder meets the flood long before the breach reaches its 10 m (5 h): no flow at the full size; the
    # reference is then the full breach with the polder at its initial level, at the full-size time: the model's
    # free flow over the ideal weir's, 0.7 C, whatever the start
    got = []
    for start_h in (0.5, 2.0, 6.0):
        tl = Timeline(stage=FloodStage.constant(FLOOD), polder=Polder(area=2e4, initial_level=0.0),
                      method=delivery_method("split_barge"), start=start_h * HOUR, bottom=0.0, length=B,
                      wall_slope=0.0, growth=_linear_growth)
        _run_start(tl)
        cal = tl.window_calibration
        assert cal["polder_level_m"] == 0.0 and cal["time_s"] == pytest.approx(5 * HOUR, abs=1.0)
        assert cal["steps"][0]["weir_discharge"] == 0.0 and cal["flowing"]
        got.append((tl.window_coefficient, tl.open_breach_window()))
    assert got[0][0] == pytest.approx(0.7 * C_REPORT, rel=1e-12)
    assert got == [got[0]] * 3
