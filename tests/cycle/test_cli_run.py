"""`breachflow run` (the README's main command) on the embedded default scenario, and `combine`."""
import numpy as np
import xarray as xr
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.output import RunDirectory

runner = CliRunner()


def test_default_run_closes_the_breach_and_combines(tmp_path):
    out = tmp_path / "run"
    res = runner.invoke(app, ["run", "--out", str(out)], terminal_width=200)
    assert res.exit_code == 0, res.output
    assert "closure summary" in res.output and "closure achieved" in res.output
    rd = RunDirectory(out)
    man = rd.manifest()
    assert man["finished"] and rd.verify() == []
    q0 = man["metadata"]["initial"]["breach_discharge"]
    last = man["cycles"][-1]["summary"]
    # the embedded scenario is built to close: the flow through the breach practically stops
    assert last["closed"] and last["breach_discharge"] < 0.05 * q0
    for png in ("plan_view.png", "closure_progress.png"):
        assert (out / png).stat().st_size > 20_000
    # the plan view explains itself: a legend of its marks, and why the run counts as closed
    from breachflow.cycle.plots import closure_reason, plan_view_figure

    fig = plan_view_figure(rd)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("no-flow" in t for t in labels) and any("resting" in t for t in labels) \
        and any("moving" in t for t in labels) and any("contour" in t for t in labels)
    governing = last["governing"]
    reason = closure_reason(rd)
    assert fig._suptitle.get_text() == reason
    assert reason.startswith(f"closed at cycle {len(man['cycles'])}: ") and governing in reason
    assert f"{last['criteria'][governing]['value']:.3g}" in reason
    arch = tmp_path / "archive.nc"
    res = runner.invoke(app, ["combine", str(out), "-o", str(arch)])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(arch) as ds:
        assert ds.sizes["cycle"] == len(man["cycles"])
        assert ds.sizes["particle"] == last["masses"]
        np.testing.assert_allclose(ds.depth.isel(cycle=-1).values, rd.open_cycle(rd.last_cycle()).depth.values)
    # running the default again in the same place is allowed (it overwrites its own default run)
    res = runner.invoke(app, ["run", "--out", str(out), "--resume"])
    assert res.exit_code == 0, res.output


def test_progress_lines_show_the_criteria(tmp_path):
    res = runner.invoke(app, ["run", "--out", str(tmp_path / "r")], terminal_width=400)
    assert res.exit_code == 0, res.output
    assert "[max_speed " in res.output and "blocked_fraction " in res.output
