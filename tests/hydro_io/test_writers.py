"""Writers (ADH/SMS, ESRI grids, HEC-RAS sdf) and the unaligned triangulation: write → read gives the same
values within the text precision, and the expected values are analytic (fields linear in x and y, which
bilinear / barycentric interpolation reproduces exactly), not numbers the code produced earlier.
"""
import re
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

from breachflow.errors import InputError
from breachflow.field import grid_snapshot, write_snapshot
from breachflow.io import open_snapshot
from breachflow.io import grid_to_mesh, to_unaligned_mesh, write_adh, write_esri, write_sdf
from breachflow.field.snapshot import mesh_face_nodes, node_coordinates

FT = 0.3048


def _lin(a, bx, by):
    return lambda x, y: a + bx * x + by * y


BED = _lin(30.0, 0.002, -0.004)
WSE = _lin(36.0, -0.001, 0.0005)
U = _lin(1.2, 0.0005, 0.001)
V = _lin(-0.4, 0.0002, -0.0007)


def _analytic_grid(nx=41, ny=31, dx=10.0, x0=-200.0, y0=-150.0, times=None, obstacle=None, crs=None):
    x = x0 + dx * np.arange(nx)
    y = y0 + dx * np.arange(ny)
    X, Y = np.meshgrid(x, y)
    bed, h, u, v = BED(X, Y), WSE(X, Y) - BED(X, Y), U(X, Y), V(X, Y)
    if times is not None:
        scale = np.linspace(0.5, 1.0, len(times))[:, None, None]
        h, u, v = h[None] * scale, u[None] * scale, v[None] * scale
    return grid_snapshot(x, y, bed, h, u, v, time=times, obstacle=obstacle, crs_wkt=crs)


def _tri_areas(x, y, f):
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    return 0.5 * ((x[b] - x[a]) * (y[c] - y[a]) - (x[c] - x[a]) * (y[b] - y[a]))


# ---------------------------------------------------------------- unaligned mesh

@pytest.mark.parametrize("seed", [0, 1, 2, 7, 123])
@pytest.mark.parametrize("n_nodes", [300, 1500])
def test_unaligned_mesh_interpolates_linear_fields_exactly_and_covers_the_grid(seed, n_nodes):
    g = _analytic_grid()
    m = to_unaligned_mesh(g, n_nodes, seed)
    x, y = node_coordinates(m)
    f = mesh_face_nodes(m)
    area = _tri_areas(x, y, f)
    assert (area > 0).all()                                           # anticlockwise, no slivers of zero area
    assert area.sum() == pytest.approx(400.0 * 300.0, rel=1e-12)      # covers the cell-centre rectangle exactly
    assert 0.75 * n_nodes < x.size < 1.25 * n_nodes
    np.testing.assert_allclose(m.bed_elevation.values, BED(x, y), atol=1e-9)
    np.testing.assert_allclose(m.depth.values, WSE(x, y) - BED(x, y), atol=1e-9)
    np.testing.assert_allclose(m.u.values, U(x, y), atol=1e-12)
    np.testing.assert_allclose(m.v.values, V(x, y), atol=1e-12)
    # not aligned with the grid: interior nodes off the cell-centre lines, rotated lattice
    inner = (x > -195) & (x < 195) & (y > -145) & (y < 145)
    on_lines = (np.abs((x[inner] + 200) / 10 - np.rint((x[inner] + 200) / 10)) < 1e-3) | \
               (np.abs((y[inner] + 150) / 10 - np.rint((y[inner] + 150) / 10)) < 1e-3)
    assert on_lines.mean() < 0.02
    assert 10.0 <= m.attrs["mesh_rotation_deg"] <= 35.0


