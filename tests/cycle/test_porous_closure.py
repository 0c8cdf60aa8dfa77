"""The closure cycle with remap = "porous": seepage reported beside the overflow, discharge criteria,
the pile leaks where an impervious raised bed does not, resume is identical."""
import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import CycleContext, criteria, section_discharge
from breachflow.cycle.driver import ClosureRun
from breachflow.cycle.main import ClosureResult
from breachflow.errors import InputError
from breachflow.io import RunDirectory
from breachflow.scenario.config import parse_scenario

from .test_closure_run import Crash, _same, ci_scene


def _run(path, cycles=3, remap="porous", changes=None, resume=False, progress=None):
    text = ci_scene(cycles, remap, changes)
    setup = closure_setup(parse_scenario(text))
    run = ClosureRun(setup, path, text, resume=resume, progress=progress)
    run.run()
    return run


def test_porous_pile_reports_seepage_and_leaks(tmp_path):
    run = _run(tmp_path / "p", cycles=4)
    man = run.rundir.manifest()
    q0 = man["metadata"]["initial"]["breach_discharge"]
    summ = [c["summary"] for c in man["cycles"]]
    q = [s["breach_discharge"] for s in summ]
    seep = [s["seepage_discharge"] for s in summ]
    assert q[-1] < 0.9 * q0  # the pile reduces the flow ...
    assert all(0 < sp <= qq + 1e-9 for sp, qq in zip(seep, q))  # ... and part of it seeps through
    # the same scene with an impervious raised bed passes less water after as many masses
    imp = _run(tmp_path / "r", cycles=4, remap="raised_bed").rundir.manifest()
    assert [c["summary"]["seepage_discharge"] for c in imp["cycles"]] == [0.0] * 4
    assert imp["cycles"][-1]["summary"]["breach_discharge"] < q[-1]
    with xr.open_dataset(run.rundir.cycle_path(4)) as ds:
        # no cell is blocked by masses in porous mode: the obstacles are the domain's own
        obstacle = ds["obstacle"].isel(cycle=0) if "cycle" in ds["obstacle"].dims else ds["obstacle"]
        np.testing.assert_array_equal(obstacle.values.astype(bool), run.setup.domain.obstacle)


def test_discharge_criteria(tmp_path):
    run = _run(tmp_path / "c", cycles=2, changes={"criteria.breach_discharge": "1e4 m^3/s",
                                                "criteria.seepage_discharge": "1e-6 m^3/s",
                                                "criteria.overflow_discharge": "1e-6 m^3/s"})
    rep = run.reports[0]
    by = {r.name: r for r in rep.criteria}
    assert by["breach_discharge"].satisfied and rep.closed  # the breach passes far less than 1e4 m3/s
    assert by["breach_discharge"].value == pytest.approx(abs(rep.breach_discharge))
    assert by["seepage_discharge"].value == pytest.approx(rep.seepage_discharge)
    assert by["overflow_discharge"].value == pytest.approx(abs(rep.breach_discharge) - rep.seepage_discharge)
    assert not by["seepage_discharge"].satisfied
    # the criterion on a hand-made snapshot: Q = sum h v dx over the breach row
    x = np.arange(-5.0, 6.0)
    y = np.array([-1.0, 0.0, 1.0])
    h = np.full((3, x.size), 2.0)
    v = np.full((3, x.size), 0.5)
    ds = xr.Dataset({"depth": (("y", "x"), h), "u": (("y", "x"), 0 * v), "v": (("y", "x"), v),
                     "wet": (("y", "x"), h > 0)}, coords={"x": x, "y": y})
    ctx = CycleContext(cycle=1, snapshot=ds, breach_x=(-3.0, 3.0), levee_y=0.0, seepage_discharge=2.0)
    assert criteria.get("breach_discharge")("6 m^3/s").value(ctx) == pytest.approx(7 * 2.0 * 0.5)
    assert section_discharge(ds, (-3.0, 3.0), 0.0) == pytest.approx(7.0)
    assert criteria.get("overflow_discharge")("1 m^3/s").value(ctx) == pytest.approx(5.0)


def test_porous_run_resumes_identically(tmp_path):
    full = _run(tmp_path / "full", cycles=2)

    def crash_after_first(rep):
        if rep.cycle == 1:
            raise Crash()

    with pytest.raises(Crash):
        _run(tmp_path / "res", cycles=2, progress=crash_after_first)
    _run(tmp_path / "res", cycles=2, resume=True)
    for g in (1, 2):
        _same(full.rundir.cycle_path(g), RunDirectory(tmp_path / "res").cycle_path(g))


