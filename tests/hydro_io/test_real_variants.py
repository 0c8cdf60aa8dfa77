"""Issue 13: constructs real third-party files use (SMS, ADH, TUFLOW, BASEMENT, Hydro_AS-2D, LISFLOOD-FP,
GDAL, old HEC-RAS exports), each allowed by the format as those tools write it. Each test builds the
construct into a copy of a sample and checks the values read against the sample read without it.
"""
import struct
import warnings

import numpy as np
import pytest

from breachflow import InputError
from breachflow.errors import BreachflowWarning, ParseError
from breachflow.hydro import open_snapshot
from breachflow.hydro.io.adh import read_dat, read_mesh


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


def test_begcurve_blocks_are_skipped(formats, tmp_path):
    lines = _lines(formats / "adh_demo.3dm")
    curve = ["BEGCURVE Version: 1", "ID 1", "Units: m", "XY 2", "0.0 10.9", "7200.0 11.35", "ENDCURVE"]
    p = _write(tmp_path, "c.2dm", "\n".join(lines[:2] + curve + lines[2:]) + "\n")
    m = _no_warnings(read_mesh, p, strict=True)
    np.testing.assert_array_equal(m.faces, read_mesh(formats / "adh_demo.3dm").faces)
    bad = _write(tmp_path, "d.2dm", "\n".join(lines[:2] + curve[:-1] + lines[2:]) + "\n")
    with pytest.raises(ParseError, match="block opened at line 3 has no ENDCURVE"):
        read_mesh(bad)
