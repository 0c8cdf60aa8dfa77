"""``solver = "nested"`` with the levee in any direction (issue 13).

The whole scene is turned in a projected CRS (UTM 15N, the breach centre at ``ORIGIN``) by angles that
are not multiples of 90°: the regional model (the breach's own steady state on an unaligned triangle
mesh, written as the user's ADH / HEC-RAS files) and a DEM of the intact levee with its centreline. The
turning is done here with plain cos/sin (:func:`turn`), independent of the package's
:class:`~breachflow.site.frame.GridFrame`; the reference is the same scene at 0° (the nested model on
the CRS axes, the path the consistency tests of ``test_nested.py`` check).
"""
import json
import math
import time
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr
from pyproj import CRS

from breachflow.cycle.config import closure_setup, demo_breach
from breachflow.cycle.main import run_closure
from breachflow.errors import InputError
from breachflow.hydro.nested import NestedSolver, consistency
from breachflow.field.snapshot import mesh_snapshot, mesh_triangles
from breachflow.swe.domain import levee_bed
from breachflow.scenario.config import load_scenario
from breachflow.scenario.geometry import typical_breach

from .meshing import unaligned_mesh
from .test_nested import _steady, export_files

ORIGIN = (612_000.0, 4_012_000.0)  # map position of the scene's breach centre
WKT = CRS.from_epsg(32615).to_wkt()


def turn(x, y, angle):
    """Map coordinates of scene points (x, y) turned by *angle* (degrees, counter-clockwise) about the
    breach centre and moved to ``ORIGIN``."""
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    x, y = np.asarray(x, float), np.asarray(y, float)
    return ORIGIN[0] + c * x - s * y, ORIGIN[1] + s * x + c * y


def turn_vector(u, v, angle):
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    return c * np.asarray(u, float) - s * np.asarray(v, float), s * np.asarray(u, float) + c * np.asarray(v, float)


def turned_mesh(mesh, angle):
    """*mesh* (scene coordinates) turned by *angle* into the map: node positions and velocities."""
    x, y = turn(mesh["mesh2d_node_x"].values, mesh["mesh2d_node_y"].values, angle)
    u, v = turn_vector(mesh["u"].values, mesh["v"].values, angle)
    return mesh_snapshot(x, y, mesh_triangles(mesh), mesh["bed_elevation"].values, mesh["depth"].values, u, v,
                         crs_wkt=WKT, source=f"test: the mesh turned by {angle:g} deg")


def write_dem(scene, angle, path, half=260.0, spacing=2.0):
    """A north-up NetCDF DEM (EPSG:32615) of the intact levee of *scene* turned by *angle*, ± *half* m
    around the breach centre: the scene's analytic bed (:func:`~breachflow.swe.domain.levee_bed`) at
    each cell centre turned back into the scene."""
    intact = replace(scene, breach=replace(scene.breach, depth=1e-9, scour_depth=0.0))  # no cut
    x = ORIGIN[0] + np.arange(-half, half + 1e-9, spacing)
    y = ORIGIN[1] + np.arange(-half, half + 1e-9, spacing)
    X, Y = np.meshgrid(x, y)
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    dx, dy = X - ORIGIN[0], Y - ORIGIN[1]
    z = levee_bed(intact, c * dx + s * dy, -s * dx + c * dy)
    xr.Dataset({"elevation": (("y", "x"), z, {"units": "m", "grid_mapping": "crs"}),
                "crs": ((), np.int32(0), {"crs_wkt": WKT})}, coords={"x": x, "y": y}).to_netcdf(path)
    return path


