"""Runs that differ only in their placement seed share the solves before their first cycle
(:mod:`breachflow.cycle.start_state`): a run that takes the stored start computes what it would have solved."""
import json

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.cycle.main import default_scenario_text, run_closure
from breachflow.cycle.start_state import load, path_of, reusable, start_key
from breachflow.io import RunDirectory
from breachflow.scenario import parse_scenario

from .._scenes import TINY_CLOSURE_MEMBER

#: what a run records about its own execution, not about what it computed
TIMING = {"wall_time", "time_dem", "time_solve", "time_output", "cpu_dem", "cpu_solve", "completed"}


def _scenario(seed: int, cycles: int = 1) -> str:
    text = default_scenario_text()
    assert "max_cycles = 24\n" in text and "\nseed = 1\n" in text
    return text.replace("max_cycles = 24\n", f"max_cycles = {cycles}\n").replace("\nseed = 1\n", f"\nseed = {seed}\n")


def _summaries(rd):
    return [{k: v for k, v in c["summary"].items() if k not in TIMING} for c in rd.manifest()["cycles"]]


def _frozen(seed: int) -> str:
    """A small closure without a timeline (no ``[closure] method``: one solve before cycle 1), at *seed*."""
    return TINY_CLOSURE_MEMBER.replace("max_cycles = 2", "max_cycles = 1") + f"[closure]\nseed = {seed}\n"


@pytest.mark.parametrize("scene", ["default", "without timeline"])
def test_a_run_from_the_stored_start_computes_what_it_would_have_solved(tmp_path, scene):
    """Seed 2 of the default scenario (closure in time) and of a closure without a timeline, one cycle:
    solved with the store (it writes its start there), then again taking it from there. The start's flow,
    the timeline's pre-start history and calibrations, and the cycle (its flow field, particles and summary)
    are the same to the bit."""
    store = tmp_path / "starts"
    text = _scenario(2) if scene == "default" else _frozen(2)
    assert start_key(text) == start_key(_scenario(1) if scene == "default" else _frozen(1))
    for name, take in (("solved", False), ("taken", True)):  # the first as `breachflow run` does: solve, write
        (tmp_path / f"{name}.toml").write_text(text)
        run_closure(tmp_path / f"{name}.toml", tmp_path / name, plots=False, start_states=store, take_start=take)
    solved, taken = RunDirectory(tmp_path / "solved"), RunDirectory(tmp_path / "taken")
    key = start_key(text)
    assert [p.name for p in store.iterdir()] == [f"{key}.nc"]
    meta_s, meta_t = solved.manifest()["metadata"], taken.manifest()["metadata"]
    assert meta_s["initial"]["start_state"] == {"key": key, "file": str(path_of(store, key)), "solved": True}
    assert meta_t["initial"]["start_state"]["solved"] is False
    if scene == "default":  # the solves were not repeated: the set-up's CPU time is that of reading one file
        assert meta_t["initial"]["solve_cpu_time"] < 0.1 * meta_s["initial"]["solve_cpu_time"]
    for k in ("breach_discharge", "max_speed", "gap_mean_speed", "control_speed", "discharge_proxy", "gap_speed"):
        assert meta_t["initial"][k] == meta_s["initial"][k], k
    assert meta_t.get("timeline_start") == meta_s.get("timeline_start")  # clock, polder, weirs, history, calibrations
    assert ("timeline_start" in meta_s) is (scene == "default")
    assert _summaries(taken) == _summaries(solved)
    with solved.open_cycle(1) as a, taken.open_cycle(1) as b:
        assert sorted(a.data_vars) == sorted(b.data_vars)
        for v in a.data_vars:
            np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)
    # a run told not to take a start (`breachflow run` itself) does not, though its key is in the store
    for take in (True, False):
        run = ClosureRun(closure_setup(parse_scenario(text)), tmp_path / f"own_{take}", text, start_states=store,
                         take_start=take)
        assert (run._stored_start() is not None) is take
        run.rundir.close()


def test_the_key_ignores_the_seed_and_the_check_and_nothing_else():
    text = default_scenario_text()
    key = start_key(text)
    assert start_key(text.replace("\nseed = 1\n", "\nseed = 7\n")) == key
    assert start_key(text.replace("\nseeds = 2\n", "\nseeds = 3\n")) == key  # [check]
    assert start_key(text.replace('resolution = "1 m"', 'resolution = "0.9 m"')) != key
    assert start_key(text.replace("max_cycles = 24", "max_cycles = 23")) != key  # conservative: any other key


def test_only_flow_models_without_memory_share_a_start():
    text = default_scenario_text()
    assert reusable(closure_setup(parse_scenario(text)).solver)
    # a region re-solve keeps its region between solves
    region = text.replace('resolution = "1 m"', 'resolution = "1 m"\nresolve = "region"')
    assert not reusable(closure_setup(parse_scenario(region)).solver)


