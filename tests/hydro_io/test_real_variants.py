"""Issue 13: constructs real third-party files use (SMS, ADH, TUFLOW, BASEMENT, Hydro_AS-2D, LISFLOOD-FP,
GDAL, old HEC-RAS exports), each allowed by the format as those tools write it. Each test builds the
construct into a copy of a sample and checks the values read against the sample read without it.
"""
import warnings

import numpy as np
import pytest

from breachflow import InputError
from breachflow.errors import BreachflowWarning, ParseError
from breachflow.io import open_snapshot
from breachflow.io.adh import read_dat, read_mesh


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_bytes(text.encode() if isinstance(text, str) else text)
    return p


def _lines(path):
    return path.read_text().splitlines()


def _no_warnings(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return fn(*a, **k)


# ---------------------------------------------------------------- meshes

def test_node_strings_with_string_id_and_continued_ns_cards(formats, tmp_path):
    ref = read_mesh(formats / "adh_demo.3dm")
    lines = [ln for ln in _lines(formats / "adh_demo.3dm") if not ln.startswith("NS")]
    lines += ["NS 1 2 -3 1", "NS 10 11", "NS 12 4 5", "NS 6 -7 2 outflow", "NS 8 9 -10 3 'left bank'"]
    m = _no_warnings(read_mesh, _write(tmp_path, "ns.2dm", "\n".join(lines) + "\n"), strict=True)
    np.testing.assert_array_equal(m.faces, ref.faces)
    assert [(s.node_ids, s.string_id, s.name) for s in m.node_strings] == [
        ([1, 2, 3], 1, ""), ([10, 11, 12, 4, 5, 6, 7], 2, "outflow"), ([8, 9, 10], 3, "left bank")]
    assert m.ignored_cards == {}


def test_tuflow_mesh_header_card_and_extra_node_columns(formats, tmp_path):
    """TUFLOW / SMS meshes (MDAL's M01_5m_002.2dm): numbers after MESH2D, NO_MOVE_EQ9_CENTER_NODE, ND with 4 more columns."""
    ref = read_mesh(formats / "adh_demo.3dm")
    lines = _lines(formats / "adh_demo.3dm")
    out = ["MESH2D      292725.000     6177615.000  -13.165794     200     170     5.000     5.000  10.000",
           "NO_MOVE_EQ9_CENTER_NODE"] + [ln + "  2  0. 0. 0." if ln.startswith("ND") else ln for ln in lines[1:]]
    m = _no_warnings(read_mesh, _write(tmp_path, "t.2dm", "\n".join(out) + "\n"), strict=True)
    np.testing.assert_array_equal(m.faces, ref.faces)
    np.testing.assert_array_equal(m.z, ref.z)


def test_begcurve_blocks_are_skipped(formats, tmp_path):
    lines = _lines(formats / "adh_demo.3dm")
    curve = ["BEGCURVE Version: 1", "ID 1", "Units: m", "XY 2", "0.0 10.9", "7200.0 11.35", "ENDCURVE"]
    p = _write(tmp_path, "c.2dm", "\n".join(lines[:2] + curve + lines[2:]) + "\n")
    m = _no_warnings(read_mesh, p, strict=True)
    np.testing.assert_array_equal(m.faces, read_mesh(formats / "adh_demo.3dm").faces)
    bad = _write(tmp_path, "d.2dm", "\n".join(lines[:2] + curve[:-1] + lines[2:]) + "\n")
    with pytest.raises(ParseError, match="block opened at line 3 has no ENDCURVE"):
        read_mesh(bad)


# ---------------------------------------------------------------- datasets (MDAL's test files: tools' variants)

MDAL_T0, MDAL_T1 = [1.0, 2.0, 3.0, 4.0, 5.0], [6.0, 7.0, 8.0, 9.0, 10.0]


@pytest.fixture()
def mdal(formats):
    return formats / "mdal"


@pytest.mark.parametrize("name", ["old0", "old1", "old2", "old3"])
def test_old_scalar_files_with_and_without_headers(mdal, name):
    """old0: SCALAR/ND/TS; old1: starts at TS, no ND; old2: SCALAR "NaN=...", CRLF, ST card; old3: TIMEUNITS."""
    f = mdal / f"quad_and_triangle_vertex_scalar_{name}.dat"
    d = _no_warnings(read_dat, f)
    assert len(d) == 1 and d[0].nd == 5 and not d[0].vector
    np.testing.assert_array_equal(np.stack(d[0].values), [MDAL_T0, MDAL_T1])
    assert d[0].times == [0.0, 3600.0]
    ds = open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m", roles={f.name: "depth"},
                       plausibility="off") if name == "old3" else None
    if ds is not None:  # TIMEUNITS Seconds
        np.testing.assert_array_equal(ds.time.values, [0.0, 3600.0])
        np.testing.assert_array_equal(ds.depth.values, [MDAL_T0, MDAL_T1])


