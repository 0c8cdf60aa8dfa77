"""A real closure-cycle file (grid + trajectories) through the CF checker and GDAL (issue 7).

The tools come from the project's set-up (``python3 tasks.py test``: Debian ``gdal-bin`` and
``libudunits2-0`` when root with apt-get, and the cfchecker environment of ``tools/cf_check.py``). In CI
(``CI=true``) a missing tool fails the test; on a developer machine without them it is skipped, naming them.
"""
import ctypes.util
import importlib.util
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from pyproj import CRS

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.scenario.config import parse_scenario

from ._scenes import tiny_closure

ROOT = Path(__file__).resolve().parents[2]
EPSG = "EPSG:32615"  # WGS 84 / UTM zone 15N (the report's Louisiana sites)

SCENARIO = tiny_closure("cf check", max_cycles=1, crs=EPSG)


def _cf_check_module():
    spec = importlib.util.spec_from_file_location("breachflow_tools_cf_check", ROOT / "tools" / "cf_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def checker():
    mod = _cf_check_module()
    table = mod.ensure_env(install=False)
    missing = []
    if table is None:
        missing.append("the cfchecker environment (python3 tools/cf_check.py --setup)")
    if not ctypes.util.find_library("udunits2"):
        missing.append("UDUNITS-2 (Debian libudunits2-0)")
    if not shutil.which("gdalinfo"):
        missing.append("gdalinfo (Debian gdal-bin)")
    if missing:
        msg = "CF/GDAL check needs " + ", ".join(missing) + "; `python3 tasks.py test` installs them as root with apt-get"
        if os.environ.get("CI", "").lower() in ("true", "1", "yes"):
            pytest.fail(msg)
        pytest.skip(msg)
    return mod, table


@pytest.fixture(scope="module")
def cycle_files(tmp_path_factory):
    out = tmp_path_factory.mktemp("cfrun")
    run = ClosureRun(closure_setup(parse_scenario(SCENARIO)), out, SCENARIO)
    run.run()
    rd = run.rundir
    assert rd.completed_cycles() == [1] and rd.trajectories_path(1).exists()
    return rd.cycle_path(1), rd.trajectories_path(1)


def test_cycle_grid_and_trajectories_pass_the_cf_checker(checker, cycle_files):
    mod, table = checker
    for path in cycle_files:
        rep = mod.cf_check(path, table)
        assert (rep.errors, rep.warnings) == (0, 0), f"{path.name}:\n" + "\n".join(rep.messages or [rep.output])


def test_gdal_reads_the_crs_and_geotransform_of_the_cycle_grid(checker, cycle_files):
    mod, _ = checker
    grid = cycle_files[0]
    info = mod.gdal_info(grid, "depth")
    assert info["returncode"] == 0, info["output"]
    assert info["crs"] == CRS.from_user_input(EPSG).name, info["output"]
    with xr.open_dataset(grid) as ds:
        x, y = ds.x.values, ds.y.values
    dx, dy = x[1] - x[0], y[1] - y[0]
    # GDAL's geotransform: the outer corner of the north-west cell, pixel size (dx, -dy)
    assert info["size"] == (x.size, y.size)
    np.testing.assert_allclose(info["origin"], (x[0] - dx / 2, y[-1] + dy / 2), atol=1e-6)
    np.testing.assert_allclose(info["pixel_size"], (dx, -dy), atol=1e-9)


def test_default_crs_cycle_grid_lands_at_the_documented_local_crs(checker, tmp_path):
    """No [site] crs: the grid still has a definite CRS (the documented local transverse Mercator),
    GDAL reads it, and the cycle file passes the checker's CRS test."""
    from breachflow.field.crs import LOCAL_CRS_NAME

    mod, table = checker
    text = SCENARIO.replace(f'crs = "{EPSG}"\n', "")
    assert "crs" not in text
    run = ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "run", text)
    run.run()
    grid = run.rundir.cycle_path(1)
    info = mod.gdal_info(grid, "depth")
    assert info["returncode"] == 0 and info["crs"] == LOCAL_CRS_NAME, info["output"]
    assert mod.crs_problems(grid) == []
    rep = mod.cf_check(grid, table)
    assert (rep.errors, rep.warnings) == (0, 0), "\n".join(rep.messages or [rep.output])


DATA = ROOT / "tests" / "hydro_io" / "data"
INGESTS = {
    "hecras_sdf": [DATA / "RASExport.sdf"],
    "adh_mesh": [DATA / "adh_demo.3dm", DATA / "adh_demo_dep.dat", DATA / "adh_demo_vel.dat", DATA / "adh_demo.bc"],
    "hecras_hdf_muncie": [DATA / "hecras" / "Muncie2DOnly_SI.p01.steps_0_25_48.hdf"],  # real HEC-RAS 6 results
}


@pytest.mark.parametrize("name", sorted(INGESTS))
def test_ingested_mesh_snapshots_pass_the_cf_checker(checker, tmp_path, name):
    """UGRID mesh snapshots as `breachflow ingest` writes them: no vlen strings (HEC-RAS profile names are
    CF char arrays), and the UGRID variables pass the UGRID-1.0 rules that replace cfchecker's CF-§9.5-only
    cf_role check."""
    from breachflow.io import open_snapshot
    from breachflow.field.snapshot import read_snapshot, write_snapshot

    if name.startswith("hecras_hdf"):
        pytest.importorskip("rashdf")
    mod, table = checker
    path = write_snapshot(open_snapshot(INGESTS[name]), tmp_path / f"{name}.nc")
    rep = mod.cf_check(path, table)
    assert (rep.errors, rep.warnings) == (0, 0), rep.messages
    roles, problems = mod.ugrid_problems(path)
    assert roles == {"mesh2d": "mesh_topology", "mesh2d_face_nodes": "face_node_connectivity"} and problems == []
    back = read_snapshot(path)
    if "profile_name" in back:
        assert [str(p) for p in back["profile_name"].values] == ["PF 1", "PF 2"]


def test_the_ugrid_check_catches_broken_meshes(checker, tmp_path):
    """The replacement check is not a blanket pass: bad connectivity and missing attributes are errors."""
    import netCDF4

    from breachflow.io import open_snapshot
    from breachflow.field.snapshot import write_snapshot

    mod, table = checker
    good = write_snapshot(open_snapshot(INGESTS["adh_mesh"]), tmp_path / "good.nc")
    cases = {
        "index": lambda d: d["mesh2d_face_nodes"].__setitem__((0, 0), 10**6),
        "coords": lambda d: d["mesh2d"].delncattr("node_coordinates"),
        "faces": lambda d: d["mesh2d"].setncattr("face_node_connectivity", "no_such_variable"),
    }
    for what, edit in cases.items():
        bad = tmp_path / f"bad_{what}.nc"
        bad.write_bytes(good.read_bytes())
        with netCDF4.Dataset(bad, "a") as d:
            edit(d)
        rep = mod.cf_check(bad, table)
        assert rep.errors >= 1 and any("UGRID-1.0" in m for m in rep.messages), (what, rep.messages)
