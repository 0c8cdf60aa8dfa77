"""Every sample export in tests/hydro_io/data reads to a schema-valid snapshot whose values match the file text.

Expected values are taken from the sample files with deliberately naive parsing inside the tests
(split lines, pick the numbers), independent of the readers' fast paths.
"""
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

from breachflow import InputError
from breachflow.errors import BreachflowWarning, ParseError
from breachflow.field import FieldSampler, read_snapshot, write_snapshot
from breachflow.io import open_snapshot
from breachflow.io import READERS, guess_format
from breachflow.field.snapshot import mesh_face_nodes, validate_snapshot

FT = 0.3048


def _cards(path, card):
    return [ln.split() for ln in path.read_text().splitlines() if ln.split()[:1] == [card]]


def _dat_steps(path):
    """{dataset NAME: [(time, status list | None, value rows)]} by straightforward line reading."""
    out, name, steps, lines = {}, None, None, path.read_text().splitlines()
    i = 0
    nd = nc = None
    while i < len(lines):
        t = lines[i].split()
        if not t:
            i += 1
            continue
        if t[0] == "ND":
            nd = int(t[1])
        elif t[0] == "NC":
            nc = int(t[1])
        elif t[0] == "NAME":
            name = lines[i].split(None, 1)[1].strip().strip('"')
            steps = out.setdefault(name, [])
        elif t[0] == "TS":
            stat = None
            if t[1] == "1":
                stat = [int(lines[i + 1 + k]) for k in range(nc)]
                i += nc
            rows = [[float(z) for z in lines[i + 1 + k].split()] for k in range(nd)]
            steps.append((float(t[2]), stat, np.array(rows)))
            i += nd
        i += 1
    return out


def test_adh_demo_mesh_and_datasets_match_the_file_text(formats):
    files = [formats / n for n in ("adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc")]
    ds = open_snapshot(files)
    validate_snapshot(ds)
    nodes = _cards(formats / "adh_demo.3dm", "ND")
    ids = np.array([int(n[1]) for n in nodes])
    xyz = np.array([[float(v) for v in n[2:5]] for n in nodes])
    order = np.argsort(ids)
    np.testing.assert_array_equal(ds.mesh2d_node_id.values, ids[order])
    np.testing.assert_allclose(ds.mesh2d_node_x.values, xyz[order, 0])  # MP G 9.81 in the .bc: metres
    np.testing.assert_allclose(ds.bed_elevation.values, xyz[order, 2])
    # faces: same node sets as the E3T cards (orientation may be flipped to anticlockwise)
    elems = {int(e[1]): sorted(int(v) for v in e[2:5]) for e in _cards(formats / "adh_demo.3dm", "E3T")}
    faces = mesh_face_nodes(ds)
    got = {int(fid): sorted(ds.mesh2d_node_id.values[f].tolist()) for fid, f in zip(ds.mesh2d_face_id.values, faces)}
    assert got == elems
    mats = {int(e[1]): int(e[5]) for e in _cards(formats / "adh_demo.3dm", "E3T")}
    assert dict(zip(ds.mesh2d_face_id.values.tolist(), ds.material.values.tolist())) == mats
    x, y = ds.mesh2d_node_x.values, ds.mesh2d_node_y.values
    a, b, c = faces.T
    assert (((x[b] - x[a]) * (y[c] - y[a]) - (x[c] - x[a]) * (y[b] - y[a])) > 0).all()  # UGRID: anticlockwise
    dep = _dat_steps(formats / "adh_demo_dep.dat")["Depth"]
    vel = _dat_steps(formats / "adh_demo_vel.dat")["Depth-Averaged Velocity"]
    np.testing.assert_allclose(ds.time.values, [t for t, _, _ in dep])
    for k, ((_, _, h), (_, _, uv)) in enumerate(zip(dep, vel)):
        h = h[:, 0]
        wet = h > 0
        np.testing.assert_allclose(ds.depth.values[k], np.where(wet, h, 0.0))
        np.testing.assert_array_equal(ds.wet.values[k], wet)
        np.testing.assert_allclose(ds.u.values[k], np.where(wet, uv[:, 0], 0.0))
        np.testing.assert_allclose(ds.v.values[k], np.where(wet, uv[:, 1], 0.0))
        np.testing.assert_allclose(ds.water_surface.values[k], xyz[order, 2] + np.where(wet, h, 0.0))
    assert ds.attrs["source_length_unit"] == "m" and "MP G 9.81" in ds.attrs["source_length_unit_from"]
    assert ds.mesh2d.attrs["cf_role"] == "mesh_topology" and ds.mesh2d_face_nodes.attrs["start_index"] == 0