def test_unaligned_mesh_is_deterministic_per_seed_and_keeps_time_steps():
    g = _analytic_grid(times=np.array([0.0, 600.0, 1200.0]))
    a, b, c = to_unaligned_mesh(g, 400, 5), to_unaligned_mesh(g, 400, 5), to_unaligned_mesh(g, 400, 6)
    np.testing.assert_array_equal(a.mesh2d_node_x.values, b.mesh2d_node_x.values)
    assert a.sizes["node"] != c.sizes["node"] or not np.array_equal(a.mesh2d_node_x.values, c.mesh2d_node_x.values)
    x, y = node_coordinates(a)
    assert a.depth.shape == (3, a.sizes["node"])
    for k, s in enumerate(np.linspace(0.5, 1.0, 3)):
        np.testing.assert_allclose(a.depth.values[k], s * (WSE(x, y) - BED(x, y)), atol=1e-9)
    np.testing.assert_array_equal(a.time.values, [0.0, 600.0, 1200.0])


def test_obstacle_cells_become_a_hole_in_the_mesh():
    obst = np.zeros((31, 41), dtype="i1")
    obst[10:14, :] = 1  # a levee across the domain
    g = _analytic_grid(obstacle=obst)
    for m in (to_unaligned_mesh(g, 800, 1), grid_to_mesh(g)):
        x, y = node_coordinates(m)
        f = mesh_face_nodes(m)
        cx, cy = x[f].mean(axis=1), y[f].mean(axis=1)
        j = np.rint((cy + 150) / 10).astype(int)
        i = np.rint((cx + 200) / 10).astype(int)
        assert not obst[j, i].any()
        assert f.shape[0] > 100


def test_unaligned_mesh_rejects_bad_input():
    g = _analytic_grid()
    with pytest.raises(InputError, match="at least 4"):
        to_unaligned_mesh(g, 2)
    with pytest.raises(InputError, match="jitter"):
        to_unaligned_mesh(g, 100, jitter=0.7)
    with pytest.raises(InputError, match="grid snapshot"):
        to_unaligned_mesh(grid_to_mesh(g), 100)


# ---------------------------------------------------------------- ADH / SMS

