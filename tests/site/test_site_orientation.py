"""A levee in any direction (issue 13): the example site turned about its breach centre.

``examples/site/make_site.py`` turns the whole scene (DEM and levee) by an angle about the breach
centre; the DEM stays a north-up GeoTIFF. The checks use the generator's geometry (the breach is
``PIVOT`` ± 6 m along the turned levee, the levee body |d| ≤ 8 m above 2.8 m), independent of the
model's grid frame, and GDAL's reading of the cycle files.
"""
import json
import math
import shutil
import subprocess

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.criteria import section_discharge
from breachflow.cycle.main import run_closure
from breachflow.errors import BreachflowError, InputError
from breachflow.scenario.config import load_scenario
from breachflow.site import SiteSpec, build_site

from .conftest import ROOT, SITE

rasterio = pytest.importorskip("rasterio")

HALF_BREACH = 6.0  # site.toml: breach_length = 12 m
BODY = 8.0  # |offset| from the centreline within which the example levee stands above 2.8 m


def _site(make_site, tmp_path, angle, replace=None, drop=(), extra_site=""):
    """The example site turned by *angle* in *tmp_path*: (scenario path, dem, levee)."""
    d = tmp_path / f"site_{angle:g}"
    tif, geo = make_site.write(d, angle)
    lines = []
    for ln in (SITE / "site.toml").read_text().splitlines():
        key = ln.split("=")[0].strip()
        if key in drop:
            continue
        if key in (replace or {}):
            ln = f"{key} = {replace[key]}"
        elif key == "terrain":
            ln = f'terrain = "{tif}"'
        elif key == "levee":
            ln = f'levee = "{geo}"'
        lines.append(ln)
        if ln.strip() == "[site]" and extra_site:
            lines.append(extra_site)
    p = d / "site.toml"
    p.write_text("\n".join(lines) + "\n")
    return p, tif, geo


def _scene_frame(make_site, angle, X, Y):
    """(along, across) of map points in the generator's breach frame (along the turned levee from the
    breach centre; across positive to the protected side, north in the unturned scene)."""
    x, y = make_site.turn(X, Y, -angle)
    return x - make_site.PIVOT[0], y - make_site.PIVOT[1]


def _expected_rotation(angle):
    a = (angle + 90.0) % 180.0 - 90.0
    return 90.0 if a == -90.0 else a


@pytest.mark.parametrize("angle", [0.0, 23.0, 90.0, 137.0, -61.0, 180.0, 3.0])
def test_turned_site_finds_the_breach_and_cuts_it_where_the_geometry_says(make_site, tmp_path, angle):
    _, tif, geo = _site(make_site, tmp_path, angle)
    site = build_site(SiteSpec(terrain=tif, levee=geo, breach_at=125.0, breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0,
                               flood_level=4.7), 1.5)
    assert site.centre == pytest.approx(make_site.PIVOT, abs=1e-6)
    assert site.frame.angle_deg == pytest.approx(_expected_rotation(angle), abs=1e-6)
    d = site.domain
    X, Y = site.frame.to_map(*np.meshgrid(d.x, d.y))
    a, c = _scene_frame(make_site, angle, X, Y)
    # the domain reaches well beyond the breach along the levee and across the whole levee body
    assert a.min() < -HALF_BREACH - 20 and a.max() > HALF_BREACH + 20 and c.min() < -30 and c.max() > 30
    h = 0.5 * math.hypot(d.dx, d.dy)  # a cell centre's distance to the cell's corners
    body = np.abs(c) <= BODY
    inside = body & (np.abs(a) <= HALF_BREACH - h)
    outside = body & (np.abs(a) >= HALF_BREACH + h) & (np.abs(a) < HALF_BREACH + 20)
    assert inside.sum() >= 40 and outside.sum() >= 10
    assert np.all(d.bed[inside] == 2.0)
    assert np.all(d.bed[outside] > 2.7)
    # the flood (the river, south of the unturned levee) is where the initial water is
    wet = np.isfinite(d.initial_surface)
    assert np.all(c[wet] < 0) and wet.sum() > 100
    # the level boundary is the grid edge on the river side
    edge = [k for k, bcs in d.boundaries.items() if bcs[0].kind == "level"]
    assert edge == (["south"] if site.flood_sign < 0 else ["north"])
    jj = 0 if site.flood_sign < 0 else -1
    assert np.all(c[jj] < -30)


