"""One progress helper: a bar on a terminal, periodic plain lines when piped or logged, nothing with --quiet;
and the long commands use it (a piped `run` says what it does before cycle 1, `settle` and `solve` print
progress lines when piped)."""
import io
import time

from rich.console import Console
from typer.testing import CliRunner

from breachflow.cli import app
from breachflow.progress import Progress

from ._scenes import tiny_closure


def _piped():
    buf = io.StringIO()
    return Console(file=buf, force_terminal=False, width=200), buf


def test_piped_progress_prints_a_start_periodic_and_final_line():
    con, buf = _piped()
    with Progress("work", total=4, unit="steps", console=con, interval=0.05) as p:
        for i in range(4):
            time.sleep(0.06)
            p.update(i + 1, note=f"step {i + 1}")
    lines = buf.getvalue().splitlines()
    assert lines[0] == "work: started"
    assert lines[-1].startswith("work: done 4/4 steps step 4")
    assert len(lines) >= 4  # at least one line between start and end (every interval)


def test_heartbeat_without_a_total_and_quiet_prints_nothing():
    con, buf = _piped()
    with Progress("first solve", console=con, interval=0.05):
        time.sleep(0.18)
    lines = buf.getvalue().splitlines()
    assert lines[0] == "first solve: started" and sum("running" in ln for ln in lines) >= 2
    con, buf = _piped()
    with Progress("quiet", console=con, quiet=True, interval=0.01) as p:
        time.sleep(0.03)
        p.update(1)
    assert buf.getvalue() == ""


def test_terminal_shows_a_bar_and_no_plain_lines():
    buf = io.StringIO()
    con = Console(file=buf, force_terminal=True, width=100)
    with Progress("work", total=2, console=con, interval=0.01) as p:
        p.update(1)
        time.sleep(0.02)
        p.update(2)
    assert p.lines == [] and p._bar is not None
    p.__exit__(None, None, None)  # ending twice is harmless


def test_piped_settle_and_solve_print_progress_lines(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["settle", "--diameter", "10 mm", "--drag-law", "report", "--dt", "1e-4 s",
                              "--duration", "0.05 s", "-o", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    assert "settling: started" in res.output and "settling: done" in res.output
    res = runner.invoke(app, ["solve", "demo_breach", "--resolution", "4 m", "--t-max", "5 s", "--order", "1",
                              "-o", str(tmp_path / "snap")])
    assert res.exit_code == 0, res.output
    assert "solving: started" in res.output and "solving: done" in res.output and "s simulated" in res.output


SCENARIO = tiny_closure("progress", max_cycles=1)


def test_piped_run_says_what_it_does_before_cycle_1(tmp_path):
    sc = tmp_path / "s.toml"
    sc.write_text(SCENARIO)
    res = CliRunner().invoke(app, ["run", str(sc), "-o", str(tmp_path / "run"), "--no-plots"])
    assert res.exit_code == 0, res.output
    out = res.output
    start = out.index("set-up and steady flow through the open breach (before cycle 1): started")
    done = out.index("set-up and steady flow through the open breach (before cycle 1): done")
    assert start < done < out.index("cycle   1")
    assert "before cycle 1): started" in (tmp_path / "run" / "run.log").read_text()


def test_piped_ensemble_progress_reports_members():
    from breachflow.ensemble.execute import _progress

    con, buf = _piped()
    with _progress(con, 3, True) as advance:
        advance(True)
        advance(False)
        advance(True)
    lines = buf.getvalue().splitlines()
    assert lines[0] == "members: started"
    assert lines[-1].startswith("members: done 3/3 members 2 ok, 1 failed")
    con, buf = _piped()
    with _progress(con, 1, False) as advance:  # --no-progress
        advance(True)
    assert buf.getvalue() == ""