def _sheet_flow_snapshot():
    """Still water in the breach area (|y| <= 5 m), a 0.25 m sheet at 3 m/s on the polder 18 m behind it."""
    x = np.arange(-10.0, 11.0)
    y = np.arange(-10.0, 31.0)
    h = np.full((y.size, x.size), 2.0)
    v = np.zeros_like(h)
    v[y > 15] = 3.0
    h[y > 15] = 0.25
    v[np.abs(y) <= 5] = 0.3
    return xr.Dataset({"depth": (("y", "x"), h), "u": (("y", "x"), 0 * v), "v": (("y", "x"), v),
                       "wet": (("y", "x"), h > 0)}, coords={"x": x, "y": y})


def test_max_speed_judges_the_breach_area_not_the_polder_sheet_flow():
    ds = _sheet_flow_snapshot()
    ctx = CycleContext(cycle=1, snapshot=ds, breach_x=(-6.0, 6.0), levee_y=0.0, area=(-8.0, 8.0, -5.0, 5.0))
    gap = criteria.get("max_speed")("0.5 m/s").evaluate(ctx)
    assert gap.value == pytest.approx(0.3) and gap.satisfied
    anywhere = criteria.get("max_speed")(threshold="0.5 m/s", region="domain").evaluate(ctx)
    assert anywhere.value == pytest.approx(3.0) and not anywhere.satisfied
    # without a breach area (a context that has none) the whole domain is judged, as before
    assert criteria.get("max_speed")("0.5 m/s").value(CycleContext(cycle=1, snapshot=ds)) == pytest.approx(3.0)
    with pytest.raises(InputError, match="region"):
        criteria.get("max_speed")(threshold="0.5 m/s", region="polder")


def test_seepage_fraction_and_the_closure_statement():
    ds = _sheet_flow_snapshot()
    ctx = CycleContext(cycle=1, snapshot=ds, seepage_discharge=-12.0, open_breach_discharge=80.0)
    r = criteria.get("seepage_fraction")(0.2).evaluate(ctx)
    assert r.value == pytest.approx(0.15) and r.satisfied
    # unknown open-breach discharge: never met
    assert not criteria.get("seepage_fraction")(0.2).evaluate(CycleContext(cycle=1, snapshot=ds)).satisfied
    res = ClosureResult(run_dir=None, reports=[], closed=True, governing="overflow_discharge+seepage_fraction",
                        cycles=9, masses=45, tonnage=500.0, operation_time=3600.0, closure_window=None,
                        feasible=None, wall_time=1.0, peak_speed=6.0, final_discharge=12.1, final_seepage=12.0,
                        open_breach_discharge=80.0)
    assert res.statement == ("closed (overflow stopped: 0.10 m³/s over the crest); seepage 12.00 m³/s through the "
                             "pile (15% of the open breach's 80.0 m³/s) to be sealed with finer fill")
    assert dict(res.table_rows())["closure achieved"] == "yes: " + res.statement
    res.final_seepage = 0.0
    assert res.statement == "closed" and dict(res.table_rows())["closure achieved"] == "yes"


def test_a_sealed_closure_states_the_sealed_leakage_not_the_rock_seepage():
    # a rock dam with 408.9 m3/s of seepage, then sealed: what is left is the sealed dam's leakage (0.67 m3/s,
    # 0.67 x 86400 / 4.9e7 m2 = 0.118 cm/day), not "to be sealed"
    plan = {"seal": {"sealed": True, "seal_thickness_m": 0.292, "seal_tonnage_t": 396.2},
            "leakage_end": {"breach_discharge_m3_s": 0.668, "polder_rise_m_per_day": 0.668 * 86400 / 4.9e7}}
    res = ClosureResult(run_dir=None, reports=[], closed=True, governing="overflow_discharge+polder_leakage",
                        cycles=12, masses=720, tonnage=8908.0, operation_time=33496.0, closure_window=None,
                        feasible=True, wall_time=1.0, peak_speed=6.0, final_discharge=408.9, final_seepage=408.9,
                        open_breach_discharge=1576.8, plan=plan)
    assert res.statement == ("closed and sealed (0.29 m of seal, 396 t): leakage 0.67 m³/s through the dam, "
                             "a polder rise of 0.12 cm/day")
    assert "to be sealed" not in dict(res.table_rows())["closure achieved"]
    plan["seal"]["sealed"] = False  # a seal that did not meet the criterion leaves the rock stage's statement
    assert res.statement.endswith("to be sealed with finer fill")
