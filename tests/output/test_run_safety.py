"""Never lose a user's run (issue 15): full disk, permissions, temp files of killed runs, provenance."""
import errno
import os
import re
import shutil
import subprocess
import uuid
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import breachflow
from breachflow.errors import DiskFullError
from breachflow.field.snapshot import grid_snapshot, write_snapshot
from breachflow.atomic import atomic_write_netcdf
from breachflow import provenance
from breachflow.io import RunDirectory
from breachflow import atomic as atomic_mod

from .test_rundir import _field, _traj


def _expected_commit():
    """The commit of the checkout the package is imported from, asked of git independently (None outside)."""
    here = Path(breachflow.__file__).resolve().parent
    try:
        r = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
    except OSError:
        return None
    return r.stdout.strip() if r.returncode == 0 else None


# ------------------------------------------------------------------ permissions
@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_outputs_get_the_users_umask_permissions(tmp_path, mask):
    old = os.umask(mask)
    try:
        atomic_mod.atomic_write_text("x", tmp_path / "a.txt")
        atomic_write_netcdf(xr.Dataset({"v": ("x", [1.0])}), tmp_path / "a.nc")
        with open(tmp_path / "plain.txt", "w") as fh:  # what an ordinary open() gives: the reference
            fh.write("x")
    finally:
        os.umask(old)
    want = (tmp_path / "plain.txt").stat().st_mode & 0o777
    assert want == 0o666 & ~mask
    for name in ("a.txt", "a.nc"):
        assert (tmp_path / name).stat().st_mode & 0o777 == want, name


# ------------------------------------------------------------------ full disk, simulated
def test_enospc_names_the_file_and_leaves_nothing(tmp_path, monkeypatch):
    def full(self, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full)
    with pytest.raises(DiskFullError, match=r"no space left on device writing .*cycle\.nc"):
        atomic_write_netcdf(xr.Dataset({"v": ("x", [1.0])}), tmp_path / "cycle.nc")
    assert list(tmp_path.iterdir()) == []


def test_hdf_error_on_a_full_disk_is_named_as_such(tmp_path, monkeypatch):
    """netCDF-C reports a full disk as ``RuntimeError: NetCDF: HDF error`` (no errno): with the file
    system full it is a DiskFullError; with room left the original error stands."""
    def hdf(self, *a, **k):
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", hdf)
    ds = xr.Dataset({"v": ("x", [1.0])})
    with pytest.raises(RuntimeError, match="HDF error") as info:
        atomic_write_netcdf(ds, tmp_path / "a.nc")
    assert not isinstance(info.value, DiskFullError)
    monkeypatch.setattr(atomic_mod.shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(10**9, 10**9, 0))
    with pytest.raises(DiskFullError, match=r"writing .*a\.nc .*HDF error"):
        atomic_write_netcdf(ds, tmp_path / "a.nc")
    assert list(tmp_path.iterdir()) == []


def test_full_disk_during_a_cycle_then_resume(tmp_path, monkeypatch):
    run = RunDirectory(tmp_path / "run")
    run.start("s", seed=1)
    run.write_cycle(1, _field(1), _traj(1, 4), {"k": np.arange(3)}, {})
    real = xr.Dataset.to_netcdf

    def full_on_trajectories(self, path, *a, **k):
        if "trajectories" in str(path):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, path, *a, **k)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full_on_trajectories)
    with pytest.raises(DiskFullError, match=re.escape(run.trajectories_path(2).name)):
        run.write_cycle(2, _field(2), _traj(2, 4), {"k": np.arange(3)}, {})
    monkeypatch.undo()
    # the field file written before the full disk is no committed cycle's: verify names it, resume sweeps it
    assert run.completed_cycles() == [1]
    assert run.verify() == [f"{run.cycle_path(2)}: not in the manifest (a cycle file of no committed cycle)"]
    assert not [p for p in run.path.iterdir() if p.name.startswith(".")]
    # space freed: the resumed run sweeps the uncommitted cycle-2 field file and carries on
    resumed = RunDirectory(run.path)
    resumed.start("s", seed=1, resume=True)
    assert [p.name for p in resumed.swept] == ["cycle_0002.nc"]
    resumed.write_cycle(2, _field(2), _traj(2, 4), {"k": np.arange(3)}, {})
    assert resumed.completed_cycles() == [1, 2] and resumed.verify() == []


# ------------------------------------------------------------------ full disk, for real (tmpfs)
@pytest.fixture
def small_tmpfs(tmp_path):
    """A 64 KiB tmpfs (needs root and mount); skipped, naming why, where it cannot be mounted."""
    mnt = tmp_path / f"tmpfs-{uuid.uuid4().hex[:6]}"
    mnt.mkdir()
    if not shutil.which("mount") or (hasattr(os, "geteuid") and os.geteuid() != 0):
        pytest.skip("mounting a small tmpfs needs root and mount(8); the monkeypatched tests cover the logic")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def _big_field(g, n=80):
    x = np.arange(float(n))
    rng = np.random.default_rng(g)  # incompressible values: the file really is ~n*n*8 bytes per variable
    ds = grid_snapshot(x, x, rng.random((n, n)), 1.0 + rng.random((n, n)), rng.random((n, n)), rng.random((n, n)))
    return ds


