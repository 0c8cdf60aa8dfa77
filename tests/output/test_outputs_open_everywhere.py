"""Every NetCDF file breachflow writes opens with the tools users reach for (issue 15):
``ds.pint.quantify()`` in either import order of breachflow and pint_xarray, and
``xr.open_mfdataset("RUN/cycle_*.nc")`` typed as is.

The quantify check runs in fresh interpreters (the import order is what is tested) over a closure run's
cycle and trajectory files and archive, ingested ADH and HEC-RAS snapshots, a solver snapshot with its
derived fields (Manning's n), a closure-window Dataset and an ensemble result.
"""
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.field.derived import add_derived
from breachflow.io import open_snapshot
from breachflow.field.snapshot import write_snapshot
from breachflow.io import RunDirectory
from breachflow.scenario import closure_window
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.io import write_netcdf

from ._scenes import tiny_closure

DATA = Path(__file__).resolve().parents[1] / "hydro_io" / "data"

SCENARIO = tiny_closure("open everywhere", max_cycles=3)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("open_everywhere") / "run"
    ClosureRun(closure_setup(parse_scenario(SCENARIO)), out, SCENARIO).run()
    return RunDirectory(out)


@pytest.fixture(scope="module")
def every_output(run_dir, tmp_path_factory):
    d = tmp_path_factory.mktemp("outputs")
    files = {}
    for g in run_dir.completed_cycles():
        files[f"cycle {g}"] = run_dir.cycle_path(g)
        files[f"trajectories {g}"] = run_dir.trajectories_path(g)
    files["archive"] = run_dir.combine(d / "archive.nc")
    adh = open_snapshot([DATA / n for n in ("adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc")])
    files["adh snapshot"] = write_snapshot(adh, d / "adh.nc")
    files["hec-ras snapshot"] = write_snapshot(open_snapshot([DATA / "RASExport.sdf"]), d / "sdf.nc")
    grid = run_dir.open_cycle(1)
    keep = [v for v in ("bed_elevation", "depth", "water_surface", "u", "v", "wet", "obstacle") if v in grid]
    solved = add_derived(grid[keep], 0.025)
    files["solver snapshot + derived"] = write_snapshot(solved, d / "solved.nc")
    files["closure window"] = write_netcdf(closure_window(
        surge_height="2.8 m", fall_rate="40 cm/hr", polder_area=["400 ha", "800 ha"], inundation_depth="90 cm",
        breach_discharge="200 m^3/s"), d / "window.nc")
    files["ensemble result"] = _ensemble(d)
    return files


def _ensemble(d):
    import distributed

    from breachflow.ensemble import parse_spec, run

    spec = parse_spec("""
[ensemble]
runner = "closure_window"
[ensemble.vary]
"breach.length" = ["20 m", "40 m"]
[flood]
surge_height = "2.8 m"
fall_rate = "40 cm/hr"
[polder]
area = "800 ha"
inundation_depth = "90 cm"
[breach]
mean_velocity = "3 m/s"
""")
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        run(spec, out=d / "ens", client=client, progress=False)
    return d / "ens" / "ensemble.nc"


QUANTIFY = r"""
import json, sys
first = sys.argv[1]
if first == "pint_xarray":
    import pint_xarray, xarray as xr
    import breachflow
else:
    import breachflow, pint_xarray, xarray as xr
out = {}
for label, path in json.loads(sys.argv[2]).items():
    with xr.open_dataset(path) as ds:
        try:
            q = ds.pint.quantify()
        except Exception as exc:
            out[label] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        have = {k: str(q[k].pint.units) for k in q.variables if q[k].pint.units is not None}
        want = sorted(k for k, v in ds.variables.items() if "units" in v.attrs)
        speed = None
        if "u" in q:
            speed = float(abs(q.u).max().pint.to("km/hr").pint.magnitude)
        out[label] = {"quantified": sorted(have), "with_units": want, "u_kmh": speed,
                      "u_ms": float(abs(ds.u).max()) if "u" in ds else None}
print(json.dumps(out))
"""


@pytest.mark.parametrize("first", ["breachflow", "pint_xarray"])
def test_pint_quantify_works_on_every_output_in_either_import_order(every_output, first):
    res = subprocess.run([sys.executable, "-c", QUANTIFY, first, json.dumps({k: str(v) for k, v in every_output.items()})],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout.strip().splitlines()[-1])
    assert set(report) == set(every_output)
    for label, r in report.items():
        assert "error" not in r, f"{label}: {r['error']}"
        # every variable with a units attribute is a quantity now (time decoded by xarray carries none)
        assert r["quantified"] == r["with_units"], label
        assert r["quantified"], label
        if r["u_ms"] is not None:  # a real conversion: m s-1 read as metres per second
            assert r["u_kmh"] == pytest.approx(3.6 * r["u_ms"], rel=1e-12), label


def test_manning_n_units_are_read_alike_by_pint_and_udunits(every_output):
    """Manning's n carries a unit string both pint and UDUNITS read as the same thing ("1", the SI
    convention, said in the comment); "s m-1/3" — what it was — UDUNITS reads as (1/3) s m-1."""
    with xr.open_dataset(every_output["solver snapshot + derived"]) as ds:
        attrs = ds.manning_n.attrs
    assert attrs["units"] == "1" and "s m^(-1/3)" in attrs["comment"]


