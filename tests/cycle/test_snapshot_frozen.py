"""``solver = "snapshot_frozen"`` (issue 13): the old ingested-snapshot mode under a name that says what it
is; ``"snapshot"`` still works but warns; the run says in its log and output that the flow is frozen."""
import json
import warnings

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.main import run_closure
from breachflow.errors import BreachflowWarning
from breachflow.field.snapshot import grid_snapshot
from breachflow.hydro.solvers import SnapshotSolver, solvers
from breachflow.scenario.config import parse_scenario

BASE = """
[scenario]
name = "frozen"
[site]
preset = "demo_breach"
levee_length_each_side = "12 m"
flood_side_extent = "14 m"
protected_side_extent = "14 m"
[hydro]
solver = "{solver}"
resolution = "2 m"
snapshots = ["{snap}"]
[dem]
max_time = "1.5 s"
record_interval = "0.25 s"
[placement]
diameter = ["1.6 m", "2.0 m"]
batch = 2
positions = "line"
start = ["-3 m", "0 m"]
stop = ["3 m", "0 m"]
release_height = "0.5 m"
[criteria]
max_cycles = 2
max_speed = "0.01 m/s"
[closure]
remap = "raised_bed"
seed = 2
"""


def _snapshot(tmp_path):
    """A still-water field on the demo scene's grid with a uniform 0.3 m/s current toward the polder."""
    sc = parse_scenario(BASE.replace('solver = "{solver}"', 'solver = "swe"').replace('snapshots = ["{snap}"]', ""))
    dom = closure_setup(sc).domain
    depth = np.maximum(3.0 - dom.bed, 0.0)
    ds = grid_snapshot(dom.x, dom.y, dom.bed, depth, np.zeros_like(depth), np.full_like(depth, 0.3))
    path = tmp_path / "snap.nc"
    ds.to_netcdf(path)
    return path, ds


def test_snapshot_is_a_deprecated_alias_of_snapshot_frozen(tmp_path):
    path, ds = _snapshot(tmp_path)
    with pytest.warns(DeprecationWarning, match="'snapshot' is deprecated: it is 'snapshot_frozen'"):
        s = solvers.create("snapshot", snapshots=[ds])
    assert isinstance(s, SnapshotSolver) and s.responds_to_pile is False
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        out = solvers.create("snapshot_frozen", snapshots=[ds]).solve()
    assert out.attrs["hydro_mode"] == "snapshot_frozen" and out.attrs["flow_responds_to_pile"] == 0
    with pytest.warns(DeprecationWarning, match=r"\[hydro\] solver = 'snapshot' is deprecated"):
        parse_scenario(BASE.format(solver="snapshot", snap=path))


def test_frozen_run_says_the_flow_does_not_respond_to_the_pile(tmp_path):
    path, ds = _snapshot(tmp_path)
    scen = tmp_path / "frozen.toml"
    scen.write_text(BASE.format(solver="snapshot_frozen", snap=path))
    with pytest.warns(BreachflowWarning, match="does not respond to the pile"):
        res = run_closure(scen, tmp_path / "run", plots=False)
    assert res.cycles == 2
    for rep in res.reports:
        assert rep.hydro.startswith("frozen flow, does not respond to the pile")
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert man["metadata"]["hydro_mode"] == "snapshot_frozen" and man["metadata"]["flow_responds_to_pile"] is False
    with xr.open_dataset(tmp_path / "run" / "cycle_0002.nc") as out:
        assert out.attrs["flow_responds_to_pile"] == 0 and "does not respond to the pile" in out.attrs["hydro_note"]
        # and it really is the ingested field, pile or not
        np.testing.assert_array_equal(np.squeeze(out["v"].values), ds["v"].values)
        assert int((out["particle_resting"] == 1).sum()) > 0
