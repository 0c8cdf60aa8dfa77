"""Malformed and awkward-but-valid variants of the samples: errors name the file and the line."""
import warnings

import numpy as np
import pytest

from breachflow import InputError
from breachflow.errors import BreachflowWarning, ParseError
from breachflow.io import open_snapshot
from breachflow.io.adh import read_dat, read_mesh
from breachflow.io.asc import read_asc
from breachflow.io.sdf import read_sdf


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    return p


def _lines(path):
    return path.read_text().splitlines()


def _err(exc_info, path, line):
    e = exc_info.value
    assert e.path == str(path), e
    assert e.line == line, e


# ---------------------------------------------------------------- mesh

def test_mesh_pitfalls_parse_to_the_same_mesh(formats, tmp_path):
    ref = read_mesh(formats / "adh_demo.3dm")
    lines = _lines(formats / "adh_demo.3dm")
    nodes = [ln for ln in lines if ln.startswith("ND")]
    elems = [ln for ln in lines if ln.startswith("E3T")]
    # nodes first, shuffled, comments, CRLF, extra trailing columns, TRI synonym, 2DM extras
    rng = np.random.default_rng(0)
    body = ["MESH2D 12 14", "# comment", "MESHNAME 'demo_reach'", "NUM_MATERIALS_PER_ELEM 1",
            *[nodes[i] + " 0.0" for i in rng.permutation(len(nodes))], "! adh comment",
            "BEGPARAMDEF", "GM  \"Mesh\"", "ND 99 1 2 3", "ENDPARAMDEF",
            *[("TRI" + e[3:] if k % 2 else e) for k, e in enumerate(elems)],
            "NS 1 2", "3 -4 upstream", "BEG2DMBC", "BC 1 2", "END2DMBC"]
    p = _write(tmp_path, "v.2dm", "\r\n".join(body) + "\r\n")
    m = read_mesh(p)
    np.testing.assert_array_equal(m.node_ids, ref.node_ids)
    np.testing.assert_array_equal(m.faces, ref.faces)
    np.testing.assert_allclose(m.z, ref.z)
    assert m.name == "demo_reach"


def test_mesh_with_id_gaps_maps_ids_to_indices(tmp_path):
    text = "MESH2D\nE3T 7 10 30 20 1\nND 30 1 1 0\nND 10 0 0 0\nND 20 0 1 0\n"
    m = read_mesh(_write(tmp_path, "g.3dm", text))
    np.testing.assert_array_equal(m.node_ids, [10, 20, 30])
    np.testing.assert_array_equal(m.faces, [[0, 2, 1]])


def test_long_runs_use_the_fast_path_with_identical_results(tmp_path):
    n = 50
    nodes = [f"ND {i + 1} {i % 10}.0 {i // 10}.5 {i * 0.01:.2f}" for i in range(n)]
    elems = [f"E3T {k + 1} {k + 1} {k + 2} {k + 11} 1" for k in range(30)]
    fast = read_mesh(_write(tmp_path, "a.3dm", "MESH2D\n" + "\n".join(elems + nodes) + "\n"))
    # the same cards with leading blanks go through the per-line path
    slow = read_mesh(_write(tmp_path, "b.3dm", "MESH2D\n" + "\n".join(" " + ln for ln in elems + nodes) + "\n"))
    np.testing.assert_array_equal(fast.faces, slow.faces)
    np.testing.assert_array_equal(fast.z, slow.z)
    np.testing.assert_allclose(fast.y[:12], [0.5] * 10 + [1.5] * 2)


@pytest.mark.parametrize("edit, line, match", [
    (lambda L: L[:16] + ["ND 2 5 5 5"] + L[16:], 19, "duplicate node id 2 \\(first defined at line 17\\)"),
    (lambda L: L[:2] + ["E3T 1 4 2 99 1"] + L[3:], 3, "references node id 99"),
    (lambda L: L[:20] + ["ND 7 5.0x 4.1 1.0"] + L[21:], 21, "non-numeric|expected a number"),
    (lambda L: L[:20] + ["ND 7 5.0 4.1"] + L[21:], 21, "expected 4 values, found 3"),
    (lambda L: L[:5] + ["E3T 4 6 4 6 2"] + L[6:], 6, "repeats a node"),
    (lambda L: L[:5] + ["E3T 3 6 4 1 2"] + L[6:], 6, "duplicate element id 3"),
    (lambda L: L[:5] + ["17 18 19"] + L[6:], 6, "unexpected numeric line"),
    (lambda L: ["MESH3D"] + L[1:], 1, "expected MESH2D"),
    (lambda L: L[:3] + ["E3T 1.5 4 2 1 1"] + L[3:], 4, "not an integer"),
])
def test_malformed_mesh_raises_parse_error_with_line(formats, tmp_path, edit, line, match):
    lines = _lines(formats / "adh_demo.3dm")
    p = _write(tmp_path, "bad.3dm", "\n".join(edit(lines)) + "\n")
    with pytest.raises(ParseError, match=match) as ei:
        read_mesh(p)
    _err(ei, p, line)
    assert str(ei.value).startswith(f"{p}:{line}: ")