def test_real_full_disk_names_the_file_and_resume_continues(small_tmpfs):
    run = RunDirectory(small_tmpfs / "run")
    run.start("s", seed=1)
    with pytest.raises(DiskFullError, match=r"no space left on device writing .*cycle_0001\.nc"):
        run.write_cycle(1, _big_field(1), None, {"k": np.arange(3)}, {})
    assert run.completed_cycles() == []
    # nothing half-written (run.lock: the run still holds the directory's lock)
    assert sorted(p.name for p in run.path.iterdir()) == ["manifest.json", "run.lock", "scenario.toml"]
    # free space (grow the file system), then resume and write the cycle
    r = subprocess.run(["mount", "-o", "remount,size=4m", str(small_tmpfs)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    resumed = RunDirectory(run.path)
    resumed.start("s", seed=1, resume=True)
    resumed.write_cycle(1, _big_field(1), None, {"k": np.arange(3)}, {})
    assert resumed.completed_cycles() == [1] and resumed.verify() == []


def test_real_full_disk_in_ingest_is_one_line(small_tmpfs, capsys):
    """`breachflow ingest` onto a full disk: exit code 2 and one 'no space left' line (was a
    PermissionError / 25-frame HDF traceback); nothing is left in the directory."""
    from breachflow.cli import main

    data = Path(__file__).parents[1] / "hydro_io" / "data"
    (small_tmpfs / "filler").write_bytes(os.urandom(56 * 1024))  # 8 KiB left: less than the snapshot needs
    with pytest.raises(SystemExit) as info:
        main(["ingest", str(data / "depth_max.asc"), str(data / "velocity_max.asc"), "--units", "ft", "--bed", "0 ft",
              "--velocity-direction", "0", "-o", str(small_tmpfs / "snap.nc")])
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    assert f"no space left on device writing {small_tmpfs / 'snap.nc'}" in " ".join(err.split())
    assert "Traceback" not in err
    assert [p.name for p in small_tmpfs.iterdir()] == ["filler"]


# ------------------------------------------------------------------ temp files of a killed run
def test_resume_sweeps_temp_files_and_uncommitted_cycles(tmp_path):
    run = RunDirectory(tmp_path / "run")
    run.start("s", seed=1)
    run.write_cycle(1, _field(1), _traj(1, 4), {"k": np.arange(3)}, {})
    # what `kill -9` during cycle 2's writes leaves: mkstemp temp files and a field file never committed
    left = [".cycle_0002_trajectories.nc.k3_x9a2b.nc", ".cycle_0002.nc.abcdefgh.nc", ".restart_0002.npz.a1b2c3d4.npz",
            ".manifest.json.zz99yy88.json", "cycle_0002.nc", "restart_0002.npz", "trajectories_0002.nc"]
    for name in left:
        (run.path / name).write_bytes(b"partial")
    keep = ["notes.txt", ".hidden_by_user"]
    for name in keep:
        (run.path / name).write_text("mine")
    resumed = RunDirectory(run.path)
    resumed.start("s", seed=1, resume=True)
    assert sorted(p.name for p in resumed.swept) == sorted(left)
    assert not any((run.path / n).exists() for n in left)
    assert all((run.path / n).exists() for n in keep)  # only breachflow's own leftovers go
    assert resumed.completed_cycles() == [1] and resumed.verify() == []


# ------------------------------------------------------------------ provenance
def test_every_written_file_and_the_manifest_carry_provenance(tmp_path, monkeypatch):
    provenance.set_command(["run", "mine.toml", "--out", "runs/mine"])
    try:
        run = RunDirectory(tmp_path / "run")
        run.start("s", seed=1)
        run.write_cycle(1, _field(1), _traj(1, 4), {"k": np.arange(3)}, {})
        run.write_cycle(2, _field(2), _traj(2, 3), {"k": np.arange(3)}, {})
        arch = run.combine(tmp_path / "archive.nc")
        snap = write_snapshot(_big_field(1, 6), tmp_path / "snap.nc")
        man = run.manifest()
    finally:
        provenance.set_command(None)
    commit = _expected_commit()
    files = [(run.cycle_path(1), None), (run.trajectories_path(2), None), (arch, None), (arch, "trajectories"),
             (snap, None)]
    for path, group in files:
        with xr.open_dataset(path, group=group, decode_times=False) as ds:
            a = ds.attrs
        where = f"{path.name}{'/' + group if group else ''}"
        assert a["breachflow_version"] == breachflow.__version__, where
        assert a["breachflow_command"] == "breachflow run mine.toml --out runs/mine", where
        assert a["history"].splitlines()[0].endswith(": breachflow run mine.toml --out runs/mine"), where
        if commit:
            assert a["breachflow_git_commit"].split("+")[0] == commit, where
        else:
            assert "breachflow_git_commit" not in a, where
    assert man["provenance"]["breachflow_version"] == breachflow.__version__
    assert man["provenance"]["breachflow_command"] == "breachflow run mine.toml --out runs/mine"
    assert man["sessions"][0]["action"] == "start"
    if commit:
        assert man["provenance"]["breachflow_git_commit"].split("+")[0] == commit


def test_no_git_commit_outside_a_checkout(monkeypatch):
    def no_git(*a, **k):
        raise FileNotFoundError("git")

    provenance.git_commit.cache_clear()
    monkeypatch.setattr(provenance.subprocess, "run", no_git)
    try:
        assert provenance.git_commit() is None
        assert "breachflow_git_commit" not in provenance.attrs()
        assert provenance.attrs()["breachflow_version"] == breachflow.__version__
    finally:
        provenance.git_commit.cache_clear()