@pytest.mark.parametrize("units, to_m", [("m", 1.0), ("ft", FT)])
def test_adh_round_trip_on_an_unaligned_mesh(tmp_path, units, to_m):
    m = to_unaligned_mesh(_analytic_grid(times=np.array([0.0, 1800.0])), 700, 3)
    paths = write_adh(m, tmp_path / "run", units=units)
    assert [p.name for p in paths] == ["run.3dm", "run_dep.dat", "run_vel.dat", "run.bc"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = open_snapshot(paths)  # plausibility="raise": the checks pass
    assert r.attrs["source_length_unit"] == units and r.attrs["source_length_unit_from"].startswith("MP G")
    x, y = node_coordinates(r)
    x0, y0 = node_coordinates(m)
    np.testing.assert_allclose(x, x0, rtol=1e-11)
    np.testing.assert_allclose(y, y0, rtol=1e-11)
    np.testing.assert_array_equal(mesh_face_nodes(r), mesh_face_nodes(m))
    np.testing.assert_allclose(r.bed_elevation.values, BED(x0, y0), rtol=1e-11)
    for k, s in enumerate([0.5, 1.0]):  # %16.8e: 9 significant digits
        np.testing.assert_allclose(r.depth.values[k], s * (WSE(x0, y0) - BED(x0, y0)), rtol=6e-9)
        np.testing.assert_allclose(r.u.values[k], s * U(x0, y0), rtol=6e-9, atol=1e-12)
        np.testing.assert_allclose(r.v.values[k], s * V(x0, y0), rtol=6e-9, atol=1e-12)
    np.testing.assert_array_equal(r.time.values, [0.0, 1800.0])
    # the file text is what ADH writes (values in the file unit)
    dep = paths[1].read_text().splitlines()
    assert dep[:3] == ["DATASET", 'OBJTYPE "mesh2d"', "BEGSCL"] and 'NAME "Depth"' in dep
    first = float(dep[dep.index("TS 0   0.00000000e+00") + 1])
    assert first == pytest.approx(0.5 * (WSE(x0[0], y0[0]) - BED(x0[0], y0[0])) / to_m, rel=6e-9)
    assert re.search(r"^MP G (9\.81|32\.17\d*)$", paths[3].read_text(), re.M)


def test_adh_dates_dry_nodes_and_a_grid_snapshot(tmp_path):
    t = np.array(["2024-01-01T00:00", "2024-01-01T01:30"], dtype="datetime64[ns]")
    g = _analytic_grid(nx=9, ny=7, times=t)
    g["depth"][:, :2, :] = 0.0  # dry rows
    g["u"][:, :2, :] = 0.0
    g["v"][:, :2, :] = 0.0
    paths = write_adh(g, tmp_path / "g")  # a grid: written on the mesh of its cell centres
    r = open_snapshot(paths)
    assert r.sizes["node"] == 63 and r.sizes["face"] == 2 * 8 * 6
    np.testing.assert_array_equal(r.time.values, t)
    x, y = node_coordinates(r)
    dry = y < -150 + 15
    assert (r.depth.values[:, dry] == 0).all() and (r.wet.values[:, dry] == 0).all()
    np.testing.assert_allclose(r.depth.values[1, ~dry], (WSE(x, y) - BED(x, y))[~dry], rtol=6e-9)


def test_adh_writer_leaves_nothing_half_written(tmp_path, monkeypatch):
    from breachflow.io import writers

    m = to_unaligned_mesh(_analytic_grid(), 200, 0)
    texts = writers.adh_texts(m, tmp_path / "x")
    texts[tmp_path / "missing_dir" / "x.bc"] = None  # writing this one fails (None is not text)
    monkeypatch.setattr(writers, "adh_texts", lambda *a, **k: texts)
    with pytest.raises(TypeError):
        writers.write_adh(m, tmp_path / "x")
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


# ---------------------------------------------------------------- ESRI

@pytest.mark.parametrize("units, to_m", [("m", 1.0), ("ft", FT)])
def test_esri_round_trip(tmp_path, units, to_m):
    crs = 'PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",15],PARAMETER["scale_factor",0.9996],PARAMETER["false_easting",500000],PARAMETER["false_northing",0],UNIT["metre",1]]'
    g = _analytic_grid(crs=crs)
    g["depth"][:3, :] = 0.0
    g["u"][:3, :] = 0.0
    g["v"][:3, :] = 0.0
    paths = write_esri(g, tmp_path / "snap", units=units)
    assert {p.name for p in paths} >= {"snap_depth.asc", "snap_wse.asc", "snap_terrain.asc", "snap_vx.asc", "snap_vy.asc", "snap_depth.prj"}
    text = (tmp_path / "snap_depth.asc").read_text().splitlines()
    assert text[5] == "NODATA_value -9999" and text[-1].split()[0] == "-9999"  # southern rows are dry
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = open_snapshot(paths, units=units)
    X, Y = np.meshgrid(g.x.values, g.y.values)
    np.testing.assert_allclose(r.x.values, g.x.values, atol=1e-9)  # 12 significant digits of the corner
    np.testing.assert_allclose(r.bed_elevation.values, BED(X, Y), rtol=1e-8)
    wet = Y > -150 + 25
    np.testing.assert_allclose(r.depth.values[wet], (WSE(X, Y) - BED(X, Y))[wet], rtol=1e-8)
    assert (r.depth.values[~wet] == 0).all()
    np.testing.assert_allclose(r.u.values[wet], U(X, Y)[wet], rtol=1e-8)
    np.testing.assert_allclose(r.v.values[wet], V(X, Y)[wet], rtol=1e-8)
    assert "crs" in r.variables


def test_esri_needs_a_grid(tmp_path):
    with pytest.raises(InputError, match="need a grid snapshot"):
        write_esri(grid_to_mesh(_analytic_grid(nx=4, ny=4)), tmp_path / "m")


# ---------------------------------------------------------------- HEC-RAS sdf

@pytest.mark.parametrize("direction", ["+x", "-x", "+y"])
@pytest.mark.parametrize("n_sections", [2, 5])
def test_sdf_round_trip_on_the_cut_lines(tmp_path, direction, n_sections):
    # a 1-D-like field: the water surface varies only along the flow, bed and speed across it too
    x = -100.0 + 5.0 * np.arange(41)
    y = -50.0 + 5.0 * np.arange(21)
    X, Y = np.meshgrid(x, y)
    s = {"+x": (1, 0), "-x": (-1, 0), "+y": (0, 1)}[direction]
    along = s[0] * X + s[1] * Y
    across = s[0] * Y - s[1] * X
    bed = 2.0 + 0.01 * across
    wse = 10.0 - 0.001 * along
    speed = 1.0 + 0.004 * across + 0.0005 * along
    g = grid_snapshot(x, y, bed, wse - bed, speed * s[0], speed * s[1])
    p = write_sdf(g, tmp_path / "RASExport.sdf", n_sections=n_sections, points=21)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = open_snapshot(p)
    nx_, ny_ = node_coordinates(r)
    al = s[0] * nx_ + s[1] * ny_
    ac = s[0] * ny_ - s[1] * nx_
    assert np.unique(np.round(al, 6)).size == n_sections  # nodes lie on n straight cut lines across the flow
    np.testing.assert_allclose(r.bed_elevation.values, 2.0 + 0.01 * ac, atol=2e-6)
    np.testing.assert_allclose(r.depth.values[0], 10.0 - 0.001 * al - (2.0 + 0.01 * ac), atol=4e-6)
    sp = 1.0 + 0.004 * ac + 0.0005 * al
    np.testing.assert_allclose(r.u.values[0], sp * s[0], atol=2e-6)
    np.testing.assert_allclose(r.v.values[0], sp * s[1], atol=2e-6)
    assert r.attrs["source_length_unit"] == "m"


def test_sdf_in_feet_with_dated_profiles(tmp_path):
    t = np.array(["2020-01-01T01:00", "2020-01-01T02:00"], dtype="datetime64[ns]")
    g = _analytic_grid(times=t)
    p = write_sdf(g, tmp_path / "f.sdf", units="ft")
    text = p.read_text()
    assert "UNITS: US CUSTOMARY" in text and "   01JAN2020 0100" in text
    r = open_snapshot(p)
    np.testing.assert_array_equal(r.time.values, t)
    x, y = node_coordinates(r)
    np.testing.assert_allclose(r.bed_elevation.values, BED(x, y), atol=1e-6 * FT * 2)


# ---------------------------------------------------------------- CLI

def test_cli_export_adh_esri_sdf_and_ingest_back(tmp_path):
    from breachflow.cli import app

    snap = write_snapshot(_analytic_grid(nx=21, ny=16), tmp_path / "s.nc")
    run = CliRunner()
    r = run.invoke(app, ["export", str(snap), "--format", "adh", "-o", str(tmp_path / "a" / "run"), "--nodes", "150", "--seed", "2"])
    assert r.exit_code == 0, r.output
    files = [str(tmp_path / "a" / n) for n in ("run.3dm", "run_dep.dat", "run_vel.dat", "run.bc")]
    r = run.invoke(app, ["ingest", *files, "-o", str(tmp_path / "back.nc")])
    assert r.exit_code == 0, r.output
    r = run.invoke(app, ["export", str(snap), "-f", "esri", "-o", str(tmp_path / "e" / "g"), "--units", "ft"])
    assert r.exit_code == 0, r.output
    grids = sorted(str(p) for p in (tmp_path / "e").glob("*.asc"))
    r = run.invoke(app, ["ingest", *grids, "--units", "ft", "-o", str(tmp_path / "g.nc")])
    assert r.exit_code == 0, r.output
    r = run.invoke(app, ["export", str(snap), "-f", "sdf", "-o", str(tmp_path / "RASExport")])
    assert r.exit_code == 0 and (tmp_path / "RASExport.sdf").exists(), r.output
    r = run.invoke(app, ["export", str(snap), "-f", "hdf", "-o", str(tmp_path / "x")])
    assert r.exit_code != 0 and isinstance(r.exception, InputError)


# ---------------------------------------------------------------- our own SWE steady state, as another model would hand it over

@pytest.fixture(scope="module")
def breach_steady():
    from breachflow.swe import SWEOptions, SWESimulation
    from breachflow.swe.domain import breach_domain, breach_vicinity
    from breachflow.scenario import geometry

    sc = geometry.typical_breach()
    dom = breach_domain(sc, 16.0)
    sim = SWESimulation(dom, SWEOptions())
    assert sim.run_to_steady(1e-4, 3600.0, region=breach_vicinity(dom, sc)).converged
    return sim.snapshot()


@pytest.mark.parametrize("seed", [0, 4])
def test_typical_breach_steady_state_through_adh_on_an_unaligned_mesh(tmp_path, breach_steady, seed):
    from scipy.interpolate import RegularGridInterpolator

    g = breach_steady
    m = to_unaligned_mesh(g, g.sizes["x"] * g.sizes["y"], seed)
    x, y = node_coordinates(m)
    # node values are bilinear interpolations of the grid (independent check with scipy)
    pts = np.column_stack([y, x])
    for name in ("bed_elevation", "depth"):
        ref = RegularGridInterpolator((g.y.values, g.x.values), g[name].values)(pts)
        np.testing.assert_allclose(m[name].values, np.where(ref > 1e-6, ref, 0.0) if name == "depth" else ref, atol=1e-9)
    wet = m.depth.values > 1e-6
    ref_u = RegularGridInterpolator((g.y.values, g.x.values), g["u"].values)(pts)
    np.testing.assert_allclose(m.u.values[wet], ref_u[wet], atol=1e-9)
    paths = write_adh(m, tmp_path / "breach")
    r = open_snapshot(paths)  # plausibility checks at their defaults pass
    np.testing.assert_allclose(r.depth.values[0], m.depth.values, rtol=6e-9, atol=1e-12)
    np.testing.assert_allclose(np.hypot(r.u.values[0], r.v.values[0]), np.hypot(m.u.values, m.v.values), rtol=6e-9, atol=1e-12)
    assert r.depth.values.max() > 5.0 and np.hypot(r.u.values, r.v.values).max() > 5.0  # a real breach flow


def test_typical_breach_steady_state_through_esri_and_sdf(tmp_path, breach_steady):
    g = breach_steady
    r = open_snapshot(write_esri(g, tmp_path / "breach"), units="m")
    np.testing.assert_allclose(r.depth.values, g.depth.values, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(r.v.values, g.v.values, rtol=1e-8, atol=1e-12)
    s = open_snapshot(write_sdf(g, tmp_path / "breach.sdf", n_sections=6))
    assert s.sizes["node"] == 6 * 41 and s.depth.values.max() > 1.0


@pytest.mark.parametrize("units", ["m", "ft", "survey_foot"])
def test_crs_goes_along_in_the_files_units(tmp_path, units):
    g = _analytic_grid(nx=9, ny=7, crs="EPSG:32633")  # WGS 84 / UTM 33N, metres
    paths = write_adh(to_unaligned_mesh(g, 60, 1), tmp_path / "c", units=units)
    assert paths[-1].name == "c.prj"
    r = open_snapshot(paths)
    assert "crs" in r.variables and r.attrs["source_length_unit"] == units
    e = open_snapshot(write_esri(g, tmp_path / "e", units=units), units=units)
    np.testing.assert_allclose(e.x.values, g.x.values, atol=1e-9)
    assert "UTM zone 33N" in e["crs"].attrs["crs_wkt"]