def test_an_unreadable_or_foreign_start_file_is_not_taken(tmp_path):
    key = "0" * 64
    path_of(tmp_path, key).write_bytes(b"not a netcdf file")
    assert load(tmp_path, key) is None
    # a readable file written for another key (renamed): not taken
    ds = xr.Dataset({"depth": (("y", "x"), np.zeros((2, 2)))}, attrs={"start_key": "1" * 64, "start_state": json.dumps(None)})
    ds.to_netcdf(path_of(tmp_path, key))
    assert load(tmp_path, key) is None
    assert load(tmp_path, "2" * 64) is None  # no file


def test_a_run_whose_check_is_off_keeps_no_start_state(tmp_path):
    """`breachflow run` keeps its start for the check's extra seeds; with `[check] enabled = false` no seed
    takes it, and the run directory holds no `check/` folder."""
    from typer.testing import CliRunner

    from breachflow.cli import app

    path = tmp_path / "tiny.toml"
    path.write_text(_frozen(1) + "[check]\nenabled = false\n")
    res = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "run"), "--no-plots"])
    assert res.exit_code == 0, res.output
    man = RunDirectory(tmp_path / "run").manifest()
    assert man["finished"] and man["metadata"]["initial"]["start_state"]["solved"]
    assert not (tmp_path / "run" / "check").exists()


def test_the_finer_grid_calibrates_from_the_runs_weir_coefficient(tmp_path, monkeypatch):
    """The verdict check's finer grid: the default scenario at 2 m calibrates its weir at the start; at 1 m the
    calibration begins from that coefficient (``weir_coefficient``) instead of the report's, at the 2 m
    start's polder level, and ends within the calibration's tolerance in one solve where from the report's
    coefficient the 2 m run took more; such a run shares no start state. The check hands the run's coefficient to its
    finer grid's closures and open-breach solve."""
    from breachflow.cycle.timeline import CALIBRATION_TOLERANCE
    from breachflow.ensemble import check as check_mod
    from breachflow.ensemble.check import START_STATES, CheckSection, run_check
    from breachflow.scenario.toml import scenario_with

    coarse = scenario_with(_scenario(2), {"hydro.resolution": "2 m"})
    fine = scenario_with(_scenario(2), {"hydro.resolution": "1 m"})
    for name, text in (("coarse", coarse), ("fine", fine)):
        (tmp_path / f"{name}.toml").write_text(text)
    run_closure(tmp_path / "coarse.toml", tmp_path / "coarse", plots=False, start_states=tmp_path / "coarse" / "check" / START_STATES,
                take_start=False)
    start = RunDirectory(tmp_path / "coarse").manifest()["metadata"]["timeline_start"]
    weir = start["weir_coefficient"]
    assert weir != start["weir_calibration"][0]["weir_coefficient"]  # calibrated: not the report's

    run_closure(tmp_path / "fine.toml", tmp_path / "seeded", plots=False, start_states=tmp_path / "other",
                weir_coefficient=weir)
    seeded = RunDirectory(tmp_path / "seeded").manifest()["metadata"]
    steps = seeded["timeline_start"]["weir_calibration"]
    assert steps[0]["weir_coefficient"] == weir and steps[0]["polder_level"] == start["polder_level"]
    assert len(steps) == 1 < len(start["weir_calibration"])  # the 2 m run, from the report's: more solves
    assert abs(steps[-1]["model_discharge"] / steps[-1]["weir_discharge"] - 1) <= CALIBRATION_TOLERANCE
    assert seeded["initial"]["weir_calibration_from"] == weir
    assert RunDirectory(tmp_path / "coarse").manifest()["metadata"]["initial"]["weir_calibration_from"] is None
    assert seeded["initial"]["start_state"] is None and not (tmp_path / "other").exists()

    # the check: its extra seeds take the run's start, the finer grid's closures calibrate from its coefficient
    specs, solved = [], []
    monkeypatch.setattr(check_mod, "_execute", lambda spec, out, workers, console: specs.append(spec) or
                        [{"status": "error", "error_type": "Skipped", "error_message": "not run"}] * len(spec.member_values))
    # the open breach (both grids, marched for the flow's time means): each solve from the run's coefficient
    monkeypatch.setattr(check_mod, "_open_breach_on", lambda sc, path, res, section, w=None, fine=True, windows=0:
                        solved.append((w, fine, windows)) or
                        check_mod.CheckRun(label="1 m", cell_size=1.0, seed=-1, closed=None))
    run_check(tmp_path / "coarse", coarse, section=CheckSection(seeds=2, refine_seeds=1, grid="uniform"))
    assert [s.options for s in specs] == [{"start_states": f"../{START_STATES}"}, {"weir_coefficient": weir}]
    assert solved == [(weir, False, 4), (weir, True, 4)]
    run_check(tmp_path / "coarse", coarse, section=CheckSection(seeds=1, refine_seeds=0, grid="nested",
                                                                 flow_mean_windows=0))
    assert solved[2:] == [(weir, True, 0)]


@pytest.mark.parametrize("bad", [0.0, -1.37, float("nan")])
def test_a_bad_weir_coefficient_is_refused_before_the_run_starts(tmp_path, bad):
    from breachflow.errors import InputError

    text = _scenario(2)
    with pytest.raises(InputError, match="weir_coefficient: .* positive number"):
        ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "run", text, weir_coefficient=bad)
    assert not (tmp_path / "run").exists()
