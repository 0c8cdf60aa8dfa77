"""The start state of a closure run, computed once and reused by runs that share it (docs/verdict-check.md,
*Extra seeds start from the run's start state*).

Before its first cycle a closure run solves the open breach: under the closure in time the closure window's
weir calibration on the breach at full size, the polder filled to the start of the closure, the start's weir
calibration (one to five solves) and the steady open breach at the start. None of it depends on the placement
seed: the verdict check's extra seeds and an ensemble's replicates would repeat the same solves, which on the
typical breach are a third of a run's CPU time. A run given a *store* (a directory) writes its start state
there as ``<key>.nc``, and a run whose key is found there takes it instead of solving:

* the key (:func:`start_key`) is the SHA-256 of the scenario's tables without ``[closure] seed`` and
  without the verdict check's ``[check]``, with the package's version and git commit: the same key, the same
  solves;
* the file holds the steady open breach at the start (the grid snapshot the first cycle starts from) and, in
  the attribute ``start_state`` (JSON), the timeline's state after the calibrations (clock, polder level,
  weir coefficients, the pre-start history and the calibration steps), written atomically;
* only flow models that keep no state between solves take part (:func:`reusable`: the embedded solver on one
  grid, re-solving the whole domain); a nested grid remembers its coarse field, a region re-solve its region,
  a stage hydrograph without a timeline counts its solves, so their runs solve their start themselves.

A run that takes a start state computes what it would have computed: the snapshot and the timeline's state
read back are the values it would have solved, to the bit (NetCDF float64 and JSON floats round-trip), so its
cycles are the same (``tests/cycle/test_start_state.py``). A file that cannot be read, or that holds another
key, is not taken: the run solves its start (the manifest's ``metadata.initial.start_state.solved``).
"""
from __future__ import annotations

import hashlib
import json
import tomllib
from pathlib import Path

import xarray as xr

#: attribute of a start-state file holding the timeline's state (JSON)
STATE_ATTRIBUTE = "start_state"
#: the tables and keys a start state does not depend on: the placement seed and the verdict check
IGNORED = (("closure", "seed"), ("check",))


def start_key(scenario_text: str) -> str:
    """SHA-256 (hex) of the scenario *scenario_text* without the keys of :data:`IGNORED`, with the package's
    version and git commit (:mod:`breachflow.provenance`): runs with the same key solve the same start."""
    from .. import provenance

    table = tomllib.loads(scenario_text)
    for path in IGNORED:
        node = table
        for part in path[:-1]:
            node = node.get(part, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict):
            node.pop(path[-1], None)
    ctx = {"scenario": table, "version": provenance.version(), "git": provenance.git_commit()}
    return hashlib.sha256(json.dumps(ctx, sort_keys=True, default=str).encode()).hexdigest()


def reusable(solver) -> bool:
    """True when *solver* (a closure setup's flow model) keeps no state between solves, so that a start
    solved by another run is the start this run would solve: its ``memoryless`` attribute (the embedded
    ``swe`` solver with its cold and warm settings re-solving the whole domain, directly or under the closure
    in time's timeline, which hands the attribute on); flow models without it do not share a start."""
    return bool(getattr(solver, "memoryless", False))


def path_of(store, key: str) -> Path:
    return Path(store) / f"{key}.nc"


def timeline_state(timeline) -> dict | None:
    """The timeline's state after the start's calibrations (JSON-able), None without a timeline."""
    if timeline is None:
        return None
    return {"state": timeline.state(), "history": list(timeline.history), "calibration": list(timeline.calibration),
            "window_calibration": dict(timeline.window_calibration)}


def restore_timeline(timeline, saved: dict | None) -> None:
    """Set *timeline* to the state :func:`timeline_state` recorded."""
    if timeline is None:
        return
    timeline.restore(saved["state"])
    timeline.history = list(saved["history"])
    timeline.calibration = list(saved["calibration"])
    timeline.window_calibration = dict(saved["window_calibration"])


def save(store, key: str, snapshot: xr.Dataset, timeline) -> Path:
    """Write the start state (*snapshot*, *timeline*'s state) to ``store/<key>.nc`` atomically."""
    from ..atomic import atomic_write_netcdf
    from ..io.cf import netcdf_encoding

    ds = snapshot.copy()
    ds.attrs = {**snapshot.attrs, STATE_ATTRIBUTE: json.dumps(timeline_state(timeline), default=_plain), "start_key": key,
                "title": "breachflow closure run: the steady open breach at the start of the closure"}
    path = path_of(store, key)
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_netcdf(ds, path, encoding=netcdf_encoding(ds))


def _plain(value):
    """numpy scalars as the Python numbers of the same value (JSON)."""
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON-able: {value!r}")


def load(store, key: str):
    """``(snapshot, timeline state)`` of ``store/<key>.nc``, or None when there is no such file or it cannot
    be read (then the run solves its start)."""
    path = path_of(store, key)
    if not path.is_file():
        return None
    try:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            if ds.attrs.get("start_key") != key:
                return None
            snapshot = ds.load()
        saved = json.loads(snapshot.attrs.pop(STATE_ATTRIBUTE))
    except (OSError, ValueError, KeyError, RuntimeError):
        return None
    snapshot.attrs.pop("start_key", None)
    return snapshot, saved
