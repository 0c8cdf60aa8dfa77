"""The command line as a user meets it (issue 15): --version, python -m breachflow, -q/-v, piped output,
one output flag, runners listed, errors naming CLI flags, warnings in run.log, solver progress."""
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

import breachflow
from breachflow.cli import _common, app
from breachflow.errors import BreachflowWarning, InputError

runner = CliRunner()
DATA = os.path.join(os.path.dirname(__file__), "hydro_io", "data")


def _bf(*args, extra_env=None, **kw):
    """`python -m breachflow ARGS` in a subprocess with stdout/stderr piped (not a terminal), no COLUMNS."""
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES", "TERMINAL_WIDTH")}
    env.update(extra_env or {})
    return subprocess.run([sys.executable, "-m", "breachflow", *args], capture_output=True, text=True, env=env,
                          timeout=300, **kw)


def test_version_flag_and_python_dash_m():
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.output.startswith(f"breachflow {breachflow.__version__}")
    p = _bf("--version")
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith(f"breachflow {breachflow.__version__}")


def test_piped_output_is_not_wrapped_and_floats_are_rounded():
    """Piped, rich assumed 80 columns and broke table cells over lines; `--levee-height "10 ft"` printed
    `h_W = 3.0479999999999996 m`."""
    from breachflow.scenario import flood_presets

    p = _bf("window", "--list-presets")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    for preset in flood_presets():
        row = next(l for l in lines if f" {preset.key} " in l)
        assert preset.event in row, (preset.key, row)
    p = _bf("growth", "--levee-height", "10 ft")
    assert p.returncode == 0, p.stderr
    assert "h_W = 3.048 m" in p.stdout and "3.0479999" not in p.stdout
    # table titles are not broken over lines either (they wrapped at the table's own width)
    title = next(l for l in p.stdout.splitlines() if l.startswith("Breach length B (m) vs development time"))
    assert title.rstrip().endswith("h_W = 3.048 m"), title


def test_quiet_and_verbose():
    args = ["window", "--surge-height", "9.2 ft", "--fall-rate", "40 cm/hr", "--polder-area", "800 ha",
            "--inundation-depth", "90 cm", "--discharge", "7060 cfs"]
    loud = runner.invoke(app, args)
    assert loud.exit_code == 0 and "closure window" in loud.output.lower()
    quiet = runner.invoke(app, ["--quiet", *args])
    assert quiet.exit_code == 0 and quiet.output.strip() == ""
    both = runner.invoke(app, ["-q", "-v", *args])
    assert both.exit_code != 0


COMMANDS_WITH_OUTPUT = ["run", "model-problem", "combine", "ingest", "window", "solve", "settle", "ensemble"]


@pytest.mark.parametrize("command", COMMANDS_WITH_OUTPUT)
def test_one_output_flag_spelling(command):
    """Every subcommand that writes takes `--out/-o`; the old `--output` is accepted but not shown."""
    from breachflow.cli import app as typer_app
    import typer.main

    cmd = typer.main.get_command(typer_app).commands[command]
    out = [p for p in cmd.params if "--out" in p.opts]
    assert out and "-o" in out[0].opts and not out[0].hidden, [p.opts for p in cmd.params]
    for p in cmd.params:
        if "--output" in p.opts:
            assert p.hidden, (command, p.opts)


def test_old_output_spelling_still_works(tmp_path):
    res = runner.invoke(app, ["model-problem", "--output", str(tmp_path / "a.nc")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "a.nc").stat().st_size > 0
    res = runner.invoke(app, ["model-problem", "--out", str(tmp_path / "b.nc"), "--output", str(tmp_path / "c.nc")])
    assert res.exit_code != 0


def test_list_runners_lists_closure():
    p = _bf("ensemble", "--list-runners")  # a fresh process: nothing imported the closure runner yet
    assert p.returncode == 0, p.stderr
    names = {line.split(":")[0].strip() for line in p.stdout.splitlines() if ":" in line}
    assert {"window", "closure", "synthetic"} <= names, p.stdout


def test_errors_name_cli_flags_not_keywords(tmp_path):
    res = runner.invoke(app, ["ingest", os.path.join(DATA, "depth_max.asc"), os.path.join(DATA, "velocity_max.asc"),
                              "--units", "ft", "--bed", "0 ft", "-o", str(tmp_path / "a.nc")])
    assert isinstance(res.exception, InputError)
    msg = str(res.exception)
    assert "--velocity-direction" in msg and "velocity_direction" not in msg
    res = runner.invoke(app, ["ingest", os.path.join(DATA, "depth_max.asc"), "--bed", "0 ft", "-o", str(tmp_path / "b.nc")])
    msg = str(res.exception)
    assert "--units m or --units ft" in msg and "units=" not in msg
    res = runner.invoke(app, ["solve", "--resolution", "4 kg"])
    assert "--resolution" in str(res.exception)


def test_warnings_reach_the_console_and_the_run_log(tmp_path, capsys):
    _common.reset()
    con = _common.console()
    con.print("before the log was attached")
    log = con.attach_log(tmp_path / "run.log")
    old = warnings.showwarning
    try:
        _common.install_warning_hook()
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            _common.install_warning_hook()
            warnings.warn("implausible depth 40 m at node 7", BreachflowWarning)
    finally:
        warnings.showwarning = old
        _common.reset()
    text = log.read_text()
    assert "before the log was attached" in text
    assert "warning: implausible depth 40 m at node 7" in text
    assert "implausible depth 40 m at node 7" in capsys.readouterr().err


def test_run_to_steady_reports_progress():
    from breachflow.swe import SWEOptions, SWESimulation
    from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

    surface = np.where(np.arange(20)[None, :] < 10, 2.0, 1.0)  # a dam break: never steady within 5 s
    dom = uniform_grid(0.0, 20.0, 0.0, 1.0, 1.0, dy=1.0, bed=0.0, initial_surface=surface,
                       boundaries={"west": [BC.wall()], "east": [BC.wall()]})
    sim = SWESimulation(dom, SWEOptions(order=1))
    seen = []
    hist = sim.run_to_steady(tolerance=1e-12, t_max=5.0, check_interval=1.0,
                             progress=lambda s, h: seen.append((s.t, len(h.time))))
    assert not hist.converged and len(seen) == 5
    assert [n for _, n in seen] == list(range(1, len(hist.time) + 1))
    assert np.all(np.diff([t for t, _ in seen]) > 0) and seen[-1][0] == pytest.approx(5.0)


@pytest.mark.parametrize("command", ["run", "ingest", "ensemble", "export", "stone-size"])
def test_piped_help_is_not_squeezed_to_80_columns(command):
    """Piped, rich drew --help at 80 columns: each option's description became a narrow column broken
    every few words. Piped help is 120 wide (or $COLUMNS)."""
    p = _bf(command, "--help")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert max(len(l) for l in lines) == 120, max(len(l) for l in lines)
    narrow = _bf(command, "--help", extra_env={"COLUMNS": "70"})
    assert max(len(l) for l in narrow.stdout.splitlines()) == 70
    if command == "ingest":
        row = next(l for l in lines if "--crs" in l)
        assert "(overrides the files); in the" in row, row
