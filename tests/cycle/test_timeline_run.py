"""A closure run in time end to end (slow): the cycle files' polder level and the balance time follow a
separate integration of the run's own discharges; the plan and the CF variables are written."""
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import solve_ivp

from breachflow.cycle.main import run_closure
from breachflow.scenario.toml import scenario_with

CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


@pytest.mark.slow
def test_run_that_cannot_close_follows_an_independent_polder_integration(tmp_path):
    # 1.4-1.9 t masses by helicopter (20 t/h: ~15 min a cycle), an unreachable end criterion, a small polder
    text = scenario_with(CI_CLOSURE, {"criteria.max_cycles": 4, "closure.method": "helicopter", "closure.start": "0.25 h",
                                      "closure.breach_date": "2005-08-29T09:00",
                                      "placement.diameter": ["1.0 m", "1.1 m"], "polder.area": "8 ha",
                                      "polder.pump_capacity": "2 m^3/s"})
    scen = tmp_path / "s.toml"
    scen.write_text(text)
    res = run_closure(scen, tmp_path / "run", plots=True)
    assert not res.closed and res.plan is not None
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    start = man["metadata"]["timeline_start"]
    with xr.open_mfdataset(str(tmp_path / "run" / "cycle_*.nc"), decode_times=False) as ds:
        t = ds["operation_time"].values.astype(float)
        q = ds["breach_discharge"].values.astype(float)
        zp = ds["polder_level"].values.astype(float)
        zf = ds["flood_level"].values.astype(float)
        assert ds["operation_time"].attrs["units"] == "seconds since 2005-08-29 09:00:00"
    # independent: from the level at the start, each interval with the discharge of the previous solve
    area, pump = 8e4, 2.0
    edges = np.concatenate([[start["operation_time"]], t])
    flows = np.concatenate([[start["timeline_discharge"]], q[:-1]])
    assert start["balance_time"] is None  # the polder is below the flood level at the start
    z, t_bal, ref = start["polder_level"], None, []
    for k in range(t.size):
        def meets(tt, zz, f=zf[k]):
            return zz[0] - f  # constant flood level of the CI scene
        meets.terminal = True
        sol = solve_ivp(lambda tt, zz, qq=flows[k]: [(qq - pump) / area], (edges[k], edges[k + 1]), [z],
                        events=meets, rtol=1e-10, atol=1e-12)
        if sol.t_events[0].size:
            t_bal, z = float(sol.t_events[0][0]), zf[k]
        else:
            z = float(sol.y[0, -1])
        ref.append(z)
        if t_bal is not None:  # after the balance the breach flow reverses: not part of this check
            break
    n = len(ref)
    np.testing.assert_allclose(zp[:n] - start["polder_level"], np.array(ref) - start["polder_level"], rtol=0.01)
    assert t_bal is not None, "the small polder should meet the flood level within the run"
    assert res.plan["window"]["balance_time_s"] == pytest.approx(t_bal, rel=0.01)
    # operation times: start + tonnes / 20 t/h
    delivered = np.array([row["delivered_t"] for row in res.plan["timeline"] if row["phase"].startswith("cycle")])
    np.testing.assert_allclose(t - 0.25 * 3600, delivered / 20.0 * 3600.0, rtol=1e-9)
    assert (tmp_path / "run" / "closure_plan.json").exists() and (tmp_path / "run" / "closure_plan.png").exists()
