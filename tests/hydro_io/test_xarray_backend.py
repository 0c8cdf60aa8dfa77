"""`xr.open_dataset(path, engine="breachflow")`: the snapshot readers as an xarray backend, found through the
`xarray.backends` entry point, giving what `open_snapshot` gives."""
import io

import pytest
import xarray as xr

from breachflow.errors import InputError
from breachflow.io import open_snapshot
from breachflow.io.xarray_backend import BreachflowBackendEntrypoint

from pathlib import Path

DATA = Path(__file__).resolve().parent / "data"

ADH = ["adh_demo.3dm", "adh_demo_dep.dat", "adh_demo_vel.dat", "adh_demo.bc"]


@pytest.fixture(autouse=True)
def one_clock(monkeypatch):
    """Every snapshot of a test stamped at the same time: the ``history`` attribute holds the time a snapshot
    was made, and two readings a second apart would differ in it alone (``assert_identical`` compares attributes)."""
    from datetime import datetime, timezone

    import breachflow.field.snapshot as snapshot

    fixed = datetime(2026, 1, 1, tzinfo=timezone.utc)

    class Clock(datetime):
        @classmethod
        def now(cls, tz=None):
            return fixed if tz is not None else fixed.replace(tzinfo=None)

    monkeypatch.setattr(snapshot, "datetime", Clock)


def test_the_engine_is_registered_through_the_entry_point():
    engines = xr.backends.list_engines()
    assert isinstance(engines["breachflow"], BreachflowBackendEntrypoint)


def test_an_sdf_opens_by_engine_and_by_its_extension_as_open_snapshot_reads_it():
    want = open_snapshot(DATA / "RASExport.sdf")
    xr.testing.assert_identical(xr.open_dataset(DATA / "RASExport.sdf", engine="breachflow"), want)
    xr.testing.assert_identical(xr.open_dataset(str(DATA / "RASExport.sdf")), want)  # guessed


def test_an_adh_mesh_finds_its_datasets_and_bc_beside_it():
    want = open_snapshot([DATA / n for n in ADH])
    got = xr.open_dataset(DATA / "adh_demo.3dm", engine="breachflow")
    xr.testing.assert_identical(got, want)
    assert got.attrs["source_length_unit"] == "m" and got["depth"].sizes["time"] == 2
    assert float(abs(got["u"]).max()) > 0
    with pytest.warns(UserWarning, match="no velocity"):  # the companions given: the velocity left out
        only_depth = xr.open_dataset(DATA / "adh_demo.3dm", engine="breachflow",
                                     companions=[DATA / "adh_demo_dep.dat", DATA / "adh_demo.bc"])
    xr.testing.assert_identical(only_depth["depth"], want["depth"])
    assert float(abs(only_depth["u"]).max()) == 0


def test_reader_options_and_drop_variables_pass_through():
    with pytest.warns(UserWarning, match="no velocity"):
        ds = xr.open_dataset(DATA / "depth_max.asc", engine="breachflow", units="ft", bed="0 ft",
                             drop_variables=["wet"])
        want = open_snapshot(DATA / "depth_max.asc", units="ft", bed="0 ft")
    xr.testing.assert_identical(ds, want.drop_vars("wet", errors="ignore"))
    assert "wet" not in ds


def test_guess_can_open_claims_only_breachflow_formats():
    b = BreachflowBackendEntrypoint()
    assert b.guess_can_open("x/RASExport.sdf") and b.guess_can_open("mesh.3dm") and b.guess_can_open("m.2DM")
    for other in ("a.nc", "a.dat", "a.asc", "a.hdf", "a.tif", "noext"):
        assert not b.guess_can_open(other), other
    assert not b.guess_can_open(io.BytesIO(b"x"))


def test_bad_input_is_a_clear_error():
    with pytest.raises(InputError, match="by path"):
        BreachflowBackendEntrypoint().open_dataset(io.BytesIO(b"x"))
    with pytest.raises(InputError, match="does not exist"):
        xr.open_dataset("no_such_file.sdf", engine="breachflow")