def test_unknown_mesh_card_strict_and_lenient(formats, tmp_path):
    lines = _lines(formats / "adh_demo.3dm")
    p = _write(tmp_path, "u.3dm", "\n".join(lines[:2] + ["FOO 1 2"] + lines[2:]) + "\n")
    with pytest.raises(ParseError, match="unknown card 'FOO'") as ei:
        read_mesh(p, strict=True)
    _err(ei, p, 3)
    assert read_mesh(p).ignored_cards == {"FOO": 1}


def test_mesh_without_nodes_or_elements(tmp_path):
    with pytest.raises(ParseError, match="no ND"):
        read_mesh(_write(tmp_path, "a.3dm", "MESH2D\nE3T 1 1 2 3 1\n"))
    with pytest.raises(ParseError, match="no 2-D elements"):
        read_mesh(_write(tmp_path, "b.3dm", "MESH2D\nND 1 0 0 0\n"))
    with pytest.raises(ParseError, match="empty file"):
        read_mesh(_write(tmp_path, "c.3dm", ""))


# ---------------------------------------------------------------- datasets

def test_dat_missing_endds_and_partial_last_step(formats, tmp_path):
    lines = _lines(formats / "adh_demo_dep.dat")
    p = _write(tmp_path, "crash_dep.dat", "\n".join(lines[:-1 - 5]) + "\n")  # no ENDDS, last step has 7 of 12 values
    with pytest.warns(BreachflowWarning, match=r"crash_dep.dat:21: partial last time step \(7 of 12 lines\) dropped; kept 1"):
        ds = read_dat(p)
    assert ds[0].times == [0.0] and ds[0].partial_step_line == 21 and not ds[0].complete
    q = _write(tmp_path, "noend_dep.dat", "\n".join(lines[:-1]) + "\n")
    with pytest.warns(BreachflowWarning, match="no ENDDS"):
        assert read_dat(q)[0].times == [0.0, 3600.0]
    # a crashed velocity file with the complete depth file: the common steps are used
    vel = _lines(formats / "adh_demo_vel.dat")
    v = _write(tmp_path, "crash_vel.dat", "\n".join(vel[:-4]) + "\n")
    with pytest.warns(BreachflowWarning):
        snap = open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", v, formats / "adh_demo.bc"])
    assert snap.sizes["time"] == 1


@pytest.mark.parametrize("edit, line, match", [
    (lambda L: L[:8] + L[9:], 20, "time step at line 8 has 11 value line\\(s\\), expected 12 \\(found card 'TS'\\)"),
    (lambda L: L[:10] + ["  9.0e-01x"] + L[11:], 11, "non-numeric token '9.0e-01x'"),
    (lambda L: L[:10] + ["  nan"] + L[11:], 11, "not finite"),
    (lambda L: L[:7] + ["TS 0 abc"] + L[8:], 8, "TS card time: expected a number"),
    (lambda L: L[:20] + ["TS 0 0.0"] + L[21:], 21, "does not increase"),
    (lambda L: ["DATASET"] + ["BEGSCL", "NC 14", "NAME x", "TS 0 0"], 5, "before the ND count card"),
    (lambda L: L[:6] + ["TIMEUNITS FORTNIGHTS"] + L[7:], 7, "unknown TIMEUNITS"),
    (lambda L: L[:-1] + ["BEGSCL"], 34, "new dataset before ENDDS"),
    (lambda L: ["GARBAGE"] + L[1:], 1, "not an SMS ASCII dataset"),
    (lambda L: L[:20] + ["TS 2 3600"] + L[21:], 21, "status flag 2 must be 0 or 1"),
    (lambda L: L[:3] + ["ND -4"] + L[4:], 4, "negative"),
])
def test_malformed_dat_raises_parse_error_with_line(formats, tmp_path, edit, line, match):
    p = _write(tmp_path, "bad_dep.dat", "\n".join(edit(_lines(formats / "adh_demo_dep.dat"))) + "\n")
    with pytest.raises(ParseError, match=match) as ei:
        read_dat(p)
    _err(ei, p, line)