def test_legacy_files_repeating_the_header_before_every_step(formats, tmp_path):
    dep = _lines(formats / "adh_demo_dep.dat")
    ts = [i for i, ln in enumerate(dep) if ln.startswith("TS")]
    out = []
    for i in ts:
        out += ["SCALAR", "ND 12", "ST 0", "TIMEUNITS SECONDS", f"TS {dep[i].split()[2]}", *dep[i + 1:i + 13]]
    p = _write(tmp_path, "leg_dep.dat", "\n".join(out) + "\n")
    d = _no_warnings(read_dat, p)[0]
    ref = read_dat(formats / "adh_demo_dep.dat")[0]
    assert d.times == ref.times
    np.testing.assert_array_equal(np.stack(d.values), np.stack(ref.values))
    bad = _write(tmp_path, "bad_dep.dat", "\n".join(out).replace("ND 12", "ND 11", 2).replace("ND 11", "ND 12", 1) + "\n")
    with pytest.raises(ParseError, match="ND 11 after the first time step") as ei:
        read_dat(bad)
    assert ei.value.line == 19  # 17 lines of the first block, SCALAR, then ND
    vec = _write(tmp_path, "kind_dep.dat", "\n".join(out[:18] + ["VECTOR"] + out[19:]) + "\n")
    with pytest.raises(ParseError, match="VECTOR card in a SCALAR dataset"):
        read_dat(vec)


def test_element_centred_datasets_from_els_names_and_from_nc_value_lines(mdal, tmp_path):
    mesh = mdal / "quad_and_triangle.2dm"  # E4Q 1 (nodes 1 2 4 5), E3T 2 (nodes 2 3 4)
    sc, vc = mdal / "quad_and_triangle_els_scalar.dat", mdal / "quad_and_triangle_els_vector.dat"
    d = read_dat(sc)[0]
    assert d.on_faces and d.nc == 2 and d.values[0].tolist() == [1.0, 2.0]
    ds = open_snapshot([mesh, sc, vc], units="m", roles={"FaceScalarDataset": "depth"})
    # element values averaged to the nodes: node 1, 5 only in element 1; node 3 only in element 2
    assert ds.depth.values[0].tolist() == [1.0, 1.5, 2.0, 1.5, 1.0]
    assert ds.u.values[0].tolist() == [1.0, 1.5, 2.0, 1.5, 1.0]
    assert "FaceScalarDataset" in ds.attrs["element_centred_datasets"]
    # the same values in a file without _els in its name: NC value lines instead of ND
    p = _write(tmp_path, "faces_depth.dat", sc.read_text())
    d2 = read_dat(p)[0]
    assert d2.on_faces and d2.faces_from_count and d2.values[0].tolist() == [1.0, 2.0]
    two = _write(tmp_path, "two_depth.dat", sc.read_text().replace("ENDDS", "TS 0 7200\n3\n4\nENDDS"))
    d3 = read_dat(two)[0]
    assert d3.times == [3600.0, 7200.0] and d3.values[1].tolist() == [3.0, 4.0]


def test_tabs_as_separators(mdal):
    d = _no_warnings(read_dat, mdal / "quad_and_triangle_vertex_scalar_tabs.dat")[0]
    assert d.name == "VertexScalarDataset" and d.values[0].tolist() == [1.0, 2.0, 3.0, 2.0, 1.0]


