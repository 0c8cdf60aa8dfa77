"""Issue 12 (part 4): a dataset with one value too many, implausible values, a .bc without MP G and a mesh
without nodes are errors that name the file and the line (grids: row and column from the top, 1-based).
"""
import re

import pytest

from breachflow import InputError
from breachflow.errors import ParseError
from breachflow.io import open_snapshot
from breachflow.io.adh import read_dat, read_mesh


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def _lines(path):
    return path.read_text().splitlines()


def _adh(formats, **repl):
    files = {"mesh": formats / "adh_demo.3dm", "dep": formats / "adh_demo_dep.dat",
             "vel": formats / "adh_demo_vel.dat", "bc": formats / "adh_demo.bc"}
    files.update(repl)
    return list(files.values())


# ---------------------------------------------------------------- one value too many

@pytest.mark.parametrize("step", [0, 1])
def test_dat_step_with_one_value_too_many_is_an_error_naming_the_line(formats, tmp_path, step):
    lines = _lines(formats / "adh_demo_dep.dat")
    ts = [i for i, ln in enumerate(lines) if ln.startswith("TS")]
    at = ts[step] + 1 + 12            # 0-based index just after the step's 12 values
    bad = lines[:at] + ["  -3.00000000e-01"] + lines[at:]
    p = _write(tmp_path, "extra_dep.dat", "\n".join(bad) + "\n")
    with pytest.raises(ParseError, match=r"value line where a card \(TS, ENDDS, ...\) is expected.*ND=12 values") as ei:
        read_dat(p)
    assert ei.value.path == str(p) and ei.value.line == at + 1
    # and through the public API (the depths of nodes 7-12 must never come out shifted)
    with pytest.raises(ParseError):
        open_snapshot(_adh(formats, dep=p))


def test_vector_step_with_one_row_too_many(formats, tmp_path):
    lines = _lines(formats / "adh_demo_vel.dat")
    ts = [i for i, ln in enumerate(lines) if ln.startswith("TS")][0]
    at = ts + 1 + 12
    p = _write(tmp_path, "extra_vel.dat", "\n".join(lines[:at] + ["  0.1 0.2 0.0"] + lines[at:]) + "\n")
    with pytest.raises(ParseError, match=r"value line where a card \(TS, ENDDS, ...\) is expected") as ei:
        read_dat(p)
    assert ei.value.line == at + 1


def test_legacy_dat_with_one_value_too_many(tmp_path):
    text = "SCALAR\nND 3\nTS 0.0\n1.0\n2.0\n3.0\n4.0\nTS 60.0\n1.0\n2.0\n3.0\n"
    p = _write(tmp_path, "leg.dat", text)
    with pytest.raises(ParseError, match=r"value line where a card \(TS, ENDDS, ...\) is expected") as ei:
        read_dat(p)
    assert ei.value.line == 7


# ---------------------------------------------------------------- plausibility names file and line

def _loc(exc):
    m = re.match(r"(.+):(\d+): ", str(exc))
    assert m, str(exc)
    return m.group(1), int(m.group(2))


def test_implausible_depth_in_dat_names_file_and_line(formats, tmp_path):
    lines = _lines(formats / "adh_demo_dep.dat")
    ts1 = [i for i, ln in enumerate(lines) if ln.startswith("TS")][1]
    k = ts1 + 1 + 8            # value of node 9 in the second step
    lines[k] = "  1.00000000e+30"
    p = _write(tmp_path, "big_dep.dat", "\n".join(lines) + "\n")
    with pytest.raises(InputError, match="implausible water depth 1e\\+30") as ei:
        open_snapshot(_adh(formats, dep=p))
    assert _loc(ei.value) == (str(p), k + 1)
    assert ei.value.path == str(p) and ei.value.line == k + 1


def test_implausible_speed_in_vel_dat_names_file_and_line(formats, tmp_path):
    lines = _lines(formats / "adh_demo_vel.dat")
    ts0 = [i for i, ln in enumerate(lines) if ln.startswith("TS")][0]
    k = ts0 + 1 + 3
    lines[k] = "  3.0e+02 0.0 0.0"
    p = _write(tmp_path, "fast_vel.dat", "\n".join(lines) + "\n")
    with pytest.raises(InputError, match="implausible speed 300") as ei:
        open_snapshot(_adh(formats, vel=p))
    assert _loc(ei.value) == (str(p), k + 1)


def test_implausible_bed_in_mesh_names_the_nd_line(formats, tmp_path):
    lines = _lines(formats / "adh_demo.3dm")
    k = next(i for i, ln in enumerate(lines) if ln.split()[:2] == ["ND", "5"])
    t = lines[k].split()
    lines[k] = " ".join(t[:4] + ["1.0e+30"])
    p = _write(tmp_path, "hi.3dm", "\n".join(lines) + "\n")
    with pytest.raises(InputError, match="bed elevation") as ei:
        open_snapshot(_adh(formats, mesh=p), plausibility="raise")
    assert _loc(ei.value) == (str(p), k + 1)


