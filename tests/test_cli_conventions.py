"""One convention for every subcommand (docs/cli.md): help shows no value type for a flag and names arguments
in capitals; `--resume` is an explicit flag, off by default, in `run` and `ensemble` alike, and an output
directory holding results is continued or replaced only when asked; `solve` writes no PNG unasked and its
snapshot carries the CRS a closure run writes."""
import re
from pathlib import Path

import pytest
import typer.main
import xarray as xr
from pyproj import CRS
from typer.testing import CliRunner

from breachflow.cli import app

runner = CliRunner()
COMMANDS = sorted(typer.main.get_command(app).commands)


@pytest.mark.parametrize("command", COMMANDS)
def test_help_shows_no_bool_type_and_capital_arguments(command):
    res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "<bool>" not in res.output
    usage = next(ln for ln in res.output.splitlines() if "Usage:" in ln)
    assert "{" not in usage and "}" not in usage, usage
    for arg in re.findall(r"\[?([A-Za-z_]+)\]?(?:\.\.\.)?", usage.split("[OPTIONS]", 1)[-1]):
        assert arg == arg.upper(), usage


@pytest.mark.parametrize("command", ["run", "ensemble"])
def test_resume_is_the_same_flag_everywhere(command):
    cmd = typer.main.get_command(app).commands[command]
    (p,) = [p for p in cmd.params if "--resume" in p.opts]
    assert p.is_flag and p.default is False and not p.secondary_opts
    assert any("--overwrite" in q.opts for q in cmd.params)


SPEC = """
[ensemble]
name = "conventions"
runner = "closure_window"
[ensemble.vary]
"breach.length" = ["20 m"]
[flood]
surge_height = "2.8 m"
fall_rate = "40 cm/hr"
[polder]
area = "800 ha"
inundation_depth = "90 cm"
[breach]
mean_velocity = "3 m/s"
"""


def test_ensemble_output_holding_results_is_refused_without_resume(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    out = tmp_path / "out"
    (out / "members" / "m0").mkdir(parents=True)
    (out / "members" / "m0" / "result.json").write_text("{}")
    res = runner.invoke(app, ["ensemble", str(spec), "-o", str(out), "--no-progress"])
    assert res.exit_code != 0
    msg = str(res.output) + str(res.exception)
    assert "holds an ensemble" in msg and "--resume" in msg and "--overwrite" in msg
    res = runner.invoke(app, ["ensemble", str(spec), "-o", str(tmp_path / "empty"), "--resume"])
    assert res.exit_code != 0 and "nothing to resume" in str(res.output) + str(res.exception)
    res = runner.invoke(app, ["ensemble", str(spec), "-o", str(out), "--resume", "--overwrite"])
    assert res.exit_code != 0


SOLVE = ["solve", "demo_breach", "--resolution", "4 m", "--t-max", "5 s", "--order", "1"]


def test_solve_writes_no_png_unasked_and_its_snapshot_has_the_run_crs(tmp_path, monkeypatch):
    from breachflow.field.crs import LOCAL_CRS_NAME

    monkeypatch.chdir(tmp_path)
    res = runner.invoke(app, [*SOLVE, "-o", "snap"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["snap"]
    assert sorted(p.name for p in (tmp_path / "snap").iterdir()) == ["snapshot.nc"]
    with xr.open_dataset(tmp_path / "snap" / "snapshot.nc") as ds:
        gm = ds["depth"].attrs.get("grid_mapping") or ds["depth"].encoding.get("grid_mapping")
        assert CRS.from_wkt(ds[gm].attrs["crs_wkt"]).name == LOCAL_CRS_NAME
    res = runner.invoke(app, [*SOLVE, "-o", "snap2", "--crs", "EPSG:32615"])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "snap2" / "snapshot.nc") as ds:
        gm = ds["depth"].attrs.get("grid_mapping") or ds["depth"].encoding.get("grid_mapping")
        assert CRS.from_wkt(ds[gm].attrs["crs_wkt"]).to_epsg() == 32615


def test_solve_out_is_a_directory_replaced_only_with_overwrite(tmp_path, monkeypatch):
    """`solve -o DIR` as `run`, `ensemble` and `atlas`: a directory holding a snapshot is refused (naming
    --overwrite) before anything is written, replaced with --overwrite; with no --out it is runs/solve."""
    monkeypatch.chdir(tmp_path)
    res = runner.invoke(app, SOLVE)
    assert res.exit_code == 0, res.output
    snap = tmp_path / "runs" / "solve" / "snapshot.nc"
    first = snap.stat().st_mtime_ns
    res = runner.invoke(app, SOLVE)
    assert res.exit_code != 0
    msg = str(res.output) + str(res.exception)
    assert "holds a solve" in msg and "--overwrite" in msg
    assert snap.stat().st_mtime_ns == first
    res = runner.invoke(app, [*SOLVE, "--overwrite"])
    assert res.exit_code == 0, res.output
    assert snap.stat().st_mtime_ns != first
    (tmp_path / "afile").write_text("x")
    res = runner.invoke(app, [*SOLVE, "-o", "afile"])
    assert res.exit_code != 0 and "not a directory" in str(res.output) + str(res.exception)


def test_solve_out_ending_in_nc_still_writes_that_file_and_warns(tmp_path, monkeypatch):
    """The usage before the output directory: `-o FILE.nc` writes FILE.nc (replacing it, as before) with a
    DeprecationWarning that names the directory form."""
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        res = runner.invoke(app, [*SOLVE, "-o", "old.nc"])
        assert res.exit_code == 0, res.output
        assert "deprecated" in res.output and "--out old writes old/snapshot.nc" in res.output, res.output
    from breachflow.cli.solve import solve_target

    with pytest.warns(DeprecationWarning, match=r"--out old writes old/snapshot\.nc"):
        assert solve_target(Path("old.nc"), False) == Path("old.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.nc"]
    with xr.open_dataset(tmp_path / "old.nc") as ds:
        assert "depth" in ds
