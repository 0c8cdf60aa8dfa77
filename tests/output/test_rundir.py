"""Run directories: atomic cycle files, manifest commit point, resume checks, archive."""
import numpy as np
import pytest
import xarray as xr

from breachflow import InputError
from breachflow.dem.state import ParticleState
from breachflow.field.snapshot import grid_snapshot
from breachflow.io import RunDirectory, particles_dataset, trajectories_dataset
from breachflow import atomic as atomic_mod


def _field(g):
    x = np.arange(4.0)
    y = np.arange(3.0)
    depth = np.full((3, 4), 1.0 + g)
    ds = grid_snapshot(x, y, np.zeros((3, 4)), depth, np.ones((3, 4)), np.zeros((3, 4)))
    state = ParticleState.spheres([[0.5, 0.5, 0.5 + g], [1.5, 0.5, 0.5]], radius=0.5)
    return xr.merge([ds, particles_dataset(state, placed_cycle=[1, g], resting=[True, True])], combine_attrs="override")


def _traj(g, nobs):
    t = np.tile(np.arange(nobs, dtype=float), (2, 1))
    pos = np.random.default_rng(g).random((2, nobs, 3))
    pos[1, -1] = np.nan
    t[1, -1] = np.nan
    return trajectories_dataset([0, 1], t, pos, cycle=g)


def test_cycles_commit_resume_and_combine(tmp_path):
    run = RunDirectory(tmp_path / "run")
    run.start("a = 1\n", seed=7)
    with pytest.raises(InputError, match="holds a run already"):
        RunDirectory(tmp_path / "run").start("a = 1\n", seed=7)
    run.write_cycle(1, _field(1), _traj(1, 5), {"pos": np.zeros((2, 3))}, {"max_speed": 1.0})
    run.write_cycle(2, _field(2), _traj(2, 3), {"pos": np.ones((2, 3))}, {"max_speed": 0.5})
    assert run.completed_cycles() == [1, 2] and run.verify() == []
    with pytest.raises(InputError, match="does not follow"):
        run.write_cycle(4, _field(4), None, {}, {})
    # resume: same scenario and seed only
    assert RunDirectory(run.path).start("a = 1\n", seed=7, resume=True)["cycles"][-1]["cycle"] == 2
    with pytest.raises(InputError, match="another scenario or seed"):
        RunDirectory(run.path).start("a = 2\n", seed=7, resume=True)
    np.testing.assert_array_equal(run.load_restart(2)["pos"], np.ones((2, 3)))
    out = run.combine(tmp_path / "archive.nc")
    with xr.open_dataset(out) as ar:
        assert ar.sizes["cycle"] == 2 and list(ar.cycle.values) == [1, 2]
        np.testing.assert_allclose(ar.depth.isel(cycle=1).values, 3.0)
        np.testing.assert_allclose(ar.particle_z.values, [2.5, 0.5])
    with xr.open_dataset(out, group="trajectories", decode_times=False) as tr:
        assert tr.sizes["trajectory"] == 4 and tr.sizes["obs"] == 5
        assert tr.attrs["featureType"] == "trajectory"
        assert tr.trajectory_id.attrs["cf_role"] == "trajectory_id"
        assert np.isnan(tr.x.values[2, 3:]).all()  # cycle-2 trajectories padded


def test_crash_during_write_leaves_previous_cycles_intact(tmp_path, monkeypatch):
    run = RunDirectory(tmp_path / "run")
    run.start("s", seed=1)
    run.write_cycle(1, _field(1), _traj(1, 4), {"k": np.arange(3)}, {})
    before = run.cycle_path(1).read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", boom)
    with pytest.raises(OSError, match="disk full"):
        run.write_cycle(2, _field(2), _traj(2, 4), {"k": np.arange(3)}, {})
    monkeypatch.undo()
    assert run.completed_cycles() == [1]
    assert not run.cycle_path(2).exists()
    assert run.cycle_path(1).read_bytes() == before
    assert not list(run.path.glob(".*.tmp"))
    # the resumed run writes cycle 2 normally
    run.write_cycle(2, _field(2), None, {"k": np.arange(3)}, {})
    assert run.completed_cycles() == [1, 2] and run.verify() == []


def test_atomic_write_failure_removes_temp(tmp_path):
    with pytest.raises(ValueError):
        atomic_mod.atomic_write(tmp_path / "f.txt", lambda tmp: (_ for _ in ()).throw(ValueError("x")))
    assert list(tmp_path.iterdir()) == []


def test_a_resumed_run_of_an_earlier_version_reads_its_nested_box_under_the_current_key(tmp_path):
    """Runs written before the nested grid's box got its name stored it as ``nested_window``: resuming
    one reads (and rewrites) the key as ``nested_box``; a manifest holding both keeps the current one."""
    import json

    run = RunDirectory(tmp_path / "run")
    run.start("a = 1\n", seed=7, metadata={"hydro_mode": "nested"})
    run.close()
    man = json.loads(run.manifest_path.read_text())
    man["metadata"]["nested_window"] = [-42.0, 42.0, -36.0, 36.0]  # as an earlier version wrote it
    run.manifest_path.write_text(json.dumps(man))
    resumed = RunDirectory(run.path)
    meta = resumed.start("a = 1\n", seed=7, resume=True)["metadata"]
    assert meta["nested_box"] == [-42.0, 42.0, -36.0, 36.0] and "nested_window" not in meta
    on_disk = json.loads(run.manifest_path.read_text())["metadata"]
    assert on_disk["nested_box"] == [-42.0, 42.0, -36.0, 36.0] and "nested_window" not in on_disk
    resumed.close()
    # both keys (never written by one version): the current one wins
    on_disk.update(nested_window=[0.0, 1.0, 0.0, 1.0])
    man["metadata"] = on_disk
    run.manifest_path.write_text(json.dumps(man))
    assert RunDirectory(run.path).manifest()["metadata"]["nested_box"] == [-42.0, 42.0, -36.0, 36.0]
