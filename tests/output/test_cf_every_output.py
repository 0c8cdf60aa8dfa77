"""Every kind of NetCDF file breachflow writes passes the CF checker with 0 errors / 0 warnings and opens in
GDAL without a warning: cycle file, trajectories, ``combine`` archive, ``model-problem`` output, ``settle``
output and the ensemble's ``ensemble.nc`` (the ingested snapshots: tests/output/test_cf_gis_check.py).

The tools come from the project's set-up as in test_cf_gis_check.py (skipped, naming them, where absent
outside CI).
"""
import ctypes.util
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.scenario.config import parse_scenario

from ._scenes import tiny_closure

ROOT = Path(__file__).resolve().parents[2]

SCENARIO = tiny_closure("cf every output", max_cycles=2, crs="EPSG:32615")


@pytest.fixture(scope="module")
def checker():
    spec = importlib.util.spec_from_file_location("breachflow_tools_cf_check_all", ROOT / "tools" / "cf_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    table = mod.ensure_env(install=False)
    missing = [what for what, ok in (("the cfchecker environment (python3 tools/cf_check.py --setup)", table is not None),
                                     ("UDUNITS-2 (Debian libudunits2-0)", ctypes.util.find_library("udunits2")),
                                     ("gdalinfo (Debian gdal-bin)", shutil.which("gdalinfo"))) if not ok]
    if missing:
        msg = "CF/GDAL check needs " + ", ".join(missing) + "; `python3 tasks.py test` installs them as root with apt-get"
        if os.environ.get("CI", "").lower() in ("true", "1", "yes"):
            pytest.fail(msg)
        pytest.skip(msg)
    return mod, table


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One file of every kind the package writes (name -> path)."""
    tmp = tmp_path_factory.mktemp("cfall")
    out = {}
    run = ClosureRun(closure_setup(parse_scenario(SCENARIO)), tmp / "run", SCENARIO, start_states=tmp / "starts")
    run.run()
    rd = run.rundir
    out["cycle file"] = rd.cycle_path(2)
    (out["start state"],) = (tmp / "starts").glob("*.nc")  # breachflow.cycle.start_state
    out["trajectories"] = rd.trajectories_path(1)
    out["combine archive"] = rd.combine(tmp / "archive.nc")

    from breachflow.cli.run import run_model_problem

    run_model_problem(output=tmp / "model_problem.nc")
    out["model-problem output"] = tmp / "model_problem.nc"

    from breachflow.studies.validation import save_settling, settling_curves

    ds = settling_curves([0.01, 0.08], 7800.0, ("report", "clift_gauvin"), dt=1e-4, duration=0.05)
    out["settle output"] = save_settling(ds, tmp / "settling")["netcdf"]

    out["ensemble.nc"] = _ensemble_file(tmp)

    from typer.testing import CliRunner

    from breachflow.cli import app

    res = CliRunner().invoke(app, ["solve", "demo_breach", "--resolution", "4 m", "--t-max", "5 s", "--order", "1",
                                   "-o", str(tmp / "solve")])
    assert res.exit_code == 0, res.output
    out["solve output"] = tmp / "solve" / "snapshot.nc"
    res = CliRunner().invoke(app, ["window", "--surge-height", "2.8 m", "--fall-rate", "40 cm/hr", "--polder-area",
                                   "800 ha", "--inundation-depth", "90 cm", "--breach-length", "30 m",
                                   "--mean-velocity", "3 m/s", "-o", str(tmp / "window.nc")])
    assert res.exit_code == 0, res.output
    out["window output"] = tmp / "window.nc"
    out["check.nc"] = _check_file(tmp)
    out["atlas.nc"] = _atlas_file(tmp)
    return out


def _check_file(tmp: Path) -> Path:
    """check.nc of a verdict check (the run, a second seed, the finer grid with a failed closure), written by
    the check's own writer."""
    from breachflow.ensemble.check import CheckRun, judge, write_check

    runs = [CheckRun("4 m", 4.0, 2, True, tonnage=310.0, lost_tonnage=12.0, cycles=8, discharge=180.0,
                     gap_mean_speed=2.1, gap_max_speed=3.2, own=True),
            CheckRun("4 m", 4.0, 3, False, verdict="not closed: max_cycles", tonnage=400.0, cycles=12, discharge=181.0,
                     gap_mean_speed=2.1, gap_max_speed=3.3),
            CheckRun("2 m", 2.0, 2, None, discharge=176.0, gap_mean_speed=2.0, gap_max_speed=3.5),
            CheckRun("2 m", 2.0, 3, False, error="RuntimeError: crane broke")]
    return write_check(judge(runs, 0.05).dataset(), tmp / "check.nc")


def _atlas_file(tmp: Path) -> Path:
    """atlas.nc of the example district generator's 1.6 km levee screened at 3 locations, one of them failed,
    written by the atlas's own writer."""
    from breachflow.atlas.execute import plan, screen_location
    from breachflow.atlas.outputs import build_dataset, write_outputs

    spec = importlib.util.spec_from_file_location("make_district", ROOT / "examples" / "district" / "make_district.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["make_district"] = mod
    spec.loader.exec_module(mod)
    folder = tmp / "district"
    folder.mkdir()
    mod.write(folder, length=1600.0)
    (folder / "district.toml").write_text(mod.district_toml(folder / "terrain.tif", folder / "levee.geojson"))
    district, locations = plan(folder / "district.toml")
    records = [screen_location(district, loc, str(tmp / f"loc{loc.index}.json"), "k") for loc in locations]
    records[0] = {"result": {"status": "failed", "message": "RuntimeError: no terrain"}}
    write_outputs(build_dataset(district, locations, records), district, locations, tmp / "atlas")
    return tmp / "atlas" / "atlas.nc"


def _ensemble_file(tmp: Path) -> Path:
    """ensemble.nc of a closure-runner ensemble with 2 sizes x 3 replicates (one member failed), assembled and
    written by the ensemble's own code from member records as the closure runner returns them."""
    from breachflow.ensemble.dataset import build_dataset, write_result
    from breachflow.ensemble.runners import member_runners, normalise_results
    from breachflow.ensemble.spec import parse_spec

    spec = parse_spec("""
[ensemble]
name = "cf check"
runner = "closure"
replicates = 3
[ensemble.vary]
mass_size = { parameter = "placement.diameter", values = ["4 m", "5 m"], long_name = "diameter of the dropped masses" }
[placement]
batch = 10
""")
    runner = member_runners.get("closure")
    rng = np.random.default_rng(1)
    records = []
    for i in range(6):
        if i == 4:
            records.append({"status": "failed", "error_type": "RuntimeError", "error_message": "crane broke",
                            "seed": i, "elapsed": 1.0, "cpu_time": 1.0, "key": f"m{i}", "run_dir": str(tmp / f"m{i}")})
            continue
        raw = {"cycles": 3, "masses_placed": 30, "tonnage": (rng.uniform(1e5, 2e5), "kg"),
               "closure_duration": (rng.uniform(3e3, 9e3), "s"), "closure_achieved": bool(i % 2),
               "governing_criterion": "max_speed", "peak_velocity": (3.0, "m/s"),
               "initial_breach_discharge": (1800.0, "m^3/s"), "final_breach_discharge": (20.0, "m^3/s"),
               "final_seepage_discharge": (0.0, "m^3/s"), "feasible": bool(i % 2)}
        res = {k: v.to_json() for k, v in normalise_results(raw, runner.outputs).items()}
        records.append({"status": "ok", "results": res, "seed": i, "elapsed": 2.0, "cpu_time": 2.0, "key": f"m{i}",
                        "run_dir": str(tmp / f"m{i}")})
    # the closure members' runs: the 2-cycle run of this module as every ok member's closure run
    for i in range(6):
        (tmp / f"m{i}").mkdir(exist_ok=True)
        (tmp / f"m{i}" / "closure").symlink_to(tmp / "run", target_is_directory=True)
    from breachflow.ensemble.cycles import add_per_cycle

    ds = add_per_cycle(build_dataset(spec, records, runner, out_dir=tmp), records, runner)
    assert ds["cycle_breach_discharge"].dims == ("mass_size", "replicate", "cycle")
    return write_result(ds, tmp / "ensemble.nc")


KINDS = ["cycle file", "start state", "trajectories", "combine archive", "model-problem output", "settle output", "ensemble.nc",
         "solve output", "window output", "check.nc", "atlas.nc"]


@pytest.mark.parametrize("kind", KINDS)
def test_every_written_file_passes_the_cf_checker(checker, files, kind):
    mod, table = checker
    rep = mod.cf_check(files[kind], table)
    assert (rep.errors, rep.warnings) == (0, 0), f"{kind}:\n" + "\n".join(rep.messages or [rep.output])
    assert mod.crs_problems(files[kind]) == []


def _gdal_variables(path) -> list[str]:
    """The variables GDAL lists as subdatasets (or the file itself when it has one raster)."""
    res = subprocess.run(["gdalinfo", str(path)], capture_output=True, text=True)
    subs = [ln.split("=", 1)[1] for ln in res.stdout.splitlines() if "_NAME=" in ln and "SUBDATASET" in ln]
    return subs or [str(path)]


#: the files holding map grids (GDAL rasters); the others are tables (trajectories, ensemble, settling
#: curves, closure windows), which GDAL's raster driver would take for grids without map axes
GRIDS = ["cycle file", "combine archive", "solve output"]


@pytest.mark.parametrize("kind", GRIDS)
def test_every_written_grid_opens_in_gdal_without_a_warning(checker, files, kind):
    """gdalinfo on the file and on each of its raster variables: exit 0, the CRS read, and no "Warning"
    line (before: "dimension #0 (cycle) is not a Time or Vertical dimension")."""
    import xarray as xr

    with xr.open_dataset(files[kind]) as ds:  # the map grids: variables on (y, x)
        grids = {v for v in ds.data_vars if ds[v].dims[-2:] == ("y", "x")}
    names = [str(files[kind]), *(n for n in _gdal_variables(files[kind]) if n.rsplit(":", 1)[-1] in grids)]
    assert any(n.endswith(":depth") for n in names), names
    for name in names:
        res = subprocess.run(["gdalinfo", name], capture_output=True, text=True)
        text = res.stdout + res.stderr
        assert res.returncode == 0, text
        warn = [ln for ln in text.splitlines() if "warning" in ln.lower()]
        assert not warn, f"{kind}: gdalinfo {name}:\n" + "\n".join(warn)
        if name.endswith((":depth", ":u", ":bed_elevation")):  # the run's CRS; solve: the local one
            assert ("UTM zone 15N" if kind != "solve output" else "breachflow local transverse Mercator") in text, text


def _gdal(*cmd) -> tuple[int, list[str], str]:
    """Exit code, the "Warning" lines and the whole text of a GDAL command."""
    res = subprocess.run(list(cmd), capture_output=True, text=True)
    text = res.stdout + res.stderr
    return res.returncode, [ln for ln in text.splitlines() if "warning" in ln.lower()], text


#: the files whose records have map positions: GDAL reads them as a vector layer (name, geometry, count)
POINT_LAYERS = {"atlas.nc": ("breach_atlas", "Point", 3)}


@pytest.mark.parametrize("kind", KINDS)
def test_every_written_file_opens_in_gdal_without_a_warning(checker, files, kind):
    """``gdalinfo`` on every written file prints no "Warning" line (before: the trajectories, "dimension #1
    (obs) is not a Longitude/X dimension"); a map file opens as a raster, a table of map positions (the atlas)
    opens in ``ogrinfo`` as a point layer with its CRS and every record, without a warning or an error (before:
    "Unable to open datasource"). Tables without positions are no GIS data: GDAL's raster side does not open
    them or lists their arrays as subdatasets (docs/outputs.md)."""
    path = str(files[kind])
    rc, warn, text = _gdal("gdalinfo", path)
    assert not warn, f"{kind}: gdalinfo {path}:\n" + "\n".join(warn)
    if kind in GRIDS:
        assert rc == 0, text
    if kind in POINT_LAYERS:
        name, geometry, count = POINT_LAYERS[kind]
        rc, warn, text = _gdal("ogrinfo", "-ro", "-so", "-al", path)
        assert rc == 0 and not warn and "ERROR" not in text, f"{kind}: ogrinfo {path}:\n{text[-2000:]}"
        assert f"Layer name: {name}" in text and f"Geometry: {geometry}" in text, text[-2000:]
        assert f"Feature Count: {count}" in text, text[-2000:]
        assert 'ID["EPSG",26915]' in text, "the layer's CRS is the district terrain's (EPSG:26915)"
