"""Issue 27: an ensemble whose spec names an unknown parameter fails before it starts; one whose members all
fail exits non-zero; partial failures are reported with their counts."""
import pytest
from typer.testing import CliRunner

from breachflow.cli import app

pytest.importorskip("distributed")
runner = CliRunner()

BASE = """
[flood]
surge_height = "2.8 m"
fall_rate = "40 cm/hr"
[polder]
area = "800 ha"
inundation_depth = "90 cm"
[breach]
length = "30 m"
mean_velocity = "3 m/s"
"""


def _spec(tmp_path, vary):
    path = tmp_path / "spec.toml"
    path.write_text(f'[ensemble]\nname = "test"\nrunner = "closure_window"\n\n[ensemble.vary]\n{vary}\n{BASE}')
    return path


def test_a_misspelt_parameter_fails_before_anything_runs(tmp_path):
    spec = _spec(tmp_path, '"breach.lenght" = ["50 m", "100 m", "150 m"]')
    out = tmp_path / "out"
    res = runner.invoke(app, ["ensemble", str(spec), "--out", str(out), "--workers", "1", "--no-progress"])
    assert res.exit_code != 0
    msg = str(res.exception)
    assert "[ensemble.vary] 'breach.lenght': the scenario has no such parameter" in msg
    assert "did you mean 'length'?" in msg and "nothing was run" in msg
    assert not out.exists()  # was: 9 of 9 members failed, exit 0


def test_every_member_failing_is_a_failure_and_a_partial_failure_is_counted(tmp_path):
    spec = _spec(tmp_path, 'polder.area = ["-5 ha", "-6 ha"]')
    res = runner.invoke(app, ["ensemble", str(spec), "--out", str(tmp_path / "all"), "--workers", "1", "--no-progress"])
    assert res.exit_code != 0
    assert "every member of the ensemble failed (2 of 2); the first error:" in str(res.exception)
    spec = _spec(tmp_path, 'polder.area = ["-5 ha", "800 ha"]')
    res = runner.invoke(app, ["ensemble", str(spec), "--out", str(tmp_path / "some"), "--workers", "1", "--no-progress"],
                        env={"COLUMNS": "300"})
    assert res.exit_code == 0, res.output
    assert "1 of 2 members failed, 1 ran" in " ".join(res.output.split())