def test_dat_variants_two_columns_legacy_crlf_comments_units(formats, tmp_path):
    vel = _lines(formats / "adh_demo_vel.dat")
    two = [" ".join(ln.split()[:2]) if ln.startswith("  ") else ln for ln in vel]
    a = read_dat(_write(tmp_path, "two.dat", "\r\n".join(two) + "\r\n"))[0]
    b = read_dat(formats / "adh_demo_vel.dat")[0]
    np.testing.assert_array_equal(np.stack(a.values), np.stack(b.values))
    dep = _lines(formats / "adh_demo_dep.dat")
    legacy = ["SCALAR", "ND 12", "TIMEUNITS MINUTES"]
    for k, ln in enumerate(dep):
        if ln.startswith("TS"):
            legacy.append(f"TS {ln.split()[2]}")
        elif ln.startswith(" "):
            legacy.append(ln)
    c = read_dat(_write(tmp_path, "leg_dep.dat", "\n".join(legacy) + "\n"))[0]
    assert c.times == [0.0, 3600.0] and c.seconds_per_unit() == 60.0
    np.testing.assert_array_equal(np.stack(c.values), np.stack(read_dat(formats / "adh_demo_dep.dat")[0].values))
    # numeric SMS code 0 = hours; the .bc AWRITE code fills a missing TIMEUNITS (0 = seconds in ADH codes)
    d = _write(tmp_path, "h_dep.dat", "\n".join(ln.replace("TIMEUNITS SECONDS", "TIMEUNITS 0") for ln in dep) + "\n")
    assert read_dat(d)[0].seconds_per_unit() == 3600.0
    nounit = _write(tmp_path, "n_dep.dat", "\n".join(ln for ln in dep if not ln.startswith("TIMEUNITS")) + "\n")
    nvel = _write(tmp_path, "n_vel.dat", "\n".join(ln for ln in vel if not ln.startswith("TIMEUNITS")) + "\n")
    bc = _lines(formats / "adh_demo.bc")
    bc_min = _write(tmp_path, "m.bc", "\n".join(ln.replace("SERIES AWRITE 3 1 0", "SERIES AWRITE 3 1 1") for ln in bc) + "\n")
    snap = open_snapshot([formats / "adh_demo.3dm", nounit, nvel, bc_min])
    np.testing.assert_allclose(snap.time.values, [0.0, 3600.0 * 60.0])


def test_inconsistent_depth_and_velocity_steps(formats, tmp_path):
    vel = _write(tmp_path, "x_vel.dat", (formats / "adh_demo_vel.dat").read_text().replace("TS 0  3.60000000e+03", "TS 0  1.80000000e+03"))
    with pytest.raises(ParseError, match="depth and velocity steps are inconsistent") as ei:
        open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", vel, formats / "adh_demo.bc"])
    assert ei.value.path.endswith("adh_demo_dep.dat") and ei.value.line == 21


def test_dataset_node_count_must_match_the_mesh(formats, tmp_path):
    mesh = _lines(formats / "adh_demo.3dm")
    p = _write(tmp_path, "small.3dm", "\n".join(ln for ln in mesh if not ln.startswith("ND 12") and not ln.startswith("E3T 11")
                                                  and not ln.startswith("E3T 14") and not ln.startswith("NS 10")) + "\n")
    with pytest.raises(ParseError, match="ND=12 node values but the mesh small.3dm has 11 nodes"):
        open_snapshot([p, formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])


def test_bc_with_implausible_gravity(formats, tmp_path):
    bc = _write(tmp_path, "g.bc", (formats / "adh_demo.bc").read_text().replace("MP G 9.81", "MP G 1.62"))
    with pytest.raises(ParseError, match="MP G 1.62 is neither") as ei:
        open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", bc])
    assert ei.value.line == 14


# ---------------------------------------------------------------- ascii grids