def test_sms_multi_dataset_with_status_flags_julian_time_and_feet(formats):
    ds = open_snapshot([formats / "adh_demo.3dm", formats / "sms_demo_multi.dat"], units="ft")
    validate_snapshot(ds)
    steps = _dat_steps(formats / "sms_demo_multi.dat")
    wse = steps["Water Surface Elevation"]
    vel = steps["Velocity"]
    z = np.array([float(n[4]) for n in _cards(formats / "adh_demo.3dm", "ND")])
    # RT_JULIAN 2460310.5 is 2024-01-01T00:00 UTC; TIMEUNITS HOURS
    np.testing.assert_array_equal(ds.time.values, np.array(["2024-01-01T00:00", "2024-01-01T01:00"], dtype="datetime64[ns]"))
    faces = mesh_face_nodes(ds)
    for k, ((_, stat, w), (_, _, uv)) in enumerate(zip(wse, vel)):
        np.testing.assert_array_equal(ds.face_active.values[k], stat)
        touching = np.zeros(z.size, bool)
        touching[faces[np.array(stat, bool)].ravel()] = True
        depth = w[:, 0] - z
        wet = (depth > 0) & touching
        np.testing.assert_allclose(ds.depth.values[k], np.where(wet, depth, 0.0) * FT, atol=1e-12)
        np.testing.assert_allclose(ds.u.values[k], np.where(wet, uv[:, 0], 0.0) * FT)
        np.testing.assert_allclose(ds.bed_elevation.values, z * FT)
    assert ds.depth.values[0].max() == pytest.approx(0.9 * FT)


def test_adh_units_are_required_or_inferred(formats, tmp_path):
    with pytest.raises(InputError, match="carry no units"):
        open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat"])
    bc = tmp_path / "ft.bc"
    bc.write_text((formats / "adh_demo.bc").read_text().replace("MP G 9.81", "MP G 32.174"))
    ds = open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", bc])
    assert ds.attrs["source_length_unit"] == "ft"
    assert ds.depth.values[1].max() == pytest.approx(1.35 * FT)
    with pytest.raises(InputError, match="not a length unit"):
        open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat"], units="s")


def _asc(path):
    lines = path.read_text().split("\n")
    head = {ln.split()[0].lower(): float(ln.split()[1]) for ln in lines[:6]}
    vals = np.array([[float(v) for v in ln.split()] for ln in lines[6:] if ln.strip()])
    return head, vals