def site_table(scene, angle, dem, files) -> str:
    """``[site]`` (the turned DEM and levee centreline, the scene's breach) and the nested ``snapshots``."""
    half = scene.levee_length_each_side + 0.5 * scene.breach.length
    ax, ay = turn(-half, 0.0, angle)
    bx, by = turn(half, 0.0, angle)
    files = ", ".join(f'"{p.name}"' for p in files)
    return f"""
[site]
terrain = "{dem.name}"
levee_coords = [[{ax:.6f}, {ay:.6f}], [{bx:.6f}, {by:.6f}]]
breach_at = "{half} m"
breach_length = "{scene.breach.length} m"
breach_bottom = "{scene.ground_elevation} m"
breach_wall_slope = {scene.breach.wall_slope}
flood_level = "{scene.flood_water_elevation} m"
flood_side = "right"
manning_n = {scene.manning_n}
[hydro]
solver = "nested"
snapshots = [{files}]
"""


TYPICAL_HYDRO = """resolution = "4 m"
tolerance = "1e-4 1/s"
t_max_initial = "900 s"
monitor_radius = "91.5 m"
"""


@pytest.fixture(scope="module")
def typical_mesh():
    """The typical breach (levee shortened to 250 m each side) at steady state on a 4 m grid, on an
    unaligned triangle mesh (scene coordinates)."""
    scene = replace(typical_breach(), levee_length_each_side=250.0)
    grid = _steady(scene, 4.0)
    assert grid.attrs["steady_state"] == 1
    return scene, grid, unaligned_mesh(grid, 4.0, angle_deg=17.0, seed=1)


def _nested(scene, mesh, angle, fmt, folder):
    """The nested solver of the scene turned by *angle*, set up from the user's files as ``breachflow run`` does."""
    folder.mkdir(parents=True, exist_ok=True)
    files = export_files(turned_mesh(mesh, angle), folder, fmt)  # ADH: with its .prj
    dem = write_dem(scene, angle, folder / "dem.nc")
    sc = folder / "nested.toml"
    sc.write_text(site_table(scene, angle, dem, files) + TYPICAL_HYDRO)
    setup = closure_setup(load_scenario(sc))
    return setup, setup.solver


@pytest.fixture(scope="module")
def references(typical_mesh, tmp_path_factory):
    """Per format: the nested re-solve of the unturned scene (0°, the model on the CRS axes)."""
    scene, _, mesh = typical_mesh
    out = {}

    def get(fmt):
        if fmt not in out:
            _, ns = _nested(scene, mesh, 0.0, fmt, tmp_path_factory.mktemp(f"ref_{fmt}"))
            assert ns.frame is None
            out[fmt] = (ns.solve(), ns.regional)
        return out[fmt]
    return get


@pytest.mark.parametrize("fmt,angle", [("adh", 23.0), ("hecras_hdf", 137.0),
                                       pytest.param("adh", -61.0, marks=pytest.mark.slow),
                                       pytest.param("hecras_hdf", 23.0, marks=pytest.mark.slow)])