def test_binary_sms_dataset_is_read(mdal, tmp_path):
    """MDAL's expectations for its binary sample: "Water Depth (m)", one step at t = 0, values 1, 2, ..."""
    with pytest.warns(BreachflowWarning, match="without ENDDS"):
        d = read_dat(mdal / "quad_and_triangle_binary.dat")
    assert len(d) == 1 and d[0].name == "Water Depth (m)" and not d[0].vector
    assert d[0].times == [0.0] and d[0].values[0].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert d[0].status[0].tolist() == [1, 1]
    with pytest.warns(BreachflowWarning):
        snap = open_snapshot([mdal / "quad_and_triangle.2dm", mdal / "quad_and_triangle_binary.dat"], units="m",
                             plausibility="off")
    assert snap.depth.values[0].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert "binary SMS dataset without TIMEUNITS card: hours" in snap.attrs["source_time_units"]
    # a binary vector dataset with TIMEUNITS (seconds), two steps and a TUFLOW maximum step, written here
    import struct as st

    def card(c, fmt="", *v):
        return st.pack("<i", c) + (st.pack("<" + fmt, *v) if fmt else b"")
    body = (card(3000) + card(100, "i", 3) + card(110, "i", 4) + card(120, "i", 1) + card(140) + card(150, "i", 0)
            + card(170, "i", 5) + card(180, "i", 2) + card(190) + b"Velocity".ljust(40, b"\0") + card(250, "i", 2))
    for t, k in ((0.0, 1.0), (60.0, 2.0), (99999.0, 9.0)):
        body += card(200) + b"\0" + st.pack("<f", t) + np.array([[k, -k]] * 5, dtype="<f4").tobytes()
    body += card(210)
    vel = _write(tmp_path, "v.dat", body)
    with pytest.warns(BreachflowWarning, match="99999 .*TUFLOW maxima"):
        v = read_dat(vel)[0]
    assert v.vector and v.times == [0.0, 60.0] and v.time_units == "SECONDS" and v.complete
    np.testing.assert_array_equal(v.values[1], [[2.0, -2.0]] * 5)
    big = _write(tmp_path, "b.dat", st.pack(">i", 3000) + b"\0" * 8)
    with pytest.raises(ParseError, match="big-endian binary SMS dataset .*not supported"):
        read_dat(big)
    with pytest.raises(ParseError, match="binary file"):
        read_dat(_write(tmp_path, "x.dat", b"DATASET\0\0\1\2"))
    trunc = _write(tmp_path, "t.dat", body[:-30])
    with pytest.raises(ParseError, match="ends inside the values of the step"):
        read_dat(trunc)


# ---------------------------------------------------------------- roles and time units