def test_implausible_depth_with_node_id_gaps_names_the_line_of_the_id(tmp_path):
    # ND equals the largest id: value line k is node id k, so the skipped id 3 still has a line
    mesh = _write(tmp_path, "g.3dm", "MESH2D\nE3T 1 1 2 4 1\nND 1 0 0 0\nND 2 1 0 0\nND 4 0 1 0\n")
    dat = _write(tmp_path, "g_dep.dat", "DATASET\nBEGSCL\nND 4\nNC 1\nNAME Depth\nTS 0 0\n1.0\n2.0\n0.0\n1e30\nENDDS\n")
    with pytest.raises(InputError, match="implausible water depth") as ei:
        open_snapshot([mesh, dat], units="m")
    assert _loc(ei.value) == (str(dat), 10)


def test_implausible_sdf_water_elevation_names_the_line(formats, tmp_path):
    text = (formats / "RASExport.sdf").read_text()
    old = "WATER ELEVATION: 852.40, 854.10"
    assert old in text
    bad = text.replace(old, "WATER ELEVATION: 852.40, 1e30")
    p = _write(tmp_path, "big.sdf", bad)
    with pytest.raises(InputError, match="implausible water depth") as ei:
        open_snapshot(p)
    assert _loc(ei.value) == (str(p), bad[:bad.index("WATER ELEVATION: 852.40, 1e30")].count("\n") + 1)


def test_implausible_sdf_velocity_names_the_line(formats, tmp_path):
    text = (formats / "RASExport.sdf").read_text()
    old = "      0.400, 1.85"
    bad = text.replace(old, "      0.400, 185.0", 1)
    p = _write(tmp_path, "fast.sdf", bad)
    with pytest.raises(InputError, match="implausible speed") as ei:
        open_snapshot(p)
    assert _loc(ei.value) == (str(p), bad[:bad.index("0.400, 185.0")].count("\n") + 1)


@pytest.mark.parametrize("row, col", [(1, 1), (2, 4), (4, 5), (3, 2)])
def test_implausible_grid_value_names_file_line_row_and_column_from_the_top(formats, tmp_path, row, col):
    lines = _lines(formats / "depth_max.asc")
    first = next(i for i, ln in enumerate(lines) if not re.match(r"[A-Za-z]", ln.strip()))
    k = first + row - 1
    vals = lines[k].split()
    vals[col - 1] = "1e30"
    lines[k] = " ".join(vals)
    p = _write(tmp_path, "depth.asc", "\n".join(lines) + "\n")
    with pytest.raises(InputError, match=rf"row {row}, column {col} \(from the top") as ei:
        open_snapshot([p, formats / "velocity_max.asc"], units="ft", bed="0 ft", velocity_direction=0)
    assert _loc(ei.value) == (str(p), k + 1)


def test_implausible_grid_value_in_a_flat_stream_names_its_line(formats, tmp_path):
    # values as one flat stream, 3 per line: row 2 col 2 (0-based flat index 6) is on data line 3
    lines = _lines(formats / "depth_max.asc")
    first = next(i for i, ln in enumerate(lines) if not re.match(r"[A-Za-z]", ln.strip()))
    vals = " ".join(lines[first:]).split()
    vals[6] = "1e30"
    body = [" ".join(vals[i:i + 3]) for i in range(0, len(vals), 3)]
    p = _write(tmp_path, "depth.asc", "\n".join(lines[:first] + body) + "\n")
    with pytest.raises(InputError, match=r"row 2, column 2 \(from the top") as ei:
        open_snapshot([p, formats / "velocity_max.asc"], units="ft", bed="0 ft", velocity_direction=0)
    assert _loc(ei.value) == (str(p), first + 3)


# ---------------------------------------------------------------- .bc without MP G, mesh without nodes

def test_bc_without_mp_g_names_the_file(formats, tmp_path):
    bc = _write(tmp_path, "nog.bc", "\n".join(ln for ln in _lines(formats / "adh_demo.bc") if not ln.startswith("MP G")) + "\n")
    with pytest.raises(InputError, match=r"nog\.bc.*no MP G card") as ei:
        open_snapshot(_adh(formats, bc=bc))
    assert str(bc) in str(ei.value)


def test_mesh_without_node_cards_names_a_line(tmp_path):
    p = _write(tmp_path, "a.3dm", "MESH2D\nMESHNAME x\nE3T 1 1 2 3 1\nE3T 2 2 3 4 1\n")
    with pytest.raises(ParseError, match="no ND") as ei:
        read_mesh(p)
    assert ei.value.path == str(p) and ei.value.line == 3


def test_implausible_sdf_bed_names_the_surface_line_point(formats, tmp_path):
    text = (formats / "RASExport.sdf").read_text()
    old = "      2025300.00, 13712000.00, 848.20"
    bad = text.replace(old, "      2025300.00, 13712000.00, 1e30")
    p = _write(tmp_path, "bed.sdf", bad)
    with pytest.raises(InputError, match=r"implausible \|bed elevation\|") as ei:
        open_snapshot(p)
    assert _loc(ei.value) == (str(p), bad[:bad.index("13712000.00, 1e30")].count("\n") + 1)
