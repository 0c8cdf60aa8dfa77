"""Sleeping and waking in the DEM driver (:class:`~breachflow.dem.simulation.DemSimulation`, docs/theory.md, *DEM contact*).

An awake particle whose speed and ``r |w|`` stay below ``sleep_velocity`` for
``sleep_steps`` consecutive steps is put to sleep (transitions are applied every ``sleep_check``
steps, so that one O(N) re-binning serves a batch of new sleepers) (not integrated, velocity zero, still a contact
partner). It is woken when a moving particle (contact-point speed above ``wake_velocity``, default
10 ``sleep_velocity``) touches it, when a moving boundary touches it, or when the force models' force on it changes by more than
``wake_force_fraction`` of its weight. Per-step work is proportional to the awake particles and their
pairs; the O(N) work (re-binning sleeping particles, merging parked histories) happens only when
particles fall asleep or wake. :meth:`DemSimulation.sleep <breachflow.dem.simulation.DemSimulation.sleep>`
puts given particles to sleep at once (the cycle's masses that rested at the end of the previous cycle).

:class:`Sleepers` is the component ``DemSimulation.sleepers``; the parking and restoring of the pair
histories is the neighbour list's (:meth:`.pairlist.PairList.on_sleep`, :meth:`.pairlist.PairList.attach_woken`).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import pair_contacts
from .boundaries import Plane


class Sleepers:
    """Sleeping and waking of a :class:`~breachflow.dem.simulation.DemSimulation` (its ``sleepers``).

    It reads the scene it serves (*sim*: particle state, awake ids ``idx``, force models, boundaries and
    the sleep settings ``sleep_velocity``, ``sleep_steps``, ``sleep_check``, ``wake_force_fraction``) and
    owns, per particle: ``count`` (consecutive slow steps), ``wake_flag``, ``fm_ref`` (the force models'
    force when it fell asleep, the reference of the wake-by-force check), and the wake list ``wake_ids``
    with its length ``n_wake`` (filled by the contact kernels)."""

    def __init__(self, sim):
        self.sim = sim
        self.count = np.zeros(0, np.int64)
        self.wake_flag = np.zeros(0, bool)
        self.fm_ref = np.zeros((0, 3))
        self.wake_ids = np.zeros(0, np.int64)
        self.n_wake = np.zeros(1, np.int64)

    def resize(self, n: int) -> None:
        """Room for *n* particles (the per-particle arrays grow, keeping their rows)."""
        for name, shape in (("count", (n,)), ("wake_flag", (n,)), ("fm_ref", (n, 3)), ("wake_ids", (n,))):
            old = getattr(self, name)
            new = np.zeros(shape, old.dtype)
            new[: old.shape[0]] = old
            setattr(self, name, new)

    def sleep(self, ids) -> np.ndarray:
        """:meth:`DemSimulation.sleep <breachflow.dem.simulation.DemSimulation.sleep>`."""
        sim = self.sim
        s = sim.state
        ids = np.unique(np.asarray(ids, np.int64).ravel())
        if ids.size and (ids[0] < 0 or ids[-1] >= s.n):
            raise InputError(f"sleep: particle ids must be in [0, {s.n}), got {ids[0]}..{ids[-1]}")
        ids = ids[s.active[ids] & ~sim._fixed[ids]]
        if ids.size == 0:
            return ids
        s.awake[ids] = False
        for a in (s.vel, s.omega, s.vel_prev, s.omega_prev, sim.work["v"], sim.work["w"]):
            a[ids] = 0.0
        self.count[ids] = 0
        self.wake_flag[ids] = False
        if sim.models:
            fm, tm = np.zeros((s.n, 3)), np.zeros((s.n, 3))
            for m in sim.models:
                m.accumulate(s, s.pos, s.vel, s.omega, sim.t, fm, tm)
            self.fm_ref[ids] = fm[ids]
        sim.pairs.invalidate()
        sim._refresh_idx()
        return ids

    def wake(self, ids):
        """Wake particles *ids* (not the fixed ones); returns how many."""
        if len(ids) == 0:
            return 0
        sim = self.sim
        s = sim.state
        ids = np.asarray(ids, np.int64)
        ids = ids[~sim._fixed[ids]]
        if ids.size == 0:
            return 0
        s.awake[ids] = True
        self.wake_flag[ids] = False
        self.count[ids] = 0
        # a sleeping particle was in equilibrium: its net force (hence a(t) for the Verlet kick) is ~0;
        # refreshing F(t) exactly would cost one contact evaluation per wake event
        sim.force[ids] = 0.0
        sim.torque[ids] = 0.0
        sim.work["fp"][ids] = 0.0  # previous-step force (predicted_verlet's trend): none
        sim.work["tp"][ids] = 0.0
        sim.pairs.pos_build[ids] = s.pos[ids]
        sim.idx = np.union1d(sim.idx, ids).astype(np.int64)
        sim.pairs.attach_woken(ids)
        return ids.size

    def sleep_and_wake(self):
        """After a step: wake the particles the contact kernels flagged and those whose force-model force
        changed, then (every ``sleep_check`` steps) put the slow ones to sleep."""
        sim = self.sim
        s = sim.state
        nw = int(self.n_wake[0])
        if nw:
            ids = self.wake_ids[:nw].copy()
            self.wake_flag[ids] = False
            self.wake(ids)
        if sim.models and not sim.static_models:
            self.wake_by_force()
        # transitions to sleep only every sleep_check steps: one O(N) regrid per batch of sleepers
        ns = pair_contacts.sleep_update(sim.idx, s.vel, s.omega, s.vel_prev, s.omega_prev, s.radius,
                                        sim.sleep_velocity, sim.sleep_steps, self.count, s.awake, sim._tmp_ids,
                                        sim.steps % sim.sleep_check == 0)
        if ns:
            self.after_sleep(ns)

    def after_sleep(self, ns):
        """Bookkeeping of the *ns* particles that just fell asleep (listed in ``DemSimulation._tmp_ids``)."""
        sim = self.sim
        s = sim.state
        ids = sim._tmp_ids[:ns]
        self.fm_ref[ids] = sim._fm[ids]
        sim.idx = sim.idx[s.awake[sim.idx]]
        sim.pairs.on_sleep()

    def wake_by_force(self):
        """Wake sleepers whose force-model force (last evaluated into ``DemSimulation._fm``) moved away from
        the value recorded when they fell asleep by more than ``wake_force_fraction`` of their weight."""
        sim = self.sim
        s = sim.state
        asleep = np.flatnonzero(~s.awake & s.active)
        if asleep.size:
            dF = np.linalg.norm(sim._fm[asleep] - self.fm_ref[asleep], axis=1)
            woke = asleep[dF > sim.wake_force_fraction * s.mass[asleep] * np.linalg.norm(sim.gravity.g)]
            self.wake(woke)

    def wake_from_boundaries(self):
        """Wake sleepers within ``skin`` of a moving plane."""
        sim = self.sim
        s = sim.state
        for b in sim.boundaries:
            if b.moving and isinstance(b, Plane):
                asleep = np.flatnonzero(~s.awake & s.active)
                if asleep.size:
                    gap = (s.pos[asleep] - b.point) @ b.normal - s.radius[asleep]
                    touching = asleep[gap < sim.skin]
                    self.wake(touching)

    def wake_all(self):
        """Wake every sleeping particle that is not fixed."""
        sim = self.sim
        s = sim.state
        sim.pairs.invalidate()
        self.wake(np.flatnonzero(~s.awake & s.active & ~sim._fixed))