def test_dataset_roles_option_for_names_that_are_not_adh_s(mdal, formats, tmp_path):
    f = mdal / "quad_and_triangle_vertex_scalar_tabs.dat"
    with pytest.raises(InputError, match=r"no depth or water-surface dataset.*'VertexScalarDataset'.*roles="):
        open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m")
    ds = open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m", roles={"VertexScalarDataset": "depth"})
    assert ds.depth.values[0].tolist() == [1.0, 2.0, 3.0, 2.0, 1.0]
    ds = open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m", roles={f.name: "water_surface"}, plausibility="off")
    np.testing.assert_allclose(ds.depth.values[0], np.maximum(np.array([1.0, 2, 3, 2, 1]) - [20, 30, 40, 50, 10], 0))
    # national-language names
    dep = (formats / "adh_demo_dep.dat").read_text()
    for name in ("Wassertiefe", "Hauteur d'eau", "Calado", "Tirante"):
        p = _write(tmp_path, "x.dat", dep.replace('"Depth"', f'"{name}"'))
        snap = open_snapshot([formats / "adh_demo.3dm", p, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
        assert snap.attrs["source_datasets"].startswith(f"depth: {name}")
    with pytest.raises(InputError, match="choose one of"):
        open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m", roles={f.name: "speed"})
    with pytest.raises(InputError, match="no dataset named 'Nope'"):
        open_snapshot([mdal / "quad_and_triangle.2dm", f], units="m", roles={"Nope": "depth"})


def test_old_depth_is_not_taken_for_the_current_depth(formats, tmp_path):
    dep = (formats / "adh_demo_dep.dat").read_text()
    body = dep.split("BEGSCL", 1)[1]
    old = body.replace('"Depth"', '"Old Depth"').replace("1.35000000e+00", "9.99000000e-01")
    both = _write(tmp_path, "both_dep.dat", dep.split("BEGSCL", 1)[0] + "BEGSCL" + old + "BEGSCL" + body)
    files = [formats / "adh_demo.3dm", both, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"]
    with pytest.warns(BreachflowWarning, match="'Old Depth' looks like a previous step.*ignored, 'Depth' is used"):
        snap = open_snapshot(files)
    assert snap.depth.values[1].max() == pytest.approx(1.35)
    only = _write(tmp_path, "old_dep.dat", dep.split("BEGSCL", 1)[0] + "BEGSCL" + old)
    with pytest.warns(BreachflowWarning, match="only depth dataset: used as depth"):
        open_snapshot([formats / "adh_demo.3dm", only, formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])


def test_missing_timeunits_says_which_default_and_records_it(formats, tmp_path):
    dep = "\n".join(ln for ln in _lines(formats / "adh_demo_dep.dat") if not ln.startswith("TIMEUNITS")) + "\n"
    vel = "\n".join(ln for ln in _lines(formats / "adh_demo_vel.dat") if not ln.startswith("TIMEUNITS")) + "\n"
    files = [formats / "adh_demo.3dm", _write(tmp_path, "n_dep.dat", dep), _write(tmp_path, "n_vel.dat", vel)]
    with pytest.warns(BreachflowWarning, match="no TIMEUNITS card .* taken as seconds .*MDAL/QGIS assume hours"):
        snap = open_snapshot(files, units="m")
    np.testing.assert_array_equal(snap.time.values, [0.0, 3600.0])
    assert "seconds by default" in snap.attrs["source_time_units"]
    snap = _no_warnings(open_snapshot, files, units="m", time_units="hours")
    np.testing.assert_array_equal(snap.time.values, [0.0, 3600.0 * 3600.0])
    assert "hours (time_units option)" in snap.attrs["source_time_units"]
    snap = open_snapshot([formats / "adh_demo.3dm", formats / "adh_demo_dep.dat", formats / "adh_demo_vel.dat", formats / "adh_demo.bc"])
    assert "SECONDS (TIMEUNITS card, adh_demo_dep.dat line 7)" in snap.attrs["source_time_units"]


# ---------------------------------------------------------------- ESRI ASCII grids

def test_grids_with_other_extensions_nan_nodata_and_nan_cells(formats, tmp_path):
    ref = open_snapshot([formats / "depth_max.asc", formats / "velocity_max.asc"], units="ft", bed="0 ft", velocity_direction=0)
    dep = (formats / "depth_max.asc").read_text()
    # GDAL's float grids: NODATA_value nan and nan cells
    nan = dep.replace("NODATA_value -9999", "NODATA_value nan").replace("-9999", "nan")
    wd = _write(tmp_path, "res-0001.wd", nan)        # LISFLOOD-FP depth
    txt = _write(tmp_path, "speed.txt", (formats / "velocity_max.asc").read_text().replace("-9999", "NaN"))
    snap = _no_warnings(open_snapshot, [wd, txt], units="ft", bed="0 ft", velocity_direction=0,
                        roles={"speed.txt": "speed"})
    np.testing.assert_array_equal(snap.depth.values, ref.depth.values)
    np.testing.assert_array_equal(snap.u.values, ref.u.values)
    # format given instead of roles / a known suffix
    t2 = _write(tmp_path, "depth_map.txt", dep)
    snap = open_snapshot([t2], format="asc", units="ft", bed="0 ft", plausibility="off")
    np.testing.assert_array_equal(snap.depth.values, ref.depth.values)
    with pytest.raises(InputError, match="cannot tell the format"):
        open_snapshot([t2], units="ft", bed="0 ft")
    inf = _write(tmp_path, "depth_inf.asc", dep.replace("0.42", "inf"))
    with pytest.raises(ParseError, match="'inf' is not finite") as ei:
        open_snapshot([inf], units="ft", bed="0 ft")
    assert ei.value.line == 7


# ---------------------------------------------------------------- HEC-RAS sdf

def test_sdf_keywords_without_spaces_and_water_surface_extents(formats, tmp_path):
    from breachflow.io.sdf import read_sdf

    text = (formats / "RASExport.sdf").read_text()
    ref = open_snapshot(formats / "RASExport.sdf")
    var = (text.replace("BEGIN STREAM NETWORK:", "BEGINSTREAMNETWORK:").replace("END STREAM NETWORK:", "ENDSTREAMNETWORK:")
           .replace("BEGIN SPATIAL EXTENT:", "BEGIN SPATIALEXTENT:").replace("END SPATIAL EXTENT:", "END SPATIALEXTENT:")
           .replace("BEGIN CROSS-SECTIONS:", "BEGINCROSS-SECTIONS:"))
    ext = "    WATER SURFACE EXTENTS:\n      2025150.0, 13712250.0, 2025050.0, 13712150.0\n      2025160.0, 13712260.0, 2025040.0, 13712140.0\n"
    var = var.replace("      0.740, 0.00\n  END:", "      0.740, 0.00\n" + ext + "  END:")
    p = _write(tmp_path, "v.sdf", var)
    data = _no_warnings(read_sdf, p, strict=True)
    assert data.sections[0].extents == [(2025150.0, 13712250.0, 2025050.0, 13712150.0), (2025160.0, 13712260.0, 2025040.0, 13712140.0)]
    assert data.header["XMIN"] == "2024950.00"
    snap = _no_warnings(open_snapshot, p)
    np.testing.assert_array_equal(snap.depth.values, ref.depth.values)
    np.testing.assert_array_equal(snap.u.values, ref.u.values)


def test_sdf_unknown_keyword_is_named_with_its_line(formats, tmp_path):
    from breachflow.io.sdf import read_sdf

    text = (formats / "RASExport.sdf").read_text()
    bad = text.replace("      0.740, 0.00\n  END:", "      0.740, 0.00\n    MYSTERY RECORD:\n      1.0, 2.0, 3.0\n  END:")
    p = _write(tmp_path, "u.sdf", bad)
    line = bad[:bad.index("MYSTERY")].count("\n") + 1
    with pytest.raises(ParseError, match="unknown keyword 'MYSTERY RECORD'") as ei:
        read_sdf(p, strict=True)
    assert ei.value.line == line
    with pytest.warns(BreachflowWarning, match=rf"'MYSTERY RECORD' \(line {line}\)"):
        snap = open_snapshot(p)
    np.testing.assert_array_equal(snap.depth.values, open_snapshot(formats / "RASExport.sdf").depth.values)


# ---------------------------------------------------------------- a mesh / grid without results is a terrain

def test_mesh_without_results_reads_as_a_terrain(formats, mdal):
    snap = _no_warnings(open_snapshot, [formats / "adh_demo.3dm", formats / "adh_demo.bc"])
    nodes = [ln.split() for ln in _lines(formats / "adh_demo.3dm") if ln.startswith("ND")]
    np.testing.assert_array_equal(snap.bed_elevation.values, [float(n[4]) for n in nodes])
    assert (snap.depth.values == 0).all() and (snap.u.values == 0).all() and "time" not in snap.dims
    assert snap.attrs["breachflow_content"].startswith("terrain")
    snap = _no_warnings(open_snapshot, mdal / "quad_and_triangle.2dm", units="ft")
    np.testing.assert_allclose(snap.bed_elevation.values, np.array([20.0, 30, 40, 50, 10]) * 0.3048)
    assert snap.sizes["face"] == 2


def test_terrain_grid_alone_reads_as_a_terrain(formats, tmp_path):
    text = (formats / "depth_max.asc").read_text()
    head, body = text.split("NODATA_value -9999\n")
    p = _write(tmp_path, "terrain.asc", head + "NODATA_value -9999\n" + body.replace("-9999", "12.5"))
    snap = _no_warnings(open_snapshot, p, units="m")
    assert (snap.depth.values == 0).all() and snap.bed_elevation.values.max() == 12.5


def test_terrain_nodata_is_named_by_row_and_column_from_the_top(formats, tmp_path):
    p = _write(tmp_path, "terrain.asc", (formats / "depth_max.asc").read_text())
    with pytest.raises(InputError, match=r"terrain\.asc:7: terrain has NODATA at row 1, column 1 \(from the top"):
        open_snapshot(p, units="m")


def test_unsupported_cards_are_named_with_their_line(formats, tmp_path):
    lines = _lines(formats / "adh_demo.3dm")
    p = _write(tmp_path, "u.3dm", "\n".join(lines[:2] + ["BEGBC 1 2", "FOO 1"] + lines[2:] + ["FOO 2"]) + "\n")
    with pytest.warns(BreachflowWarning, match=r"ignored unsupported card\(s\) 'BEGBC' \(line 3\), 'FOO' \(line 4, 2 times\)"):
        read_mesh(p)
    dep = _lines(formats / "adh_demo_dep.dat")
    q = _write(tmp_path, "u_dep.dat", "\n".join(dep[:6] + ["GRIDINFO 3"] + dep[6:]) + "\n")
    with pytest.warns(BreachflowWarning, match=r"ignored unsupported card\(s\) 'GRIDINFO' \(line 7\)"):
        read_dat(q)


def test_old_vector_file(mdal):
    d = _no_warnings(read_dat, mdal / "quad_and_triangle_vertex_vector_old.dat")[0]
    assert d.vector and d.times == [0.0]
    np.testing.assert_array_equal(d.values[0], [[1, 1], [2, 1], [3, 2], [2, 2], [1, -2]])
