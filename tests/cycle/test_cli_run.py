"""`breachflow run` (the README's main command) on the embedded default scenario, and `combine`."""
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.io import RunDirectory

runner = CliRunner()


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    """``breachflow run --out D`` on the embedded default scenario, once for the tests of this module (the
    default run is the most expensive thing here): ``(D, CliRunner result)``. Wide enough (400 columns) that
    a progress line is not wrapped."""
    out = tmp_path_factory.mktemp("default_run") / "run"
    return out, runner.invoke(app, ["run", "--out", str(out)], terminal_width=400)


def test_default_run_closes_the_breach_and_combines(default_run, tmp_path):
    out, res = default_run
    assert res.exit_code == 0, res.output
    assert "closure summary" in res.output and "closure achieved" in res.output
    rd = RunDirectory(out)
    man = rd.manifest()
    assert man["finished"] and rd.verify() == []
    q0 = man["metadata"]["initial"]["breach_discharge"]
    last = man["cycles"][-1]["summary"]
    # the embedded scenario is built to close a leaky rock-fill dam (remap "porous"): the flow over the crest
    # stops, what still passes the breach section is seepage through the pile, well below the open breach's
    # flow
    assert last["closed"] and last["governing"] == "overflow_discharge+polder_leakage"
    assert 0 < last["seepage_discharge"] < 0.3 * q0
    assert last["breach_discharge"] - last["seepage_discharge"] < 0.5
    # ... and the sealing is part of the run: the seal on the rock's upstream face brings the leakage below the
    # polder's 1 cm/day (100 ha: 0.116 m3/s)
    assert "closed and sealed" in res.output and "polder rise of" in res.output
    # the seepage is that of the pile by hand: 1-D Dupuit–Forchheimer over the breach width, with the final
    # pile's bulk porosity and stone size from the spheres and its path length at the base (longest) and at
    # the water line (shortest): the model lies between the two
    q_long, q_short = _hand_seepage(rd, man)
    assert 0.9 * q_long < last["seepage_discharge"] < 1.1 * q_short, (q_long, last["seepage_discharge"], q_short)
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
    assert fig._suptitle.get_text().replace("\n", " ") == reason  # wrapped to the figure's width
    assert reason.startswith(f"closed at cycle {len(man['cycles'])}: ")
    for name in governing.split("+"):  # mode "all": every criterion governs
        assert name in reason and f"{last['criteria'][name]['value']:.3g}" in reason
    assert "through the rock; sealed with" in reason and "m of finer fill" in reason
    left = float(reason.split("of finer fill: ")[1].split(" m³/s")[0])
    assert 0 < left <= 0.01 * 100e4 / 86400
    arch = tmp_path / "archive.nc"
    res = runner.invoke(app, ["combine", str(out), "-o", str(arch)])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(arch) as ds:
        assert ds.sizes["cycle"] == len(man["cycles"])
        assert ds.sizes["particle"] == last["masses"]
        np.testing.assert_allclose(ds.depth.isel(cycle=-1).values, rd.open_cycle(rd.last_cycle()).depth.values)
    # the check's extra seed took the run's start state (the solves before cycle 1) instead of solving it again
    # (breachflow.cycle.start_state; tests/cycle/test_start_state.py: the same cycles to the bit)
    own = man["metadata"]["initial"]["start_state"]
    assert own["solved"] and Path(own["file"]).is_file()
    members = sorted((out / "check" / "seeds" / "members").glob("*/closure"))
    assert members
    for m in members:
        initial = RunDirectory(m).manifest()["metadata"]["initial"]
        assert initial["start_state"] == {**own, "solved": False}  # the run's own file, found from the member
        assert initial["breach_discharge"] == q0
    # running the default again in the same place is allowed (it overwrites its own default run)
    res = runner.invoke(app, ["run", "--out", str(out), "--resume"])
    assert res.exit_code == 0, res.output


