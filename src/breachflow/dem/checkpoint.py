"""Checkpoints of the DEM driver (:class:`~breachflow.dem.simulation.DemSimulation`, whose ``save_state``,
``from_state`` and ``memory_bytes`` call these functions): :func:`save_state` / :func:`from_state` round-trip
everything for a bit-identical continuation (particles, forces, integrator work
arrays, sleep counters, the neighbour list with its live and parked histories, the boundaries, the memory
of the integrator and of the force models, :mod:`.memory`); ``memory_bytes`` counts what a simulation holds.
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np

from ..errors import InputError
from . import memory
from .boundaries import Plane
from .state import FLUID_FIELDS, ParticleState


#: the arrays a checkpoint holds (besides the particle state, work arrays and boundaries): the key after
#: ``sim.`` in the checkpoint -> (the component of the simulation holding it, or "" for the simulation
#: itself, the attribute); the keys are those of the checkpoints written before the neighbour list and the
#: sleeping were components, so those load too
SAVED_ARRAYS = {"force": ("", "force"), "torque": ("", "torque"), "_pos_build": ("pairs", "pos_build"),
                "_fm": ("", "_fm"), "_tm": ("", "_tm"), "_fm_sleep": ("sleepers", "fm_ref"),
                "_sleep_count": ("sleepers", "count"), "_wake_flag": ("sleepers", "wake_flag"),
                "_fixed": ("", "_fixed"), "_pa": ("pairs", "pa"), "_pb": ("pairs", "pb"),
                "_hist": ("pairs", "hist"), "_rhist": ("pairs", "rhist"), "_touch": ("pairs", "touch"),
                "_frozen_keys": ("pairs", "frozen_keys"), "_frozen_hist": ("pairs", "frozen_hist"),
                "geom": ("", "geom"), "ncell": ("", "ncell"), "periodic": ("", "periodic"), "_box": ("", "_box")}
#: the scalars a checkpoint holds, with their types (keys as :data:`SAVED_ARRAYS`)
SAVED_SCALARS = {"t": ("", "t", float), "steps": ("", "steps", int), "particle_steps": ("", "particle_steps", int),
                 "n_contacts": ("", "n_contacts", int), "_dt": ("", "_dt", float),
                 "dt_limit": ("", "dt_limit", float), "skin": ("", "skin", float),
                 "single_bin": ("", "single_bin", bool), "_dirty": ("pairs", "dirty", bool),
                 "_sleep_grid_dirty": ("pairs", "sleep_grid_dirty", bool),
                 "forces_stale": ("", "forces_stale", bool), "_use_box": ("", "_use_box", bool)}
#: what :func:`memory_bytes` counts besides :data:`SAVED_ARRAYS`
_SCRATCH = {"_wake_ids": ("sleepers", "wake_ids"), "_tmp_ids": ("", "_tmp_ids")}
#: the pair-list arrays that may be views into the compiled rebuild's buffers
_LIST = ("pa", "pb", "hist", "rhist", "touch")


def _owner(sim, part: str):
    return getattr(sim, part) if part else sim


def save_state(sim) -> dict[str, np.ndarray]:
    """Everything a bit-identical continuation needs, as a flat dict of numpy arrays (copies):
    the particle arrays (``state.*``), forces of the last step, integrator work arrays, sleep
    counters and wake references, the neighbour list with its shear / rolling histories (live and
    parked), the sleeping-particle grid, the boundaries' histories and motion (``boundary<k>.*``),
    ``t``, ``steps``, ``dt``, and the memory of the integrator and of force models with one
    (``integrator.*``, ``model<k>.*``, :mod:`.memory`). Force models themselves are not saved (they are
    passed again to :func:`from_state`, which restores their memory into them).
    Save with e.g. ``np.savez(path, **sim.save_state())``.
    """
    out: dict[str, np.ndarray] = {}
    for f in fields(sim.state):
        out["state." + f.name] = np.array(getattr(sim.state, f.name), copy=True)
    for key, (part, name) in SAVED_ARRAYS.items():
        out["sim." + key] = np.array(getattr(_owner(sim, part), name), copy=True)
    for key, (part, name, _) in SAVED_SCALARS.items():
        out["sim." + key] = np.array(getattr(_owner(sim, part), name))
    for k, a in sim.work.items():
        out["work." + k] = a.copy()
    out["sim.left_domain"] = np.asarray(sim.left_domain, np.int64)
    grid = sim.pairs.sgrid
    if grid is not None:
        for name, a in zip(("start", "ent_p", "ent_c"), grid[:3]):
            out["sgrid." + name] = a.copy()
        out["sgrid.bits"] = np.array(grid[3])
    out["n_boundaries"] = np.array(len(sim.boundaries))
    for k, b in enumerate(sim.boundaries):
        out[f"boundary{k}.hist"] = b.hist.copy()
        out[f"boundary{k}.rhist"] = b.rhist.copy()
        if isinstance(b, Plane):
            for name in ("point", "velocity", "reaction"):
                out[f"boundary{k}.{name}"] = getattr(b, name).copy()
    memory.save(sim.integrator, "integrator.", out)
    for k, m in enumerate(sim.models):
        memory.save(m, f"model{k}.", out)
    return out

def from_state(cls, data, *, boundaries=(), models=(), **kwargs):
    """A simulation of class *cls* continuing exactly from ``data`` (:func:`save_state`, or an ``np.load`` of it).

    *boundaries* must be the same kinds in the same order as when saved (their histories and plane
    motion are restored into them); *models* and the other keyword arguments are those of the
    constructor and should match the saved run (the time step and cell geometry are restored from
    *data* regardless). The integrator and the models get their saved memory back; one whose memory
    does not match the saved one (e.g. the Basset force on in one, off in the other) is an InputError.
    """
    try:
        # the per-particle fluid parameters are absent from states saved before they existed: the run's values
        state = ParticleState(**{f.name: np.array(data["state." + f.name]) for f in fields(ParticleState)
                                 if f.name not in FLUID_FIELDS or "state." + f.name in data})
        nb = int(data["n_boundaries"])
    except KeyError as e:
        raise InputError(f"DEM state lacks entry {e.args[0]!r} (not written by save_state?)") from None
    boundaries = list(boundaries)
    if nb != len(boundaries):
        raise InputError(f"DEM state was saved with {nb} boundaries, {len(boundaries)} given")
    sim = cls(state, boundaries=boundaries, models=models, **kwargs)
    for key, (part, name) in SAVED_ARRAYS.items():
        setattr(_owner(sim, part), name, np.array(data["sim." + key], copy=True))
    for key, (part, name, typ) in SAVED_SCALARS.items():
        setattr(_owner(sim, part), name, typ(data["sim." + key][()]))
    for k in sim.work:
        if "work." + k in data:
            sim.work[k] = np.array(data["work." + k], copy=True)
    for k, f in (("fp", "force"), ("tp", "torque")):  # saved before the force trend was kept: none
        if "work." + k not in data:
            sim.work[k] = np.array(data["sim." + f], copy=True)
    sim.left_domain = [int(i) for i in data["sim.left_domain"]]
    if "sgrid.start" in data:
        sim.pairs.sgrid = tuple(np.array(data["sgrid." + n], copy=True) for n in ("start", "ent_p", "ent_c")) + (
            int(data["sgrid.bits"][()]),)
    for k, b in enumerate(boundaries):
        if isinstance(b, Plane) != (f"boundary{k}.point" in data):
            raise InputError(f"boundary {k} is not of the kind saved")
        b.hist = np.array(data[f"boundary{k}.hist"], copy=True)
        b.rhist = np.array(data[f"boundary{k}.rhist"], copy=True)
        if isinstance(b, Plane):
            for name in ("point", "velocity", "reaction"):
                setattr(b, name, np.array(data[f"boundary{k}.{name}"], copy=True))
    memory.restore(sim.integrator, "integrator.", data, "integrator")
    for k, m in enumerate(sim.models):
        memory.restore(m, f"model{k}.", data, f"force model {k}")
    beyond = [k for k in data if k.startswith("model") and not k.startswith(tuple(f"model{j}." for j in
                                                                                 range(len(sim.models))))]
    if beyond:
        raise InputError(f"DEM state holds {', '.join(sorted(beyond))} of force models beyond the "
                         f"{len(sim.models)} given")
    sim._inv_m = 1.0 / sim.state.mass
    sim._inv_i = 1.0 / sim.state.inertia
    sim._refresh_idx()
    return sim

def memory_bytes(sim) -> int:
    """Bytes held by the particle state, work arrays, neighbour list and histories."""
    total = sim.state.nbytes() + sum(a.nbytes for a in sim.work.values())
    for key, (part, name) in {**SAVED_ARRAYS, **_SCRATCH}.items():
        if key not in ("geom", "ncell", "periodic", "_box"):
            total += getattr(_owner(sim, part), name).nbytes
    pl = sim.pairs
    for g in (pl.agrid, pl.sgrid):
        if g is not None:
            total += sum(a.nbytes for a in g[:3])
    total += sum(b.hist.nbytes + b.rhist.nbytes for b in sim.boundaries)
    bufs = pl.bufs or ()  # the list's capacity: the live list may be a view into it
    total += sum(a.nbytes for a in bufs)
    total -= sum(getattr(pl, name).nbytes for name in _LIST
                 if any(np.may_share_memory(getattr(pl, name), a) for a in bufs))
    return total