def test_open_mfdataset_of_the_cycle_files_as_typed(run_dir):
    cycles = run_dir.completed_cycles()
    assert len(cycles) == 3
    pattern = str(run_dir.path / "cycle_*.nc")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # xarray's notice about its future defaults
        with xr.open_mfdataset(pattern) as ds:
            ds = ds.load()
    assert ds.cycle.values.tolist() == cycles
    assert ds.depth.dims == ("cycle", "y", "x")
    assert ds.particle_x.dims == ("cycle", "particle")
    for g in cycles:
        one = run_dir.open_cycle(g)
        np.testing.assert_array_equal(ds.depth.sel(cycle=g).values, one.depth.values)
        np.testing.assert_array_equal(ds.particle_x.sel(cycle=g).values, one.particle_x.values)
        # cycle g has placed 2 g masses (batch 2); the rest of the run's capacity is not placed yet
        placed = ds.particle_placed_cycle.sel(cycle=g).values
        assert int((placed > 0).sum()) == 2 * g and set(placed[placed > 0]) == set(range(1, g + 1))
    # the trajectory files are not caught by the glob
    assert not any("traj" in p.name for p in run_dir.path.glob("cycle_*.nc"))
    assert sorted(p.name for p in run_dir.path.glob("trajectories_*.nc")) == \
        [run_dir.trajectories_path(g).name for g in cycles]
    # xarray's announced defaults (join="exact") with the README's join="outer" give the same stack
    with xr.set_options(use_new_combine_kwarg_defaults=True):
        with xr.open_mfdataset(pattern, join="outer") as new:
            np.testing.assert_array_equal(new.depth.values, ds.depth.values)
    # the steady-state history of each cycle's solve (lengths differ) is in its own group
    with xr.open_dataset(run_dir.cycle_path(1), group="convergence_history") as h:
        assert h.convergence_time.dims == ("cycle", "convergence_check")


def test_trajectory_time_is_seconds_since_the_cycle_start(run_dir):
    with xr.open_dataset(run_dir.trajectories_path(2)) as tr:
        t = tr.time
        # a plain number of seconds, not a date (xarray leaves it undecoded; no placeholder epoch)
        assert t.dtype.kind == "f" and t.attrs["units"] == "s" and "since" not in t.attrs["units"]
        assert float(t.min()) == 0.0
        assert float(t.max()) <= 1.5 + 0.25 + 1e-9  # the cycle's DEM time limit plus one record interval
        summary = run_dir.manifest()["cycles"][1]["summary"]
        assert tr.attrs["cycle_start_time"] == pytest.approx(summary["operation_time"])


def test_format_1_run_directory_still_combines_and_resumes(run_dir, tmp_path):
    """A run directory of the old layout (cycle_NNNN_trajectories.nc, no cycle dimension) keeps working:
    it resumes (bit-identical to the uninterrupted run), combine finds its files through the manifest,
    open_cycle reads its 2-D grids."""
    import shutil

    old = tmp_path / "old"
    shutil.copytree(run_dir.path, old)
    man = json.loads((old / "manifest.json").read_text())
    for c in man["cycles"]:
        g = c["cycle"]
        new_name = f"cycle_{g:04d}_trajectories.nc"
        (old / c["files"]["trajectories"]).rename(old / new_name)
        c["files"]["trajectories"] = new_name
        # format 1: 2-D grids, the steady-state history in the root group
        run_dir.open_cycle(g).to_netcdf(old / c["files"]["field"])
    # the last cycle not yet done: the old directory resumes, writing cycle 3 in the current layout
    last = man["cycles"].pop()
    for name in last["files"].values():
        (old / name).unlink()
    man.update(format_version=1, finished=False)
    man.pop("final", None)
    (old / "manifest.json").write_text(json.dumps(man))
    rd = RunDirectory(old)
    assert rd.open_cycle(2).depth.dims == ("y", "x")
    ClosureRun(closure_setup(parse_scenario(SCENARIO)), old, SCENARIO, resume=True).run()
    assert rd.completed_cycles() == [1, 2, 3] and rd.trajectories_path(3).exists()
    np.testing.assert_array_equal(rd.open_cycle(3).depth.values, run_dir.open_cycle(3).depth.values)
    np.testing.assert_array_equal(rd.open_cycle(3).particle_x.values, run_dir.open_cycle(3).particle_x.values)
    arch = rd.combine(tmp_path / "a.nc")
    with xr.open_dataset(arch) as a, xr.open_dataset(arch, group="trajectories", decode_times=False) as t:
        assert a.sizes["cycle"] == 3
        assert sorted(set(t.trajectory_cycle.values.tolist())) == [1, 2, 3]


def test_tutorial_recipe_plots_the_closure_window_in_hours(every_output):
    """The tutorial's notebook line (docs/tutorials.md) that plots the closure window, run as written on an
    ensemble result:
    the y axis says hours and the values are hours (dividing by 3600 kept the label "[s]")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pint_xarray  # noqa: F401

    readme = (Path(__file__).resolve().parents[2] / "docs" / "tutorials.md").read_text()
    line = next(ln for ln in readme.splitlines() if ln.startswith("ds.closure_window") and ".plot(" in ln)
    with xr.open_dataset(every_output["ensemble result"]) as ds:
        ds = ds.load()
    plt.figure()
    eval(line.split("  #")[0], {"ds": ds})
    ax = plt.gca()
    assert ax.get_ylabel().endswith("[hour]"), ax.get_ylabel()
    np.testing.assert_allclose(ax.lines[0].get_ydata(), ds.closure_window.values / 3600.0, rtol=1e-12)
    plt.close("all")