@pytest.fixture(scope="module")
def reference_discharge(make_site, tmp_path_factory):
    """Initial breach discharge of the unturned example at 1.5 m (what `breachflow run` solves first)."""
    return _initial_discharge(make_site, tmp_path_factory.mktemp("ref"), 0.0)


def _initial_discharge(make_site, tmp_path, angle, resolution="1.5 m"):
    p, _, _ = _site(make_site, tmp_path, angle, replace={"resolution": f'"{resolution}"'})
    setup = closure_setup(load_scenario(p))
    snap = setup.solver.solve(setup.domain)
    return section_discharge(snap, setup.breach_x, setup.levee_y)


# Grid-alignment tolerance: the turned site samples a differently placed 1 m DEM (bilinear) and its own
# lidar-noise realisation; measured differences are below 0.2 % (README); 1 % is asserted.
Q_TOL = 0.01


@pytest.mark.parametrize("angle", [23.0, pytest.param(90.0, marks=pytest.mark.slow), pytest.param(-61.0, marks=pytest.mark.slow),
                                   pytest.param(45.0, marks=pytest.mark.slow)])
def test_breach_discharge_does_not_depend_on_the_levee_direction(make_site, tmp_path, reference_discharge, angle):
    q = _initial_discharge(make_site, tmp_path, angle)
    assert reference_discharge > 30.0
    # grid north flood (137°-like) gives a negative section discharge: the magnitude is compared
    assert abs(q) == pytest.approx(reference_discharge, rel=Q_TOL)


