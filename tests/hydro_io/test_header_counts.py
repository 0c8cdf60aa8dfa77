"""Issue 27: a reader checks the counts of a header against the file before it allocates: an ESRI grid
announcing 1e8 × 1e8 cells is a ParseError naming the file and line, not a MemoryError (71 PiB)."""
import pytest

from breachflow.errors import ParseError
from breachflow.io.asc import read_asc


def test_asc_header_larger_than_the_file(tmp_path):
    p = tmp_path / "depth.asc"
    p.write_text("ncols 100000000\nnrows 100000000\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -9999\n"
                 "1 2 3 4\n5 6 7 8\n")
    with pytest.raises(ParseError) as info:
        read_asc(p)
    e = info.value
    assert e.path == str(p) and e.line == 1
    # 16 bytes of values ("1 2 3 4\n5 6 7 8\n") hold at most (16 + 1) // 2 = 8 values
    assert "header ncols 100,000,000 × nrows 100,000,000 = 10,000,000,000,000,000 values, but the file holds only 16 " \
           "bytes of values (at most 8 values)" in str(e)


def test_asc_header_within_the_file_still_reads(tmp_path):
    p = tmp_path / "depth.asc"
    p.write_text("ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n")
    g = read_asc(p)
    assert g.values.tolist() == [[3.0, 4.0], [1.0, 2.0]]  # south row first


def test_ingest_of_such_a_grid_is_one_line(tmp_path, capsys):
    from breachflow.cli import main

    p = tmp_path / "depth_max.asc"
    p.write_text("ncols 100000000\nnrows 100000000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3 4\n")
    with pytest.raises(SystemExit) as info:
        main(["ingest", str(p), "--bed", "0 m", "-o", str(tmp_path / "snap.nc")])
    err = " ".join(capsys.readouterr().err.split())
    assert info.value.code == 2 and f"{p}:1: header ncols 100,000,000" in err and "Traceback" not in err
    assert not (tmp_path / "snap.nc").exists()