def _hand_seepage(rd, man, half=6.0):
    """``(Q_long, Q_short)`` (m³/s): Dupuit–Forchheimer discharge through the final pile over the breach (``2 half`` m),
    Ergun with the pile's bulk porosity (solid volume of the resting spheres in the columns / pile volume)
    and chord-weighted stone size, upstream depth at the flood level, downstream depth at the centre
    column's toe, path length the median over the breach columns of the pile's length at the base / at the
    water line."""
    from scipy.optimize import brentq

    from breachflow.cycle.remap import pile_columns
    from breachflow.swe.porous import forchheimer_coefficients, forchheimer_dam_length

    ds = rd.open_cycle(rd.last_cycle())
    ds = ds.isel(cycle=0) if "cycle" in ds.dims else ds
    x, y, bed = ds.x.values, ds.y.values, ds.bed_elevation.values
    pos = np.stack([ds.particle_x.values, ds.particle_y.values, ds.particle_z.values], 1)
    ok = np.isfinite(pos).all(1) & (ds.particle_resting.values == 1) & (ds.particle_active.values == 1)
    top, solid, dsum = np.full(bed.shape, -np.inf), np.zeros(bed.shape), np.zeros(bed.shape)
    pile_columns(x, y, bed, np.ascontiguousarray(pos[ok]), np.ascontiguousarray(0.5 * ds.particle_diameter.values[ok]),
                 np.ones(ok.sum(), np.bool_), 8, top, solid, dsum)
    height = np.where(np.isfinite(top), np.maximum(top - bed, 0.0), 0.0)
    n, d = 1 - solid.sum() / height.sum(), dsum.sum() / solid.sum()
    ic, j0 = int(np.argmin(np.abs(x))), int(np.argmin(np.abs(y)))
    b0, ws = bed[j0, ic], ds.water_surface.values
    js = np.flatnonzero(height[:, ic] > 0)
    h1, h2 = ws[js.min() - 2, ic] - b0, ws[js.max() + 1, ic] - b0

    def length(z):
        cols = [np.flatnonzero(height[:, i] + bed[:, i] - b0 > z) for i in np.flatnonzero(np.abs(x) < half)]
        return float(np.median([(c.max() - c.min() + 1) * (y[1] - y[0]) for c in cols if c.size]))

    A, B = (float(v) for v in forchheimer_coefficients(n, d))

    def q_of(L):  # the dam length falls with q: bracket, then solve
        hi = 1.0
        while forchheimer_dam_length(hi, h1, h2, A, B) > L:
            hi *= 2.0
        return brentq(lambda q: forchheimer_dam_length(q, h1, h2, A, B) - L, 1e-6, hi)

    return tuple(2 * half * q_of(L) for L in (length(0.0), length(h1)))


def test_progress_lines_show_the_criteria(default_run):
    _, res = default_run
    assert res.exit_code == 0, res.output
    assert "[overflow_discharge " in res.output and "polder_leakage " in res.output


# --------------------------------------------------------------------------- issue 15: never lose a user's run
from breachflow.cli.run import check_run_target  # noqa: E402
from breachflow.cycle.main import default_scenario_text, run_closure  # noqa: E402
from breachflow.errors import InputError, ParseError  # noqa: E402
from breachflow.scenario.config import parse_scenario  # noqa: E402

from .test_closure_run import ci_scene  # noqa: E402


def test_a_users_run_is_never_replaced_without_overwrite(tmp_path):
    """`run my.toml --out D`, then `run --out D` (scenario forgotten) used to replace the user's run with the
    default scenario (rc 0). Now it is refused, names the flags, and leaves the run as it was."""
    out = tmp_path / "mine"
    text = ci_scene(2, "no_flow")
    (tmp_path / "mine.toml").write_text(text)
    RunDirectory(out).start(text, seed=5, metadata={"scenario_path": str(tmp_path / "mine.toml")})
    before = (out / "manifest.json").read_bytes()
    for args in (["run", "--out", str(out)], ["run", str(tmp_path / "mine.toml"), "--out", str(out)]):
        res = runner.invoke(app, args)
        assert res.exit_code != 0, res.output
        assert isinstance(res.exception, InputError)
        msg = str(res.exception)
        assert "--resume" in msg and "--overwrite" in msg and "mine.toml" in msg
        assert (out / "manifest.json").read_bytes() == before
        assert (out / "scenario.toml").read_text() == text