def _gdal_geotransform(path, var):
    """The geotransform gdalinfo (Debian gdal-bin) reports for NETCDF:path:var, or None without it."""
    if not shutil.which("gdalinfo"):
        return None
    out = subprocess.run(["gdalinfo", "-json", f"NETCDF:{path}:{var}"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)["geoTransform"]


def test_turned_site_closes_ci_sized_and_its_cycle_files_land_on_the_map(make_site, tmp_path, reference_discharge):
    """137°: the grid runs at −43° to the CRS x axis and the river is on its north edge. The breach closes;
    GDAL (rasterio, and gdalinfo when installed) puts the cut cells of the cycle file where the generator's
    breach is; masses sit in the breach in map coordinates; east/north velocities point from the river
    into the polder."""
    angle = 137.0
    p, tif, _ = _site(make_site, tmp_path, angle, replace={"resolution": '"1.5 m"'})
    res = run_closure(p, tmp_path / "run", plots=False)
    assert res.closed, [r.governing for r in res.reports]
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    q0 = man["metadata"]["initial"]["breach_discharge"]
    assert abs(q0) == pytest.approx(reference_discharge, rel=Q_TOL)
    assert man["metadata"]["site"]["grid_rotation_deg"] == pytest.approx(-43.0, abs=1e-6)
    cyc = tmp_path / "run" / "cycle_0001.nc"
    with rasterio.open(f"NETCDF:{cyc}:bed_elevation") as src:
        T = src.transform
        bed = src.read(1)
        assert src.crs.to_epsg() == 26915
    assert T.b != 0 and T.d != 0  # a rotated geotransform
    rows, cols = np.mgrid[0:bed.shape[0], 0:bed.shape[1]]
    X = T.c + (cols + 0.5) * T.a + (rows + 0.5) * T.b
    Y = T.f + (cols + 0.5) * T.d + (rows + 0.5) * T.e
    a, c = _scene_frame(make_site, angle, X, Y)
    h = 0.5 * math.hypot(T.a, T.d) * math.sqrt(2.0)
    body = np.abs(c) <= BODY
    inside = body & (np.abs(a) <= HALF_BREACH - h)
    outside = body & (np.abs(a) >= HALF_BREACH + h) & (np.abs(a) < HALF_BREACH + 20)
    assert inside.sum() >= 40 and outside.sum() >= 10
    assert np.all(bed[outside] > 2.7)
    # the breach is cut to 2.0 m except where a resting mass raised the bed (remap = "raised_bed")
    with xr.open_dataset(cyc) as ds:
        pxy = np.column_stack([ds["particle_map_x"].values[0], ds["particle_map_y"].values[0]])
        pr = 0.5 * ds["particle_diameter"].values[0]
    pxy, pr = pxy[np.isfinite(pr)], pr[np.isfinite(pr)]
    dist = np.hypot(X[..., None] - pxy[:, 0], Y[..., None] - pxy[:, 1]) - pr  # to the nearest mass's edge
    under_mass = (dist <= h).any(axis=-1)
    assert np.all(bed[inside & ~under_mass] == 2.0) and (inside & ~under_mass).sum() >= 20
    gt = _gdal_geotransform(cyc, "bed_elevation")
    if gt is not None:  # the system GDAL reads the same rotated geotransform as rasterio's
        np.testing.assert_allclose(gt, [T.c, T.a, T.b, T.f, T.d, T.e], rtol=0, atol=1e-6)
    with xr.open_dataset(cyc) as ds:
        assert ds.attrs["grid_rotation_deg"] == pytest.approx(-43.0, abs=1e-6)
        # the auxiliary map coordinates are GDAL's cell centres
        np.testing.assert_allclose(ds["map_x"].values, X, atol=1e-6)
        np.testing.assert_allclose(ds["map_y"].values, Y, atol=1e-6)
        assert "map_x" in ds["depth"].encoding.get("coordinates", "")
        assert "standard_name" not in ds["x"].attrs and "axis" not in ds["x"].attrs
        px, py = ds["particle_map_x"].values[0], ds["particle_map_y"].values[0]
        placed = np.isfinite(px)
        assert placed.sum() == 5
        pa, pc = _scene_frame(make_site, angle, px[placed], py[placed])
        assert np.all(np.abs(pa) < HALF_BREACH + 2.0) and np.all(np.abs(pc) < 3.0)
        # east/north velocity = the grid velocity turned by the grid's angle (the generator's turn about its
        # pivot, applied to vectors), and the water crosses the levee at the breach from the river to the polder
        u, v = ds["u"].values[0], ds["v"].values[0]
        ue, vn = ds["u_east"].values[0], ds["v_north"].values[0]
        tx, ty = make_site.turn(make_site.PIVOT[0] + u, make_site.PIVOT[1] + v, -43.0)
        np.testing.assert_allclose(ue, tx - make_site.PIVOT[0], atol=1e-9)
        np.testing.assert_allclose(vn, ty - make_site.PIVOT[1], atol=1e-9)
        depth = ds["depth"].values[0]
    n_prot = np.array(make_site.turn(make_site.PIVOT[0], make_site.PIVOT[1] + 1.0, angle)) - np.array(make_site.PIVOT)
    gap = (np.abs(a) < HALF_BREACH) & (np.abs(c) < 1.0) & (depth > 0.05)
    assert gap.sum() >= 2
    flux = np.sum(depth[gap] * (ue[gap] * n_prot[0] + vn[gap] * n_prot[1]))
    assert flux > 0
    # the plan view shows the breach (grid coordinates: the breach centre is the same point)
    from breachflow.cycle.plots import plan_view_figure
    from breachflow.io import RunDirectory

    fig = plan_view_figure(RunDirectory(tmp_path / "run"))
    for ax in fig.axes[:2]:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x0 < make_site.PIVOT[0] < x1 and y0 < make_site.PIVOT[1] < y1 and x1 - x0 <= 50.0


def test_turned_site_cycle_file_passes_the_cf_checker(make_site, tmp_path):
    """The georeferenced grid of a turned site (map_x/map_y, u_east/v_north, GeoTransform) through cfchecker."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("breachflow_tools_cf_check", ROOT / "tools" / "cf_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    table = mod.ensure_env(install=False)
    import ctypes.util

    if table is None or not ctypes.util.find_library("udunits2"):
        pytest.skip("cfchecker environment / UDUNITS-2 not installed (python3 tasks.py test installs them)")
    p, _, _ = _site(make_site, tmp_path, -61.0, replace={"resolution": '"3 m"', "max_cycles": "1", "t_max_initial": '"20 s"',
                                                        "t_max": '"5 s"', "max_time": '"1.5 s"'})
    run_closure(p, tmp_path / "run", plots=False)
    path = tmp_path / "run" / "cycle_0001.nc"
    rep = mod.cf_check(path, table)
    assert (rep.errors, rep.warnings) == (0, 0), "\n".join(rep.messages or [rep.output])
    assert mod.crs_problems(path) == []


def test_placement_in_map_coordinates_is_turned_into_the_grid(make_site, tmp_path):
    """A release line given in the site CRS across the turned breach ends up on that line."""
    angle = 23.0
    s = np.array(make_site.turn(make_site.PIVOT[0] - 4.0, make_site.PIVOT[1], angle))
    e = np.array(make_site.turn(make_site.PIVOT[0] + 4.0, make_site.PIVOT[1], angle))
    p, _, _ = _site(make_site, tmp_path, angle,
                    replace={"positions": '"line"\nstart = ["%.3f m", "%.3f m"]\nstop = ["%.3f m", "%.3f m"]' % (*s, *e)})
    setup = closure_setup(load_scenario(p))
    pl = setup.placement
    for given, grid in ((s, pl.start), (e, pl.stop)):
        np.testing.assert_allclose(setup.frame.to_map(*grid), given, atol=1e-6)
    # in the grid the line runs along the levee centreline (y = the breach centre's) across the breach
    assert pl.start[1] == pytest.approx(setup.levee_y, abs=1e-3) and pl.stop[1] == pytest.approx(setup.levee_y, abs=1e-3)
    assert setup.breach_x[0] < pl.start[0] < pl.stop[0] < setup.breach_x[1]
    rel = pl.release(1, 0, lambda x, y: np.zeros_like(x))
    gx, gy = setup.frame.to_map(rel.pos[:, 0], rel.pos[:, 1])
    a, c = _scene_frame(make_site, angle, gx, gy)
    assert np.all(np.abs(a) <= 4.0 + 0.5) and np.all(np.abs(c) < 0.5)


def test_turned_site_bad_input(make_site, tmp_path):
    """At 23°: errors stay clear, name the file or key, and nothing is written."""
    def fails(match, **kw):
        p, _, _ = _site(make_site, tmp_path, 23.0, **kw)
        out = tmp_path / "run"
        with pytest.raises(BreachflowError, match=match):
            run_closure(p, out, plots=False)
        assert not out.exists()

    fails(r"\[placement\] zone = .* is a box on the CRS axes, but the grid of this site runs along the levee \(23\.0°",
          replace={"positions": '"zone"\nzone = ["676110 m", "676130 m", "3372095 m", "3372105 m"]'})
    fails(r"\[closure\] area = .* box on the CRS axes", replace={"seed": "1\narea = [\"676000 m\", \"676200 m\", \"3372000 m\", \"3372200 m\"]"})
    # no data more than 3 m to the protected side of the levee centreline: the domain is not covered
    _, tif, geo = _site(make_site, tmp_path, 23.0)
    with rasterio.open(tif) as src:
        z, prof, T = src.read(1), src.profile, src.transform
    rows, cols = np.mgrid[0:z.shape[0], 0:z.shape[1]]
    _, c = _scene_frame(make_site, 23.0, T.c + (cols + 0.5) * T.a, T.f + (rows + 0.5) * T.e)
    z[c > 3.0] = prof["nodata"]
    cut = tmp_path / "cut.tif"
    with rasterio.open(cut, "w", **prof) as dst:
        dst.write(z, 1)
    with pytest.raises(InputError, match=r"cut\.tif: no elevation at \((\d+\.\d), (\d+\.\d)\) inside the domain") as err:
        build_site(SiteSpec(terrain=cut, levee=geo, breach_at=125.0, breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0,
                            flood_level=4.7), 1.5)
    import re

    bx, by = (float(v) for v in re.search(r"no elevation at \(([\d.]+), ([\d.]+)\)", str(err.value)).groups())
    assert _scene_frame(make_site, 23.0, bx, by)[1] > 3.0 - 1.5  # the point named is a map point without data


def test_terrain_smaller_than_the_wanted_box_clips_a_turned_grid_inside_it(make_site, tmp_path):
    """Extents far beyond the terrain at 23°: the grid is clipped so that every cell has terrain, it
    still holds the breach and its levee, and the report says it was clipped; a terrain that cannot hold
    the breach's footprint is an error naming both boxes."""
    _, tif, geo = _site(make_site, tmp_path, 23.0)
    spec = SiteSpec(terrain=tif, levee=geo, breach_at=125.0, breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0, flood_level=4.7,
                    extent_along=400.0, extent_flood=400.0, extent_protected=400.0)
    site = build_site(spec, 2.0)
    assert site.report["extent_clipped_to_terrain"] is True
    d = site.domain
    assert np.isfinite(d.bed).all()
    X, Y = site.frame.to_map(*np.meshgrid(d.x, d.y))
    a, c = _scene_frame(make_site, 23.0, X, Y)
    assert a.min() < -HALF_BREACH - 2 and a.max() > HALF_BREACH + 2 and c.min() < -BODY and c.max() > BODY
    with rasterio.open(tif) as src:
        b = src.bounds
    assert X.min() > b.left and X.max() < b.right and Y.min() > b.bottom and Y.max() < b.top
    # a 30 m x 30 m terrain around the breach centre: the breach fits, its footprint's corners do not
    with rasterio.open(tif) as src:
        win = rasterio.windows.from_bounds(make_site.PIVOT[0] - 9, make_site.PIVOT[1] - 9, make_site.PIVOT[0] + 9,
                                           make_site.PIVOT[1] + 9, src.transform)
        z = src.read(1, window=win)
        prof = src.profile
        prof.update(width=z.shape[1], height=z.shape[0], transform=src.window_transform(win))
    small = tmp_path / "small.tif"
    with rasterio.open(small, "w", **prof) as dst:
        dst.write(z, 1)
    with pytest.raises(InputError, match=r"small\.tif: the terrain \(x .*\) does not cover the breach and its levee "
                                         r"footprint \(x .*\)"):
        build_site(SiteSpec(terrain=small, levee=geo, breach_at=125.0, breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0,
                            flood_level=4.7, flood_side="right"), 1.0)


def test_solvers_on_the_crs_axes_still_need_an_east_west_levee(make_site, tmp_path):
    """align=False (the nested / snapshot solvers serve fields on the CRS axes): the old limit, clearly."""
    _, tif, geo = _site(make_site, tmp_path, 23.0)
    spec = SiteSpec(terrain=tif, levee=geo, breach_at=125.0, breach_length=12.0, breach_bottom=2.0, breach_wall_slope=0.0, flood_level=4.7)
    with pytest.raises(InputError, match=r"levee\.geojson: the levee runs at 23\.0° to the x axis of the CRS at the "
                                         r"breach .*'swe' solver takes any direction"):
        build_site(spec, 1.5, align=False)
    assert build_site(spec, 1.5).frame.angle_deg == pytest.approx(23.0)