def test_turned_nested_model_reproduces_the_field_and_the_unturned_solution(typical_mesh, references, tmp_path,
                                                                            fmt, angle):
    """The scene turned by *angle* in the CRS: the local model is built along the levee, re-solved with no
    masses it keeps the ingested field within 2 B of the breach (mean |Δ speed|, |Δ depth| within 5 %),
    and it is the unturned scene's solution turned: same depth and speed at the same scene position, the
    velocity turned by *angle* (map components u_east, v_north of the output)."""
    pytest.importorskip("h5py")
    scene, grid, mesh = typical_mesh
    setup, ns = _nested(scene, mesh, angle, fmt, tmp_path)
    assert isinstance(ns, NestedSolver) and ns.frame is not None
    assert ns.frame.angle_deg == pytest.approx((angle + 90.0) % 180.0 - 90.0)
    t0 = time.process_time()
    local = ns.solve()
    cpu = time.process_time() - t0
    B = scene.breach.length
    xc, yc = setup.breach_x[0] + 0.5 * B, setup.levee_y
    c = consistency(local, ns.regional, (xc, yc), 2 * B, frame=ns.frame)
    ref, ref_regional = references(fmt)
    c0 = consistency(ref, ref_regional, ORIGIN, 2 * B)
    # the same cells: the local grid's map positions, turned back into the scene, are the reference's
    sx, sy = _to_scene(local["map_x"].values, local["map_y"].values, angle)
    rx, ry = np.meshgrid(ref.x.values - ORIGIN[0], ref.y.values - ORIGIN[1])
    order = _match(sx, sy, rx, ry)
    d_depth = np.abs(local.depth.values - ref.depth.values.ravel()[order])
    ue, vn = turn_vector(ref.u.values.ravel()[order], ref.v.values.ravel()[order], angle)
    d_vel = np.hypot(local.u_east.values - ue, local.v_north.values - vn)
    near = (np.hypot(sx, sy) <= 2 * B) & (ref.depth.values.ravel()[order] > 0.01)
    print("turned nested", fmt, angle, json.dumps({k: round(v, 4) for k, v in c.items()}),
          f"mean speed {100 * c['mean_speed_diff'] / c['regional_mean_speed']:.2f} %",
          f"mean depth {100 * c['mean_depth_diff'] / c['regional_mean_depth']:.2f} %",
          f"(unturned: {100 * c0['mean_speed_diff'] / c0['regional_mean_speed']:.2f} %,",
          f"{100 * c0['mean_depth_diff'] / c0['regional_mean_depth']:.2f} %)",
          f"vs unturned within 2 B: max |d depth| {d_depth[near].max():.2e} m, max |d velocity| "
          f"{d_vel[near].max():.2e} m/s, mean {d_vel[near].mean():.2e} m/s; whole box max {d_vel.max():.2e} m/s;",
          "steady", local.attrs["steady_state"], local.attrs["simulated_time_s"], "CPU s", round(cpu, 1))
    assert local.attrs["hydro_mode"] == "nested" and local.attrs["steady_state"] == 1
    assert c["cells"] > 500
    assert c["mean_speed_diff"] <= 0.05 * c["regional_mean_speed"]
    assert c["mean_depth_diff"] <= 0.05 * c["regional_mean_depth"]
    assert c["regional_peak_speed"] == pytest.approx(float(np.hypot(grid.u, grid.v).max()), rel=0.05)
    # the turned scene's solution is the unturned one, turned: ADH files hold 12 significant digits (to
    # rounding); a HEC-RAS HDF holds its results in float32 as HEC-RAS writes them (measured: ≤ 6e-4 m,
    # ≤ 2.1e-3 m/s at 23° and 137°, 0.05 % of the mean speed)
    tol_h, tol_v = (1e-6, 1e-6) if fmt == "adh" else (2e-3, 1e-2)
    assert d_depth[near].max() < tol_h and d_vel[near].max() < tol_v
    # the output lands on the map: GDAL's geotransform puts cell (0, 0) at its map position
    gt = [float(v) for v in local["crs"].attrs["GeoTransform"].split()]
    assert gt[0] + 0.5 * gt[1] + 0.5 * gt[2] == pytest.approx(float(local.map_x[0, 0]), abs=1e-6)
    assert gt[3] + 0.5 * gt[4] + 0.5 * gt[5] == pytest.approx(float(local.map_y[0, 0]), abs=1e-6)


def _to_scene(X, Y, angle):
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    dx, dy = np.asarray(X) - ORIGIN[0], np.asarray(Y) - ORIGIN[1]
    return c * dx + s * dy, -s * dx + c * dy


def _match(sx, sy, rx, ry):
    """Flat indices of the reference cells (rx, ry) at the points (sx, sy); the cells must coincide."""
    from scipy.spatial import cKDTree

    dist, idx = cKDTree(np.c_[rx.ravel(), ry.ravel()]).query(np.c_[sx.ravel(), sy.ravel()])
    assert dist.max() < 1e-6, dist.max()
    return idx.reshape(sx.shape)