@pytest.mark.parametrize("edit, line, match", [
    (lambda L: L[:-1], 9, "expected nrows x ncols = 20 values, found 15"),
    (lambda L: L[:7] + ["-9999 0.35 2.96 4.12 0.61 7.0"] + L[8:], 10, "more than nrows x ncols"),  # a flat stream: the 21st value is on line 10
    (lambda L: L[:8] + ["0.18 2.74 4.85 2.33 abc"] + L[9:], 9, "non-numeric grid value 'abc'"),
    (lambda L: L[:1] + L[2:], 6, "lacks nrows"),
    (lambda L: L[:4] + ["cellsize -100"] + L[5:], 6, "must be positive"),
    (lambda L: L[:5] + ["nodata 0"] + L[6:], 6, "unknown header keyword 'nodata'"),
])
def test_malformed_asc_raises_parse_error_with_line(formats, tmp_path, edit, line, match):
    p = _write(tmp_path, "depth.asc", "\n".join(edit(_lines(formats / "depth_max.asc"))) + "\n")
    with pytest.raises(ParseError, match=match) as ei:
        read_asc(p)
    _err(ei, p, line)


def test_asc_grids_must_share_geometry(formats, tmp_path):
    v = _write(tmp_path, "velocity.asc", (formats / "velocity_max.asc").read_text().replace("XLLCENTER 2025050.0", "XLLCENTER 2025000.0"))
    with pytest.raises(InputError, match="differ in size, origin or cell size"):
        open_snapshot([formats / "depth_max.asc", v], units="ft", bed="0 ft", velocity_direction=0)


# ---------------------------------------------------------------- sdf

def test_sdf_keywords_are_matched_exactly_not_by_substring(formats, tmp_path):
    text = (formats / "RASExport.sdf").read_text()
    # Windows paths with colons and a keyword without a space after the colon
    text = text.replace("DTM: Terrain\\Terrain.hdf", "DTM: C:\\RAS\\Terrain.hdf").replace("STATION: 858.6", "STATION:858.6")
    data = read_sdf(_write(tmp_path, "x.sdf", text))
    assert data.header["DTM"] == "C:\\RAS\\Terrain.hdf"
    assert [xs.station for xs in data.sections] == [858.6, 575.7]
    assert data.sections[1].station_text == "575.7*"
    assert data.header["CROSS-SECTION LAYER"] == "Bear_Creek_XS.shp"
    assert data.reaches[0].centerline[1] == (2025200.0, 13712100.0)  # NULL elevation allowed


@pytest.mark.parametrize("old, new, marker, match", [
    ("WATER ELEVATION: 852.40, 854.10", "WATER ELEVATION: 852.40", "WATER ELEVATION: 852.40\n", "1 water elevations for 2 profiles"),
    ("      0.400, 1.85", "      0.400; 1.85", "0.400; 1.85", "non-numeric value '0.400;'"),
    ("      0.400, 1.85", "      1.400, 1.85", "1.400, 1.85", "not a fraction"),
    ("STATION: 575.7*", "STATION: abc", "STATION: abc", "river station 'abc'"),
    ("  END:\n\nEND CROSS-SECTIONS:", "\nEND CROSS-SECTIONS:", "END CROSS-SECTIONS:", "before the END: of the open CROSS-SECTION"),
    ("      2025163.64, 13712263.64, 855.00", "      2025163.64, 13712263.64", "13712263.64\n", "surface-line point"),
    ("BEGIN CROSS-SECTIONS:", "BEGIN CROSS-SECTIONS:\nCROSS-SECTION LAYER: x.shp", "CROSS-SECTION LAYER: x", "CROSS-SECTION LAYER outside its block|unexpected"),
])
def test_malformed_sdf_raises_parse_error_with_line(formats, tmp_path, old, new, marker, match):
    text = (formats / "RASExport.sdf").read_text()
    assert old in text
    bad = text.replace(old, new, 1)
    p = _write(tmp_path, "bad.sdf", bad)
    with pytest.raises(ParseError, match=match) as ei:
        read_sdf(p, strict=True)
    _err(ei, p, bad[:bad.index(marker)].count("\n") + 1)


def test_sdf_metric_units_and_timestamp_profiles(formats, tmp_path):
    text = (formats / "RASExport.sdf").read_text().replace("US CUSTOMARY", "METRIC")
    text = text.replace("   PF 1\n   PF 2", "   01JAN2020 0100\n   01JAN2020 0200").replace("PROFILE ID: PF 1", "PROFILE ID: 01JAN2020 0100")
    text = text.replace("PROFILE ID: PF 2", "PROFILE ID: 01JAN2020 0200")
    ds = open_snapshot(_write(tmp_path, "m.sdf", text))
    assert ds.attrs["source_length_unit"] == "m"
    np.testing.assert_array_equal(ds.time.values, np.array(["2020-01-01T01:00", "2020-01-01T02:00"], dtype="datetime64[ns]"))
    assert ds.depth.values.max() == pytest.approx(854.10 - 849.0)


