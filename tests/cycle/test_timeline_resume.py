"""A closure run in time, interrupted after cycle k and resumed, ends exactly as the run left alone: the same
operation times, flood and polder levels, breach discharges per cycle, and the same final record."""
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.io import RunDirectory
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()
#: 1.4-1.9 t masses by helicopter (20 t/h: ~15 min a cycle) into a small polder with pumps: the polder
#: level, the flood-side boundary and the discharge all change from cycle to cycle
TEXT = scenario_with(CI_CLOSURE, {"criteria.max_cycles": 3, "closure.method": "helicopter", "closure.start": "0.25 h",
                                  "placement.diameter": ["1.0 m", "1.1 m"], "polder.area": "8 ha",
                                  "polder.pump_capacity": "2 m^3/s"})
PER_CYCLE = ("operation_time", "flood_level", "polder_level", "breach_discharge")


class Crash(Exception):
    pass


def _run(path, resume=False, crash_after=None):
    def progress(rep):
        if crash_after is not None and rep.cycle == crash_after:
            raise Crash()

    run = ClosureRun(closure_setup(parse_scenario(TEXT)), path, TEXT, resume=resume, progress=progress)
    run.run()
    return RunDirectory(path)


def _per_cycle(rd):
    out = {}
    for g in rd.completed_cycles():
        with xr.open_dataset(rd.cycle_path(g), decode_times=False) as ds:
            out[g] = {k: ds[k].values.copy() for k in PER_CYCLE}
    return out


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("timeline_resume") / "full")


@pytest.mark.parametrize("k", [1, 2])
def test_resumed_run_in_time_is_identical_to_the_uninterrupted_run(reference, tmp_path, k):
    ref = _per_cycle(reference)
    assert sorted(ref) == [1, 2, 3]
    # the timeline is live in this scene: the polder rises, the clock advances by the delivered tonnes
    t = np.array([ref[g]["operation_time"].item() for g in ref])
    zp = np.array([ref[g]["polder_level"].item() for g in ref])
    q = np.array([ref[g]["breach_discharge"].item() for g in ref])
    assert np.all(np.diff(t) > 0) and zp[1] > zp[0] and np.all(np.diff(q) != 0)
    with pytest.raises(Crash):
        _run(tmp_path / "r", crash_after=k)
    assert RunDirectory(tmp_path / "r").completed_cycles() == list(range(1, k + 1))
    resumed = _run(tmp_path / "r", resume=True)
    got = _per_cycle(resumed)
    assert sorted(got) == sorted(ref)
    for g in ref:
        for name in PER_CYCLE:
            np.testing.assert_array_equal(got[g][name], ref[g][name], err_msg=f"cycle {g} {name}")
    man_ref, man = reference.manifest(), resumed.manifest()
    for a, b in zip(man_ref["cycles"], man["cycles"]):
        assert a["summary"]["timeline"] == b["summary"]["timeline"], a["cycle"]
    assert man_ref["final"] == man["final"]
    assert man_ref["metadata"]["timeline_start"] == man["metadata"]["timeline_start"]