def test_esri_ascii_grids_match_the_file_text(formats):
    ds = open_snapshot([formats / "depth_max.asc", formats / "velocity_max.asc"], units="ft", bed="10 ft",
                       velocity_direction=90.0)
    validate_snapshot(ds)
    hd, dvals = _asc(formats / "depth_max.asc")
    hv, vvals = _asc(formats / "velocity_max.asc")
    # depth_max gives the lower-left corner, velocity_max the lower-left centre: the same grid
    assert hd["xllcorner"] + hd["cellsize"] / 2 == hv["xllcenter"]
    np.testing.assert_allclose(ds.x.values, (hv["xllcenter"] + 100.0 * np.arange(5)) * FT)
    np.testing.assert_allclose(ds.y.values, (hv["yllcenter"] + 100.0 * np.arange(4)) * FT)
    d = np.where(dvals == -9999, 0.0, dvals)[::-1]  # first data row is the northern one
    sp = np.where(vvals == -9999, 0.0, vvals)[::-1]
    np.testing.assert_allclose(ds.depth.values, d * FT)
    np.testing.assert_allclose(ds.v.values, np.where(d > 0, sp, 0.0) * FT, atol=1e-15)
    np.testing.assert_allclose(ds.u.values, 0.0, atol=1e-15)
    np.testing.assert_allclose(ds.bed_elevation.values, 10 * FT)
    # the northern row, third column holds 0.42 ft in the file
    assert ds.depth.sel(x=ds.x[2], y=ds.y[-1]).item() == pytest.approx(0.42 * FT)


def test_esri_ascii_needs_units_bed_and_direction(formats, tmp_path):
    with pytest.raises(InputError, match="carry no units"):
        open_snapshot(formats / "depth_max.asc")
    with pytest.raises(InputError, match="bed elevation is unknown"):
        open_snapshot(formats / "depth_max.asc", units="ft")
    with pytest.raises(InputError, match="velocity_direction"):
        open_snapshot([formats / "depth_max.asc", formats / "velocity_max.asc"], units="ft", bed="0 ft")
    prj = tmp_path / "depth_max.prj"
    prj.write_text('PROJCS["NAD83 / Texas South Central (ftUS)",GEOGCS["NAD83",DATUM["North_American_Datum_1983",'
                   'SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],'
                   'PROJECTION["Lambert_Conformal_Conic_2SP"],UNIT["US survey foot",0.304800609601219]]')
    asc = tmp_path / "depth_max.asc"
    asc.write_bytes((formats / "depth_max.asc").read_bytes())
    with pytest.warns(BreachflowWarning, match="no velocity grid"):
        ds = open_snapshot(asc, bed="0 ft")  # units from the .prj beside the grid
    assert ds.attrs["source_length_unit"] == "survey_foot"
    assert "grid_mapping" in ds.depth.attrs
    # the stored CRS (WKT GDAL reads) is the .prj's projection with metre axes, like the stored
    # coordinates (tests/output/test_crs.py checks that points land alike with a complete CRS)
    from pyproj import CRS

    stored, given = CRS.from_wkt(ds.crs.attrs["crs_wkt"]), CRS.from_wkt(prj.read_text())
    assert [a.unit_name for a in stored.axis_info] == ["metre", "metre"]
    assert stored.coordinate_operation == given.coordinate_operation
    assert stored.datum == given.datum and stored.ellipsoid == given.ellipsoid


def test_hec_ras_sdf_matches_the_file_text(formats):
    ds = open_snapshot(formats / "RASExport.sdf")
    validate_snapshot(ds)
    assert ds.attrs["source_length_unit"] == "ft"  # UNITS: US CUSTOMARY
    assert list(ds.profile_name.values) == ["PF 1", "PF 2"]
    x, y = ds.mesh2d_node_x.values / FT, ds.mesh2d_node_y.values / FT
    # the thalweg of the first section: (2025100, 13712200, 849.00), WSE 852.40 / 854.10, velocity 2.64 / 3.37 at 0.5
    k = int(np.argmin(np.hypot(x - 2025100.0, y - 13712200.0)))
    assert np.hypot(x[k] - 2025100.0, y[k] - 13712200.0) < 1e-6
    assert ds.bed_elevation.values[k] / FT == pytest.approx(849.0)
    np.testing.assert_allclose(ds.depth.values[:, k] / FT, [852.40 - 849.0, 854.10 - 849.0])
    speed = np.hypot(ds.u.values[:, k], ds.v.values[:, k]) / FT
    np.testing.assert_allclose(speed, [2.64, 3.37])
    # flow is normal to the cut line (which runs NE -> SW) and downstream along the reach (towards SE)
    np.testing.assert_allclose(ds.u.values[:, k], -ds.v.values[:, k])
    assert (ds.u.values[:, k] > 0).all()
    # second section, fraction 0.4 of the cut line: velocity 1.98 (PF 1)
    cut0, cut1 = np.array([2025406.07, 13712106.07]), np.array([2025193.93, 13711893.93])
    p = cut0 + 0.4 * (cut1 - cut0)
    k = int(np.argmin(np.hypot(x - p[0], y - p[1])))
    assert np.hypot(*(np.array([x[k], y[k]]) - p)) < 0.01
    assert np.hypot(ds.u.values[0, k], ds.v.values[0, k]) / FT == pytest.approx(1.98)
    # between the sections the field is the barycentric interpolation of the two sections
    mid = FieldSampler(ds, time_index=0).sample([(2025100 + 2025300) / 2 * FT], [(13712200 + 13712000) / 2 * FT])
    assert mid.inside[0]
    assert mid.surface[0] / FT == pytest.approx((852.40 + 851.55) / 2)


