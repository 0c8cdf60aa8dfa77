"""``solver = "nested"``: a local model inside an ingested field, re-solved with the pile (issue 13).

The ingested ADH-like model is the package's own steady state re-sampled onto a triangulated mesh that is
not aligned with our grid (rotated 17°, jittered nodes, the intact levee as a hole, as the report's ADH
mesh has it; :mod:`meshing`), written to UGRID NetCDF and read back."""
import json
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import demo_breach
from breachflow.cycle.main import run_closure
from breachflow.hydro.nested import NestedSolver, breach_window, consistency
from breachflow.hydro.snapshot import read_snapshot, write_snapshot
from breachflow.hydro.solvers import get_solver
from breachflow.hydro.terrain import breach_domain, breach_vicinity
from breachflow.scenario.geometry import typical_breach

from .meshing import unaligned_mesh


def _steady(scene, res):
    dom = breach_domain(scene, res)
    return get_solver("swe", tolerance=1e-4, t_max=900.0, region=breach_vicinity(dom, scene)).solve(dom)


@pytest.fixture(scope="module")
def typical_grid():
    """The typical breach (levee shortened to 250 m each side) at steady state on a 4 m grid."""
    scene = replace(typical_breach(), levee_length_each_side=250.0)
    grid = _steady(scene, 4.0)
    assert grid.attrs["steady_state"] == 1
    return scene, grid


@pytest.mark.parametrize("angle,seed", [(17.0, 1), (-31.0, 2), (45.0, 3)])
def test_nested_reproduces_the_ingested_field_near_the_breach(typical_grid, tmp_path, angle, seed):
    """No masses: the local re-solve keeps the ingested field within 2 B of the breach (mean |Δ speed| and
    |Δ depth| within 5 % of the mean speed and depth there), for meshes at several angles to our grid."""
    scene, grid = typical_grid
    path = tmp_path / "typical_mesh.nc"
    write_snapshot(unaligned_mesh(grid, 4.0, angle_deg=angle, seed=seed), path)
    mesh = read_snapshot(path)
    B = scene.breach.length
    window, dx = breach_window(0.0, 0.0, B, 4.0)
    ns = NestedSolver([mesh], window, dx, manning=scene.manning_n, tolerance=1e-4, t_max_initial=900.0)
    X, Y = np.meshgrid(ns.domain.x, ns.domain.y)
    ns.region = np.hypot(X, Y) <= 2 * B
    local = ns.solve()
    c = consistency(local, mesh, (0.0, 0.0), 2 * B)
    print("consistency", angle, seed, json.dumps({k: round(v, 4) for k, v in c.items()}),
          "steady", local.attrs["steady_state"], local.attrs["simulated_time_s"])
    assert local.attrs["hydro_mode"] == "nested" and local.attrs["flow_responds_to_pile"] == 1
    assert c["cells"] > 500
    assert c["mean_speed_diff"] <= 0.05 * c["regional_mean_speed"]
    assert c["mean_depth_diff"] <= 0.05 * c["regional_mean_depth"]


NESTED_SCENARIO = """
[scenario]
name = "nested demo"
[site]
preset = "demo_breach"
levee_length_each_side = "24 m"
flood_side_extent = "30 m"
protected_side_extent = "24 m"
[hydro]
solver = "nested"
snapshots = ["{mesh}"]
resolution = "1 m"
tolerance = "2e-3 1/s"
t_max_initial = "300 s"
t_max = "60 s"
monitor_radius = "20 m"
[dem]
max_time = "10 s"
[placement]
diameter = ["1.8 m", "2.2 m"]
batch = 5
positions = "line"
release_height = "1 m"
rate = "30 1/hr"
[criteria]
mode = "any"
max_cycles = 24
max_speed = "0.5 m/s"
breach_discharge = "0.5 m^3/s"
[closure]
remap = "raised_bed"
seed = 1
"""


def test_nested_in_an_ingested_adh_mesh_closes_the_breach(tmp_path):
    """The scaled breach's steady state as an ADH-like mesh file; ``solver = "nested"`` re-solves a local
    model around the breach with the pile each cycle: the breach discharge falls to nothing and it closes."""
    scene = replace(demo_breach(), levee_length_each_side=24.0, flood_side_extent=30.0, protected_side_extent=24.0)
    grid = _steady(scene, 1.0)
    path = tmp_path / "regional_mesh.nc"
    write_snapshot(unaligned_mesh(grid, 1.0, angle_deg=23.0, seed=4), path)
    scen = tmp_path / "nested.toml"
    scen.write_text(NESTED_SCENARIO.format(mesh=path))
    res = run_closure(scen, tmp_path / "run", plots=False)
    assert res.closed, [(r.cycle, r.breach_discharge, r.max_speed) for r in res.reports]
    q = [r.breach_discharge for r in res.reports]
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    q0 = man["metadata"]["initial"]["breach_discharge"]
    assert q0 > 20.0 and abs(q[-1]) < 0.05 * q0   # the pile changed the flow: the breach is shut
    assert all(r.hydro.startswith(("solved", "skipped")) for r in res.reports)
    assert man["metadata"]["hydro_mode"] == "nested"
    with xr.open_dataset(tmp_path / "run" / f"cycle_{res.cycles:04d}.nc") as ds:
        assert ds.attrs["hydro_mode"] == "nested" and ds.attrs["flow_responds_to_pile"] == 1