@pytest.mark.parametrize("method", ["bilinear", "neighbourhood"])
def test_a_mass_just_outside_a_turned_nested_box_feels_the_regional_flow_turned(method):
    """The DEM's field in a nested run on a turned grid (as the closure driver builds it): inside the box
    the local field, outside it the regional one at the point's map position with its velocity in grid
    components — checked against a regional field linear in the map coordinates (bilinear sampling is
    exact there) and turned here with cos/sin."""
    from breachflow.cycle.driver import dem_view
    from breachflow.fluid.forces import FluidForces
    from breachflow.dem.state import ParticleState
    from breachflow.field.sampling import FieldSampler, uniform_snapshot
    from breachflow.site import GridFrame

    angle = 37.0
    ext = (ORIGIN[0] - 80.0, ORIGIN[0] + 80.0, ORIGIN[1] - 80.0, ORIGIN[1] + 80.0)
    x = np.arange(ext[0], ext[1] + 1e-9, 2.0)
    y = np.arange(ext[2], ext[3] + 1e-9, 2.0)
    X, Y = np.meshgrid(x, y)
    depth = lambda X, Y: 3.0 + 0.01 * (X - ORIGIN[0]) - 0.004 * (Y - ORIGIN[1])
    ue = lambda X, Y: 1.2 + 0.002 * (Y - ORIGIN[1])
    vn = lambda X, Y: -0.4 + 0.001 * (X - ORIGIN[0])
    regional = uniform_snapshot(depth(X, Y), u=ue(X, Y), v=vn(X, Y), bed=0.0, extent=ext, spacing=2.0)
    frame = GridFrame(angle, ORIGIN)
    ns = NestedSolver([regional], (ORIGIN[0] - 20.0, ORIGIN[0] + 20.0, ORIGIN[1] - 16.0, ORIGIN[1] + 16.0), 1.0,
                      t_max_initial=5.0, frame=frame)
    local = ns.solve()
    # the local model started from the regional field seen from the grid: depth at the cells' map positions
    sx, sy = turn(local.x.values[None, :] - ORIGIN[0], local.y.values[:, None] - ORIGIN[1], angle)
    np.testing.assert_allclose(ns.initial_state[0], depth(sx, sy), rtol=1e-9)
    local["u"] = local["u"] * 0.25  # a pile-stilled local field
    field = FieldSampler(dem_view(local), method, fallback=ns.fallback_sampler(method))
    # grid points just outside the box: east, west, north
    gx = np.array([ns.box[1] + 0.4, ns.box[0] - 3.0, ORIGIN[0] + 3.0])
    gy = np.array([ORIGIN[1] + 3.0, ORIGIN[1] - 5.0, ns.box[3] + 2.5])
    s = field.sample(gx, gy, 0.5 if method == "neighbourhood" else None)
    mx, my = turn(gx - ORIGIN[0], gy - ORIGIN[1], angle)
    c, sn = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    want_u = c * ue(mx, my) + sn * vn(mx, my)
    want_v = -sn * ue(mx, my) + c * vn(mx, my)
    assert s.inside.all()
    if method == "bilinear":  # exact for a linear field
        np.testing.assert_allclose(s.depth, depth(mx, my), rtol=1e-9)
        np.testing.assert_allclose(s.u, want_u, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(s.v, want_v, rtol=1e-9, atol=1e-12)
    else:  # the mean of the gridpoints within the disc: a linear field's value near the centre
        np.testing.assert_allclose(s.depth, depth(mx, my), atol=0.02)
        np.testing.assert_allclose(s.u, want_u, atol=0.01)
        np.testing.assert_allclose(s.v, want_v, atol=0.01)
    # the drag on a mass just outside the box points along the regional velocity in grid components
    st = ParticleState.spheres(np.array([[gx[0], gy[0], 1.5]]), 0.5)
    f, t = np.zeros((1, 3)), np.zeros((1, 3))
    FluidForces(field, sampling=method, outside="air", velocity_profile="uniform").accumulate(st, st.pos, st.vel, st.omega, 0.0, f, t)
    assert np.arctan2(f[0, 1], f[0, 0]) == pytest.approx(np.arctan2(want_v[0], want_u[0]), abs=0.02)
    assert f[0, 2] == pytest.approx(1000.0 * 9.81 * 4 / 3 * np.pi * 0.5 ** 3, rel=1e-3)  # submerged


NESTED_CLOSURE = """
[scenario]
name = "turned nested demo"
{site}resolution = "1 m"
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
[fluid]
velocity_profile = "uniform"
[closure]
remap = "raised_bed"
seed = 1
"""


def test_turned_nested_closure_from_the_users_adh_files_lands_on_the_map(tmp_path):
    """``breachflow run`` with ``solver = "nested"`` on the scaled breach turned by 137° in the CRS (the
    river on the grid's north side): its ADH files (the steady state on an unaligned mesh, turned) and a
    DEM of the turned levee; the local model re-solved with the pile shuts the breach, and the cycle
    files carry the map coordinates of the turned scene. Before: an InputError (the levee must run
    within 5° of east–west)."""
    angle = 137.0
    scene = replace(demo_breach(), levee_length_each_side=36.0, flood_side_extent=36.0, protected_side_extent=36.0)
    grid = _steady(scene, 1.0)
    mesh = unaligned_mesh(grid, 1.0, angle_deg=23.0, seed=4)
    files = [p for p in export_files(turned_mesh(mesh, angle), tmp_path, "adh") if p.suffix != ".prj"]
    dem = write_dem(scene, angle, tmp_path / "dem.nc", half=60.0, spacing=0.5)
    scen = tmp_path / "nested.toml"
    scen.write_text(NESTED_CLOSURE.format(site=site_table(scene, angle, dem, files)))
    t0 = time.process_time()
    res = run_closure(scen, tmp_path / "run", plots=False)
    cpu = time.process_time() - t0
    print("turned nested closure", angle, "cycles", res.cycles, "closed", res.closed, "masses", res.masses,
          f"tonnage {res.tonnage:.1f} t, lost {res.lost_masses}", "CPU s (run)", round(cpu, 1),
          [round(r.breach_discharge, 2) for r in res.reports])
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert man["metadata"]["hydro_mode"] == "nested"
    assert man["metadata"]["site"]["grid_rotation_deg"] == pytest.approx(angle - 180.0)
    assert res.closed, [(r.cycle, r.breach_discharge, r.max_speed) for r in res.reports]
    q0 = man["metadata"]["initial"]["breach_discharge"]
    assert abs(q0) > 20.0 and abs(res.reports[-1].breach_discharge) < 0.05 * abs(q0)
    with xr.open_dataset(tmp_path / "run" / f"cycle_{res.cycles:04d}.nc") as ds:
        assert ds.attrs["hydro_mode"] == "nested" and ds.attrs["grid_rotation_deg"] == pytest.approx(angle - 180.0)
        # ADH files without their .prj: the site's CRS, with GDAL's turned geotransform
        assert CRS.from_wkt(ds["crs"].attrs["crs_wkt"]).to_epsg() == 32615 and "GeoTransform" in ds["crs"].attrs
        # the cells land on the map where the turned scene is: within the nested box, turned
        sx, sy = _to_scene(ds.map_x.values, ds.map_y.values, angle)
        assert np.abs(sx).max() == pytest.approx(6.0 + 36.0 - 0.5, abs=1e-6)
        assert np.abs(sy).max() == pytest.approx(36.0 - 0.5, abs=1e-6)
        # the masses lie in and beside the breach of the turned scene (B = 12 m; a mirrored or unturned
        # mapping would put them tens of metres away), half of them within the opening
        px, py = _to_scene(ds.particle_map_x.values, ds.particle_map_y.values, angle)
        ok = np.isfinite(px)
        assert ok.sum() >= res.masses - res.lost_masses
        assert np.all(np.abs(px[ok]) <= 12.0) and np.all(np.abs(py[ok]) <= 10.0)
        assert np.median(np.abs(px[ok])) <= 6.0
        # velocities on the map: east/north components turned back give the grid components (float32 in the file)
        c, s = math.cos(math.radians(angle - 180.0)), math.sin(math.radians(angle - 180.0))
        np.testing.assert_allclose(c * ds.u_east + s * ds.v_north, ds.u, rtol=1e-5, atol=1e-6)


def test_nested_on_the_crs_axes_is_unchanged_and_a_nested_box_is_refused_when_turned(tmp_path):
    """A levee along the CRS x axis keeps the nested model on the CRS axes (no frame); a turned site with
    ``[hydro] nested_box`` (a box on the CRS axes) is refused with a clear error."""
    scene = replace(demo_breach(), levee_length_each_side=20.0, flood_side_extent=20.0, protected_side_extent=20.0)
    X, Y = np.meshgrid(np.arange(-25.5, 26.0, 1.0), np.arange(-19.5, 20.0, 1.0))
    from breachflow.field.snapshot import grid_snapshot

    bed = levee_bed(scene, X, Y)
    regional = grid_snapshot(X[0], Y[:, 0], bed, np.maximum(3.0 - bed, 0.0), np.zeros_like(bed), np.zeros_like(bed))
    mesh = __import__("breachflow.io", fromlist=["grid_to_mesh"]).grid_to_mesh(regional)
    for angle in (0.0, 31.0):
        d = tmp_path / f"a{angle:g}"
        d.mkdir()
        files = [p for p in export_files(turned_mesh(mesh, angle), d, "adh") if p.suffix != ".prj"]
        dem = write_dem(scene, angle, d / "dem.nc", half=30.0, spacing=0.5)
        sc = d / "s.toml"
        sc.write_text(site_table(scene, angle, dem, files) + 'resolution = "1 m"\nt_max_initial = "5 s"\n')
        ns = closure_setup(load_scenario(sc)).solver
        assert (ns.frame is None) == (angle == 0.0)
        sc.write_text(site_table(scene, angle, dem, files) + 'resolution = "1 m"\nnested_box = ["-10 m", "10 m", "-10 m", "10 m"]\n')
        if angle == 0.0:
            continue
        with pytest.raises(InputError, match=r"\[hydro\] nested_box = .* box on the CRS axes.*31\.0° from the CRS x axis"):
            closure_setup(load_scenario(sc))


def test_a_regional_model_in_another_crs_than_the_terrain_is_refused(tmp_path):
    """The user's ADH model with a .prj of another CRS than the site's terrain (EPSG:32615) would put the
    breach in the wrong place: a clear InputError naming both; the same files with the terrain's CRS run."""
    scene = replace(demo_breach(), levee_length_each_side=20.0, flood_side_extent=20.0, protected_side_extent=20.0)
    X, Y = np.meshgrid(np.arange(-25.5, 26.0, 1.0), np.arange(-19.5, 20.0, 1.0))
    from breachflow.io import grid_to_mesh
    from breachflow.field.snapshot import grid_snapshot

    bed = levee_bed(scene, X, Y)
    regional = grid_snapshot(X[0], Y[:, 0], bed, np.maximum(3.0 - bed, 0.0), np.zeros_like(bed), np.zeros_like(bed))
    angle = 31.0
    files = export_files(turned_mesh(grid_to_mesh(regional), angle), tmp_path, "adh")
    prj = [p for p in files if p.suffix == ".prj"]
    assert prj, "the ADH export writes its .prj"
    dem = write_dem(scene, angle, tmp_path / "dem.nc", half=30.0, spacing=0.5)
    sc = tmp_path / "s.toml"
    sc.write_text(site_table(scene, angle, dem, files) + 'resolution = "1 m"\nt_max_initial = "5 s"\n')
    assert closure_setup(load_scenario(sc)).solver.frame is not None  # same CRS: accepted
    prj[0].write_text(CRS.from_epsg(32616).to_wkt())  # the next UTM zone
    with pytest.raises(InputError, match=r"regional model .* is in 'WGS 84 / UTM zone 16N' but the site's terrain "
                                         r"\(.*dem\.nc\) is in 'WGS 84 / UTM zone 15N'"):
        closure_setup(load_scenario(sc))