def test_no_warnings_on_clean_samples(formats):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
        open_snapshot(formats / "RASExport.sdf")
        open_snapshot([formats / "adh_demo.3dm", formats / "sms_demo_multi.dat"], units="m")


def test_quads_six_node_triangles_element_values_and_id_order(tmp_path):
    # 2 x 3 nodes: one E4Q, one E6T whose corners are nodes 1, 3, 5 of its six; ids with gaps
    mesh = "\n".join([
        "MESH2D",
        "E4Q 1 10 20 50 40 1",
        "E6T 2 20 25 30 55 50 22 1",
        "ND 10 0 0 1", "ND 20 1 0 1", "ND 30 2 0 1", "ND 40 0 1 1", "ND 50 1 1 1", "ND 55 1.5 0.5 1",
        "ND 25 1.5 0 1", "ND 22 1 0.5 1",
    ]) + "\n"
    m = read_mesh(_write(tmp_path, "q.2dm", mesh))
    ids = m.node_ids.tolist()
    assert ids == [10, 20, 22, 25, 30, 40, 50, 55]
    assert [[ids[i] for i in f if i >= 0] for f in m.faces] == [[10, 20, 50, 40], [20, 30, 50]]
    # element-centred depth (VECTYPE-like _els data via NC values): averaged to nodes
    dat = "\n".join(["DATASET", "OBJTYPE mesh2d", "BEGVEC", "VECTYPE 1", "ND 8", "NC 2", "NAME Velocity",
                     "TS 0 0", "1.0 0.0", "3.0 0.0", "ENDDS",
                     "BEGSCL", "ND 8", "NC 2", "NAME Depth", "TS 0 0", *["2.0"] * 8, "ENDDS"]) + "\n"
    ds = open_snapshot([tmp_path / "q.2dm", _write(tmp_path, "q.dat", dat)], units="m")
    u = dict(zip(ds.mesh2d_node_id.values.tolist(), ds.u.values[0].tolist()))
    assert u[10] == 1.0 and u[30] == 3.0 and u[20] == 2.0 and u[50] == 2.0  # shared nodes: mean of the two
    assert u[22] == 0.0 and u[25] == 0.0  # mid-side nodes of the E6T: in no face corner list
    assert ds.depth.values.shape == (1, 8)


def test_dataset_lines_follow_node_ids_when_nd_is_the_largest_id(tmp_path):
    mesh = "MESH2D\nE3T 1 1 2 4 1\nND 1 0 0 0\nND 2 1 0 0\nND 4 0 1 0\n"
    _write(tmp_path, "g.3dm", mesh)
    by_id = "DATASET\nBEGSCL\nND 4\nNC 1\nNAME Depth\nTS 0 0\n1.0\n2.0\n99.0\n4.0\nENDDS\n"  # line 3 = missing id 3
    with pytest.warns(BreachflowWarning, match="no velocity dataset"):
        ds = open_snapshot([tmp_path / "g.3dm", _write(tmp_path, "a_dep.dat", by_id)], units="m")
    np.testing.assert_array_equal(ds.depth.values[0], [1.0, 2.0, 4.0])
    assert (ds.u.values == 0).all()
    in_order = "DATASET\nBEGSCL\nND 3\nNC 1\nNAME Depth\nTS 0 0\n1.0\n2.0\n4.0\nENDDS\n"
    with pytest.warns(BreachflowWarning, match="no velocity dataset"):
        ds = open_snapshot([tmp_path / "g.3dm", _write(tmp_path, "b_dep.dat", in_order)], units="m")
    np.testing.assert_array_equal(ds.depth.values[0], [1.0, 2.0, 4.0])


def test_negative_depth_beyond_the_dry_convention(formats, tmp_path):
    dep = _write(tmp_path, "neg_dep.dat", (formats / "adh_demo_dep.dat").read_text().replace("  1.20000000e-01", " -6.00000000e+01", 1))
    with pytest.raises(InputError, match=r"implausible negative depth .* of minus 60 m at time step 1 .*node 5 \(id 6\)"):
        open_snapshot([formats / "adh_demo.3dm", dep, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
    shallow = _write(tmp_path, "sh_dep.dat", (formats / "adh_demo_dep.dat").read_text().replace("  1.20000000e-01", " -2.00000000e+00", 1))
    with pytest.warns(BreachflowWarning, match="negative depth"):
        ds = open_snapshot([formats / "adh_demo.3dm", shallow, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
    assert ds.depth.values[1, 5] == 0.0 and ds.u.values[1, 5] == 0.0
