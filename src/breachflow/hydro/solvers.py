"""Pluggable hydrodynamic solvers (docs/theory.md, *Shallow-water equations*, *The closure cycle*).

A solver is a class with one method, ``solve(domain, obstacles=None, initial=None) -> xr.Dataset``,
returning a grid snapshot (schema data_schemas/snapshot_grid.json). Built-ins: ``"swe"`` (the embedded shallow-water solver,
solved to incremental steady state) and ``"snapshot_frozen"`` (serves ingested ADH / HEC-RAS snapshots,
unchanged or one per cycle from a sequence: the flow does not respond to the pile; ``"snapshot"`` is
its deprecated old name). Third-party solvers register through the entry point
group ``breachflow.solvers``, as xarray backends do::

    [project.entry-points."breachflow.solvers"]
    mysolver = "mypkg.hydro:MySolver"

>>> solvers.create("swe", order=1).options.order
1
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Protocol, Sequence, runtime_checkable

import xarray as xr

from ..errors import BreachflowWarning, InputError
from ..registry import Registry


@runtime_checkable
class HydroSolver(Protocol):
    """Anything that turns a domain (+ obstacles, + a previous state) into a snapshot Dataset."""

    def solve(self, domain, obstacles=None, initial=None) -> xr.Dataset: ...


solvers: Registry = Registry("hydrodynamic solver", "breachflow.solvers")


@solvers.register("swe")
def _swe(**options):
    from ..swe.solver import SWESolver

    return SWESolver(**options)


#: what a frozen-flow run says in its log and output attributes
FROZEN_NOTE = ("the flow is the ingested snapshot served unchanged: it does not respond to the pile "
               "(no re-solve in cycle <g>, docs/theory.md, *The closure cycle*)")


@solvers.register("snapshot_frozen")
class SnapshotSolver:
    """Serve ingested snapshots: always the same one, or the next of a sequence on each ``solve`` call.
    The pile never changes the flow (``responds_to_pile = False``); every snapshot served carries
    ``flow_responds_to_pile = 0`` and ``hydro_mode = "snapshot_frozen"``.

    *snapshots*: a Dataset, a NetCDF path, or a sequence of them; a Dataset with a ``time`` dimension
    is a sequence of its time steps. After the last one the last is repeated (with a warning).
    The domain, obstacles and initial state are ignored: the external model already contains them.

    *frame* (:class:`~breachflow.site.frame.GridFrame`, turned) and *domain*: a site whose levee runs in
    any direction has its grid along the levee; each snapshot (on the CRS axes) is then served on that
    grid, sampled at the cells' map positions with velocities turned into the grid
    (:func:`~breachflow.hydro.nested.frame_snapshot`); otherwise it is served as ingested.
    """

    responds_to_pile = False
    mode = "snapshot_frozen"

    def __init__(self, snapshots=None, *, repeat_last: bool = True, domain=None, frame=None):
        if snapshots is None:
            raise InputError("snapshot solver: give snapshots= (a Dataset, a NetCDF path or a list of them)")
        items = list(snapshots) if isinstance(snapshots, (list, tuple)) else [snapshots]
        seq = []
        for item in items:
            ds = xr.open_dataset(item) if isinstance(item, (str, Path)) else item
            if not isinstance(ds, xr.Dataset):
                raise InputError(f"snapshot solver: {item!r} is not a Dataset or a NetCDF path")
            if "time" in ds.dims and ds.sizes["time"] > 1:
                seq.extend(ds.isel(time=k) for k in range(ds.sizes["time"]))
            else:
                seq.append(ds.isel(time=0) if "time" in ds.dims else ds)
        if not seq:
            raise InputError("snapshot solver: empty sequence of snapshots")
        self.frame = frame if frame is not None and frame.rotated else None
        if self.frame is not None:
            if domain is None:
                raise InputError("snapshot solver: a turned grid frame needs the domain to serve the snapshots on")
            from .nested import frame_snapshot

            seq = [frame_snapshot(ds, domain, self.frame) for ds in seq]
        for ds in seq:  # marked in place: the served Dataset is the ingested one itself
            ds.attrs.update(hydro_mode=self.mode, flow_responds_to_pile=0, hydro_note=FROZEN_NOTE)
        self.sequence = seq
        self.repeat_last = repeat_last
        self.calls = 0

    def solve(self, domain=None, obstacles=None, initial=None) -> xr.Dataset:
        k = self.calls
        self.calls += 1
        if k >= len(self.sequence):
            if not self.repeat_last:
                raise InputError(f"snapshot solver: only {len(self.sequence)} snapshot(s) for cycle {k + 1}")
            if len(self.sequence) > 1:
                warnings.warn(f"snapshot solver: cycle {k + 1} reuses the last of {len(self.sequence)} snapshots",
                              BreachflowWarning, stacklevel=2)
            k = len(self.sequence) - 1
        return self.sequence[k]


@solvers.register("snapshot")
def _deprecated_snapshot(**options):
    """Old name of ``snapshot_frozen`` (deprecated, warns)."""
    warnings.warn("hydrodynamic solver 'snapshot' is deprecated: it is 'snapshot_frozen' (" + FROZEN_NOTE + "); "
                  "use solver = 'snapshot_frozen', or 'nested' for a local model that re-solves with the pile",
                  DeprecationWarning, stacklevel=3)
    return SnapshotSolver(**options)


@solvers.register("nested")
def _nested(**options):
    from .nested import NestedSolver

    return NestedSolver(**options)