def test_no_run_is_replaced_without_overwrite_not_even_the_default(tmp_path):
    """Issue 27: a second `breachflow run` of the embedded default used to replace the first's directory
    silently (even while the first was running, and a crashed default run with committed cycles); now every
    run, the default's included, is refused without --overwrite."""
    out = tmp_path / "default"
    RunDirectory(out).start(default_scenario_text(), seed=0)
    with pytest.raises(InputError, match="holds a run of the embedded default scenario .*--overwrite"):
        check_run_target(None, out, resume=False, overwrite=False)
    assert check_run_target(None, out, resume=False, overwrite=True) is True
    with pytest.raises(InputError, match="--overwrite"):
        check_run_target(tmp_path / "other.toml", out, resume=False, overwrite=False)
    assert check_run_target(tmp_path / "other.toml", out, resume=False, overwrite=True) is True
    with pytest.raises(InputError, match="nothing to resume"):
        check_run_target(None, tmp_path / "nothing", resume=True, overwrite=False)


def test_resume_without_a_scenario_uses_the_stored_one_sweeps_and_logs(tmp_path):
    """A run stopped after cycle 1 (with the temp file a kill during cycle 2's writes leaves) resumes with
    `run --out D --resume` alone, from the scenario.toml stored in D, says where it resumes, sweeps the
    temp file, and logs the console output to D/run.log."""
    scen = tmp_path / "mine.toml"
    scen.write_text(ci_scene(2, "no_flow"))
    out = tmp_path / "mine"

    class Stop(Exception):
        pass

    def stop(rep):
        raise Stop()

    with pytest.raises(Stop):
        run_closure(scen, out, progress=stop, plots=False)
    stray = ".cycle_0002_trajectories.nc.ab12cd34.nc"
    (out / stray).write_bytes(b"partial")
    scen.unlink()  # even the user's file is gone: the stored copy is what resumes
    res = runner.invoke(app, ["run", "--out", str(out), "--resume", "--no-plots"])
    assert res.exit_code == 0, res.output
    assert "resuming after cycle 1" in res.output and stray in res.output
    # what runs until cycle 2 ends is cycle 2, not the set-up (its flow is read from cycle 1's file)
    assert "cycle 2 (resumed after cycle 1): done" in res.output and "open breach (before cycle 1): done" not in res.output
    assert RunDirectory(out).completed_cycles() == [1, 2]
    assert not (out / stray).exists()
    log = (out / "run.log").read_text()
    assert "resuming after cycle 1" in log and "cycle   2" in log and "closure summary" in log
    man = RunDirectory(out).manifest()
    assert [s["action"] for s in man["sessions"]] == ["start", "resume"]


def test_a_bad_placement_leaves_no_run_directory(tmp_path):
    scen = tmp_path / "far.toml"
    scen.write_text(ci_scene(2, "no_flow", {"placement.start": ["-400 m", "0 m"]}))
    out = tmp_path / "far"
    res = runner.invoke(app, ["run", str(scen), "--out", str(out)])
    assert res.exit_code != 0
    assert isinstance(res.exception, InputError) and "placement.start" in str(res.exception)
    assert not out.exists()


@pytest.mark.parametrize("key, bad", [("batch", '"five"'), ("batch", "2.5"), ("max_cycles", '"ten"')])
def test_type_errors_name_the_key_and_line(tmp_path, key, bad):
    text = ci_scene(2, "no_flow")
    line = next(i for i, l in enumerate(text.splitlines(), 1) if l.startswith(f"{key} ="))
    text = "\n".join(f"{key} = {bad}" if i == line else l for i, l in enumerate(text.splitlines(), 1))
    with pytest.raises(ParseError) as info:
        parse_scenario(text, path=tmp_path / "s.toml")
    assert info.value.line == line and f"] {key}" in str(info.value) and bad.strip('"') in str(info.value)
