"""``solver = "snapshot_frozen"`` with the levee in any direction (issue 16): the ingested field (a raster
on the CRS axes) is served on the site's breach-aligned grid. The scene is the scaled breach's steady state
turned in UTM 15N by angles that are not multiples of 90° (plain cos/sin and scipy interpolation here,
independent of the package's frame and samplers); the reference is the same scene at 0°, where the
field is served as ingested on the CRS axes."""
import json
import math
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr
from scipy.interpolate import RegularGridInterpolator

from breachflow.cycle.config import closure_setup, demo_breach
from breachflow.cycle.main import run_closure
from breachflow.field.snapshot import grid_snapshot
from breachflow.scenario.config import load_scenario

from .test_nested import _steady
from .test_nested_rotated import ORIGIN, WKT, turn, turn_vector, write_dem

B = 12.0
SCENARIO = """
[scenario]
name = "frozen turned"
[site]
terrain = "{dem}"
levee_coords = [[{ax:.6f}, {ay:.6f}], [{bx:.6f}, {by:.6f}]]
breach_at = "42 m"
breach_length = "12 m"
breach_bottom = "{bottom} m"
breach_wall_slope = {wall}
flood_level = "{level} m"
flood_side = "right"
manning_n = {n}
extent_along = "30 m"
extent_flood = "30 m"
extent_protected = "30 m"
[hydro]
solver = "snapshot_frozen"
resolution = "1 m"
snapshots = ["{snap}"]
[dem]
max_time = "2 s"
[placement]
diameter = ["1.8 m", "2.2 m"]
batch = 3
positions = "line"
release_height = "1 m"
[criteria]
max_cycles = 1
max_speed = "0.01 m/s"
[closure]
remap = "raised_bed"
seed = 1
"""


@pytest.fixture(scope="module")
def scene_grid():
    scene = replace(demo_breach(), levee_length_each_side=36.0, flood_side_extent=36.0, protected_side_extent=36.0)
    return scene, _steady(scene, 1.0)


def _interp(grid, name, method="linear"):
    return RegularGridInterpolator((grid.y.values, grid.x.values), np.asarray(grid[name].values, float),
                                   method=method, bounds_error=False, fill_value=np.nan)


def raster(grid, angle, x, y):
    """The steady state as a user's raster on the CRS axes (cell centres *x*, *y* relative to ``ORIGIN``)
    of the scene turned by *angle*: each cell centre turned back into the scene and the grid
    interpolated there (velocity turned into the map)."""
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    x, y = ORIGIN[0] + np.asarray(x, float), ORIGIN[1] + np.asarray(y, float)
    X, Y = np.meshgrid(x, y)
    dx, dy = X - ORIGIN[0], Y - ORIGIN[1]
    pts = np.c_[(-s * dx + c * dy).ravel(), (c * dx + s * dy).ravel()]  # (scene y, scene x)
    f = {k: _interp(grid, k)(pts).reshape(X.shape) for k in ("bed_elevation", "depth", "u", "v")}
    ob = _interp(grid, "obstacle", "nearest")(pts).reshape(X.shape)
    out = ~np.isfinite(f["depth"]) | (ob != 0)
    ue, vn = turn_vector(np.nan_to_num(f["u"]), np.nan_to_num(f["v"]), angle)
    return grid_snapshot(x, y, np.nan_to_num(f["bed_elevation"], nan=5.0), np.where(out, 0.0, f["depth"]),
                         np.where(out, 0.0, ue), np.where(out, 0.0, vn), obstacle=out, crs_wkt=WKT)


def _run(scene, grid, angle, folder):
    folder.mkdir(parents=True, exist_ok=True)
    dem = write_dem(scene, angle, folder / "dem.nc", half=70.0, spacing=0.5)
    half = scene.levee_length_each_side + 0.5 * scene.breach.length
    ax, ay = turn(-half, 0.0, angle)
    bx, by = turn(half, 0.0, angle)
    snap = folder / "frozen.nc"
    # at 0° the raster is the steady state on the site's own cells (a frozen field on the CRS axes is served
    # as ingested and must lie on them: x ± 36 m, y ± 30 m at 1 m); turned, a 0.5 m raster on the CRS axes
    if angle == 0.0:
        raster(grid, angle, np.arange(-35.5, 35.6), np.arange(-29.5, 29.6)).to_netcdf(snap)
    else:
        raster(grid, angle, np.arange(-60.0, 60.01, 0.5), np.arange(-60.0, 60.01, 0.5)).to_netcdf(snap)
    sc = folder / "frozen.toml"
    sc.write_text(SCENARIO.format(dem=dem.name, ax=ax, ay=ay, bx=bx, by=by, bottom=scene.ground_elevation,
                                  wall=scene.breach.wall_slope, level=scene.flood_water_elevation, n=scene.manning_n, snap=snap.name))
    return sc