def test_every_sample_round_trips_through_netcdf(formats, tmp_path):
    cases = [
        [formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"],
        [formats / "adh_demo.3dm", formats / "sms_demo_multi.dat"],
        [formats / "RASExport.sdf"],
        [formats / "depth_max.asc", formats / "velocity_max.asc"],
    ]
    opts = [{}, {"units": "ft"}, {}, {"units": "ft", "bed": "0 ft", "velocity_direction": 0.0}]
    for k, (files, o) in enumerate(zip(cases, opts)):
        ds = open_snapshot(files, **o)
        out = write_snapshot(ds, tmp_path / f"s{k}.nc")
        back = read_snapshot(out)
        for name in ("depth", "u", "v", "bed_elevation", "water_surface"):
            np.testing.assert_array_equal(back[name].values, ds[name].values)
        assert back.attrs["source_files"] == ds.attrs["source_files"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s0.nc", "s1.nc", "s2.nc", "s3.nc"]  # no temp files left


def test_write_is_atomic_and_validates_first(formats, tmp_path):
    ds = open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
    out = write_snapshot(ds, tmp_path / "s.nc")
    before = out.read_bytes()
    bad = ds.copy(deep=True)
    bad["depth"].attrs["units"] = "ft"
    with pytest.raises(Exception, match="units 'ft'"):
        write_snapshot(bad, out)
    assert out.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["s.nc"]


def test_format_guessing_and_registry(formats):
    assert guess_format([formats / "a.3dm", formats / "a.dat"]) == "adh"
    assert guess_format([formats / "RASExport.sdf"]) == "sdf"
    assert guess_format([formats / "x.asc", formats / "x.prj"]) == "asc"
    assert {"adh", "sdf", "asc"} <= set(READERS.available())
    with pytest.raises(InputError, match="cannot tell the format"):
        guess_format([formats / "x.txt"])
    with pytest.raises(InputError, match="does not exist"):
        open_snapshot(formats / "missing.3dm")


def test_plausibility_names_variable_location_and_value(formats, tmp_path):
    # velocities written in cm/s but declared m/s: 104.8 "m/s" at node id 2
    vel = tmp_path / "vel.dat"
    lines = (formats / "adh_demo_vel.dat").read_text().splitlines()
    lines = [(" ".join(f"{float(v) * 100:.6e}" for v in ln.split()) if ln[:1] == " " else ln) for ln in lines]
    vel.write_text("\n".join(lines) + "\n")
    files = [formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", vel, formats / "adh_demo.bc"]
    with pytest.raises(InputError, match=r"u, v: implausible speed 104\.8 m/s at time step 1 .*node 1 \(id 2\) at x=512300 m, y=4\.17822e\+06 m"):
        open_snapshot(files)
    with pytest.warns(BreachflowWarning, match="implausible speed 104.8"):
        open_snapshot(files, plausibility="warn")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        open_snapshot(files, plausibility="off")
    # 500 m depth
    dep = tmp_path / "dep.dat"
    dep.write_text((formats / "adh_demo_dep.dat").read_text().replace("1.35000000e+00", "5.00000000e+02"))
    with pytest.raises(InputError, match=r"depth: implausible water depth 500 m at time step 1"):
        open_snapshot([formats / "adh_demo.3dm", dep, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])


def test_cli_ingest_and_inspect(formats, tmp_path):
    from breachflow.cli import app

    out = tmp_path / "snap.nc"
    files = [str(formats / n) for n in ("adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc")]
    r = CliRunner().invoke(app, ["ingest", *files, "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert "12 nodes, 14 faces" in r.output and "0 .. 1.35 m" in r.output and "2: 0 .. 3600 s" in r.output
    r = CliRunner().invoke(app, ["inspect", str(out)])
    assert r.exit_code == 0 and "UGRID mesh" in r.output
    r = CliRunner().invoke(app, ["ingest", str(formats / "depth_max.asc"), str(formats / "velocity_max.asc"),
                                 "-o", str(tmp_path / "g.nc"), "--units", "ft", "--bed", "0 ft", "--velocity-direction", "0"])
    assert r.exit_code == 0, r.output
    assert "5 x 4 = 20 cells" in r.output
    r = CliRunner().invoke(app, ["ingest", str(formats / "depth_max.asc"), "-o", str(tmp_path / "h.nc")])
    assert r.exit_code != 0 and isinstance(r.exception, InputError)
    assert not (tmp_path / "h.nc").exists()


def test_xarray_reads_the_ugrid_file_as_plain_netcdf(formats, tmp_path):
    """The written mesh carries the UGRID 1.0 topology attributes other tools look for."""
    import netCDF4

    ds = open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
    out = write_snapshot(ds, tmp_path / "m.nc")
    with netCDF4.Dataset(out) as nc:
        topo = nc["mesh2d"]
        assert topo.cf_role == "mesh_topology" and int(topo.topology_dimension) == 2
        assert topo.node_coordinates == "mesh2d_node_x mesh2d_node_y"
        fn = nc[topo.face_node_connectivity]
        assert fn.cf_role == "face_node_connectivity" and int(fn.start_index) == 0
        assert fn.dimensions == (topo.face_dimension, "max_face_nodes")
        assert nc["depth"].mesh == "mesh2d" and nc["depth"].location == "node"
        assert nc.Conventions == "CF-1.8 UGRID-1.0"


def test_inspect_rows_read_as_a_user_reads_them(formats):
    """The summary's extent keeps a projected northing to the centimetre (the ADH demo's nodes lie at
    y = 4,178,200 .. 4,178,230 m in its .3dm, not '4.1782e+06 .. 4.17823e+06'), dates print to the second,
    and the profiles of a steady HEC-RAS export are named as profiles, not given a unit '1'."""
    import xarray as xr

    from breachflow.cli.ingest import summary_rows

    adh = dict(summary_rows(open_snapshot([formats / n for n in ("adh_demo.3dm", "adh_demo_dep.dat",
                                                                  "adh_demo_vel.dat", "adh_demo.bc")])))
    assert adh["extent"] == "x 512300 .. 512360 m, y 4178200 .. 4178230 m"
    assert adh["time steps"] == "2: 0 .. 3600 s"
    sdf = dict(summary_rows(open_snapshot([formats / "RASExport.sdf"])))
    assert sdf["time steps"].startswith("2: 0 .. 1 (profile") and " 1 1" not in sdf["time steps"]
    assert "e+" not in sdf["extent"]
    dated = xr.Dataset(coords={"time": np.array(["1900-01-02T00:00", "1900-01-02T04:00"], dtype="datetime64[ns]")})
    from breachflow.cli.ingest import _time_steps

    assert _time_steps(dated["time"]) == "2: 1900-01-02T00:00:00 .. 1900-01-02T04:00:00"
