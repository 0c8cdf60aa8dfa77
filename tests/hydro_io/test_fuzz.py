"""Property-based mutation fuzzing of the sample files: a reader parses the mutated file or raises
ParseError (naming the file) — never another exception, never a hang. Bounded example counts keep
this to a few seconds."""
import warnings

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from breachflow.errors import BreachflowWarning, InputError, ParseError
from breachflow.io import open_snapshot
from breachflow.io.adh import read_dat, read_mesh
from breachflow.io.asc import read_asc
from breachflow.io.sdf import read_sdf
from breachflow.field.snapshot import validate_snapshot

NASTY = ["", "nan", "inf", "-1", "0", "1e309", "x", "ND", "TS", "E3T", "END:", "ENDDS", "BEGSCL", "NULL",
         "99999999999999999999", "1.5", "-", ",", ":", "\t", '"', "TS 1 0", "ND 3", "NC 99", "MESH2D",
         "CROSS-SECTION:", "VELOCITIES:", "PROFILE ID: PF 9", "ncols 3", "NODATA_value 0", "é", "2.5e-3"]

op = st.one_of(
    st.tuples(st.just("delete"), st.integers(0, 10**6)),
    st.tuples(st.just("duplicate"), st.integers(0, 10**6)),
    st.tuples(st.just("swap"), st.integers(0, 10**6), st.integers(0, 10**6)),
    st.tuples(st.just("token"), st.integers(0, 10**6), st.integers(0, 8), st.sampled_from(NASTY)),
    st.tuples(st.just("insert"), st.integers(0, 10**6), st.sampled_from(NASTY)),
    st.tuples(st.just("truncate"), st.integers(0, 10**6)),
    st.tuples(st.just("bytes"), st.integers(0, 10**6), st.binary(min_size=1, max_size=6)),
    st.tuples(st.just("crlf")),
)


def mutate(data: bytes, ops) -> bytes:
    for o in ops:
        lines = data.split(b"\n")
        n = max(len(lines), 1)
        if o[0] == "delete":
            del lines[o[1] % n]
        elif o[0] == "duplicate":
            lines.insert(o[1] % n, lines[o[1] % n])
        elif o[0] == "swap":
            i, j = o[1] % n, o[2] % n
            lines[i], lines[j] = lines[j], lines[i]
        elif o[0] == "token":
            toks = lines[o[1] % n].split()
            if toks:
                toks[o[2] % len(toks)] = o[3].encode()
            lines[o[1] % n] = b" ".join(toks)
        elif o[0] == "insert":
            lines.insert(o[1] % n, o[2].encode())
        elif o[0] == "truncate":
            return b"\n".join(lines)[: o[1] % max(len(data), 1)]
        elif o[0] == "bytes":
            k = o[1] % max(len(data), 1)
            return data[:k] + o[2] + data[k:]
        elif o[0] == "crlf":
            data = data.replace(b"\n", b"\r\n")
            continue
        data = b"\n".join(lines)
    return data


FUZZ = settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _check(reader, path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)
        try:
            reader(path)
        except ParseError as e:
            assert e.path == str(path)


@pytest.mark.parametrize("name, reader", [
    ("adh_demo.3dm", read_mesh), ("adh_demo_dep.dat", read_dat), ("adh_demo_vel.dat", read_dat),
    ("sms_demo_multi.dat", read_dat), ("depth_max.asc", read_asc), ("velocity_max.asc", read_asc),
    ("RASExport.sdf", read_sdf),
    # real-world variants (MDAL's test files): legacy, element-centred, tabs, binary
    ("mdal/quad_and_triangle_vertex_scalar_old1.dat", read_dat), ("mdal/quad_and_triangle_vertex_scalar_old2.dat", read_dat),
    ("mdal/quad_and_triangle_els_vector.dat", read_dat), ("mdal/quad_and_triangle_vertex_scalar_tabs.dat", read_dat),
    ("mdal/quad_and_triangle_binary.dat", read_dat), ("mdal/quad_and_triangle.2dm", read_mesh),
])
@FUZZ
@given(ops=st.lists(op, min_size=1, max_size=3))
def test_mutated_samples_parse_or_raise_parse_error(formats, tmp_path, name, reader, ops):
    p = tmp_path / name.replace("/", "_")
    p.write_bytes(mutate((formats / name).read_bytes(), ops))
    _check(reader, p)


@settings(max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(which=st.sampled_from(["adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat"]),
       ops=st.lists(op, min_size=1, max_size=2))
def test_mutated_adh_set_gives_a_valid_snapshot_or_a_clear_error(formats, tmp_path, which, ops):
    files = []
    for n in ("adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc"):
        p = tmp_path / n
        data = (formats / n).read_bytes()
        p.write_bytes(mutate(data, ops) if n == which else data)
        files.append(p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)
        try:
            ds = open_snapshot(files)
        except (ParseError, InputError):
            return
    validate_snapshot(ds)