@pytest.fixture(scope="module")
def reference(scene_grid, tmp_path_factory):
    scene, grid = scene_grid
    sc = _run(scene, grid, 0.0, tmp_path_factory.mktemp("ref"))
    setup = closure_setup(load_scenario(sc))
    served = setup.solver.solve()
    assert served.sizes["x"] == setup.domain.shape[1] and "map_x" not in served  # served as ingested
    run_closure(sc, sc.parent / "run", plots=False)
    q0 = json.loads((sc.parent / "run" / "manifest.json").read_text())["metadata"]["initial"]["breach_discharge"]
    # in scene coordinates
    served = served.assign_coords(x=served.x.values - ORIGIN[0], y=served.y.values - ORIGIN[1])
    return served, q0


@pytest.mark.parametrize("angle", [23.0, 137.0])
def test_frozen_snapshot_at_any_levee_direction(scene_grid, reference, tmp_path, angle):
    """The frozen field of the scene turned by *angle* (before: an InputError, the levee had to run within
    5° of east–west) is served on the breach-aligned grid: within 2 B of the breach it is the unturned one
    (depth and velocity vector, compared at the same scene points), its breach discharge within 2 % of the
    unturned run's, and ``breachflow run`` places masses and writes cycle files that land on the map."""
    scene, grid = scene_grid
    reference, q_ref = reference
    sc = _run(scene, grid, angle, tmp_path)
    setup = closure_setup(load_scenario(sc))
    served = setup.solver.solve()
    assert served.attrs["hydro_mode"] == "snapshot_frozen" and served.sizes["y"] == setup.domain.shape[0]
    # the served cells' map positions and east/north velocity, turned back into the scene
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    mx, my = served.map_x.values - ORIGIN[0], served.map_y.values - ORIGIN[1]
    sx, sy = c * mx + s * my, -s * mx + c * my
    su, sv = turn_vector(served.u_east.values, served.v_north.values, -angle)
    pts = np.c_[sy.ravel(), sx.ravel()]
    ref = {k: _interp(reference, k)(pts).reshape(sx.shape) for k in ("depth", "u", "v")}
    near = (np.hypot(sx, sy) <= 2 * B) & (served.depth.values > 0.01) & (ref["depth"] > 0.01)
    near &= served.obstacle.values == 0
    dv = np.hypot(su - ref["u"], sv - ref["v"])[near]
    dh = np.abs(served.depth.values - ref["depth"])[near]
    speed = np.hypot(ref["u"], ref["v"])[near]
    print(f"frozen turned {angle:g}: cells {near.sum()}, mean |dvel| {dv.mean():.4f} m/s ({100 * dv.mean() / speed.mean():.2f} % "
          f"of {speed.mean():.2f}), mean |ddepth| {dh.mean():.4f} m")
    assert near.sum() > 500
    assert dv.mean() <= 0.02 * speed.mean() and dh.mean() <= 0.01 * ref["depth"][near].mean()
    res = run_closure(sc, tmp_path / "run", plots=False)
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    q0 = man["metadata"]["initial"]["breach_discharge"]
    print(f"frozen turned {angle:g}: breach discharge {q0:.2f} vs {q_ref:.2f} m3/s unturned")
    assert abs(q0) == pytest.approx(abs(q_ref), rel=0.02)
    assert res.cycles == 1 and res.masses == 3
    with xr.open_dataset(tmp_path / "run" / "cycle_0001.nc") as ds:
        assert ds.attrs["flow_responds_to_pile"] == 0 and "GeoTransform" in ds["crs"].attrs
        px = ds.particle_map_x.values.ravel() - ORIGIN[0]
        py = ds.particle_map_y.values.ravel() - ORIGIN[1]
        ok = np.isfinite(px)
        # the masses are dropped into the breach of the turned scene
        assert ok.sum() >= 1 and np.all(np.hypot(c * px[ok] + s * py[ok], -s * px[ok] + c * py[ok]) <= 12.0)
