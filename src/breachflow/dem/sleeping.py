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
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import pair_contacts
from .boundaries import Plane
from .pairlist import _EMPTY_GRID


class SleepingMixin:
    """Sleeping and waking of :class:`~breachflow.dem.simulation.DemSimulation` (its methods are
    documented there), with the pair-list bookkeeping of new sleepers and woken particles."""

    def sleep(self, ids) -> np.ndarray:
        """Put particles *ids* to sleep now (e.g. masses that were at rest at the end of the previous
        cycle); returns the ids actually put to sleep (active, not fixed).

        Like the automatic transition (docs/theory.md, *DEM contact* sleeping): velocities and spins are zeroed (also the
        previous-step ones the report scheme uses); they are no longer integrated but remain contact
        partners. The force models' force on each is evaluated now, at rest, and kept as the reference of
        the wake-by-force check, so they wake only on a real change of that force (more than
        ``wake_force_fraction`` of the weight), when a moving particle (contact-point speed above
        ``wake_velocity``) or a moving boundary touches them. The neighbour list is rebuilt at the next
        step, parking the (shear, rolling) histories of pairs whose partners now both sleep.
        """
        s = self.state
        ids = np.unique(np.asarray(ids, np.int64).ravel())
        if ids.size and (ids[0] < 0 or ids[-1] >= s.n):
            raise InputError(f"sleep: particle ids must be in [0, {s.n}), got {ids[0]}..{ids[-1]}")
        ids = ids[s.active[ids] & ~self._fixed[ids]]
        if ids.size == 0:
            return ids
        s.awake[ids] = False
        for a in (s.vel, s.omega, s.vel_prev, s.omega_prev, self.work["v"], self.work["w"]):
            a[ids] = 0.0
        self._sleep_count[ids] = 0
        self._wake_flag[ids] = False
        if self.models:
            fm, tm = np.zeros((s.n, 3)), np.zeros((s.n, 3))
            for m in self.models:
                m.accumulate(s, s.pos, s.vel, s.omega, self.t, fm, tm)
            self._fm_sleep[ids] = fm[ids]
        self._dirty = self._sleep_grid_dirty = True
        self._refresh_idx()
        return ids

    def _wake(self, ids):
        if len(ids) == 0:
            return 0
        s = self.state
        ids = np.asarray(ids, np.int64)
        ids = ids[~self._fixed[ids]]
        if ids.size == 0:
            return 0
        s.awake[ids] = True
        self._wake_flag[ids] = False
        self._sleep_count[ids] = 0
        # a sleeping particle was in equilibrium: its net force (hence a(t) for the Verlet kick) is ~0;
        # refreshing F(t) exactly would cost one contact evaluation per wake event
        self.force[ids] = 0.0
        self.torque[ids] = 0.0
        self.work["fp"][ids] = 0.0  # previous-step force (predicted_verlet's trend): none
        self.work["tp"][ids] = 0.0
        self._pos_build[ids] = s.pos[ids]
        self.idx = np.union1d(self.idx, ids).astype(np.int64)
        self._attach_woken(ids)
        return ids.size

    def _sleep_and_wake(self):
        s = self.state
        changed = False
        nw = int(self._n_wake[0])
        if nw:
            ids = self._wake_ids[:nw].copy()
            self._wake_flag[ids] = False
            self._wake(ids)
        if self.models and not self.static_models:
            self._wake_by_force()
        # transitions to sleep only every sleep_check steps: one O(N) regrid per batch of sleepers
        ns = pair_contacts.sleep_update(self.idx, s.vel, s.omega, s.vel_prev, s.omega_prev, s.radius, self.sleep_velocity,
                                   self.sleep_steps, self._sleep_count, s.awake, self._tmp_ids,
                                   self.steps % self.sleep_check == 0)
        if ns:
            self._after_sleep(ns)

    def _after_sleep(self, ns):
        """Bookkeeping of the *ns* particles that just fell asleep (listed in ``_tmp_ids``)."""
        s = self.state
        ids = self._tmp_ids[:ns]
        self._fm_sleep[ids] = self._fm[ids]
        self.idx = self.idx[s.awake[self.idx]]
        self._on_sleep()

    def _wake_by_force(self):
        """Wake sleepers whose force-model force (last evaluated into ``_fm``) moved away from the value
        recorded when they fell asleep by more than ``wake_force_fraction`` of their weight."""
        s = self.state
        asleep = np.flatnonzero(~s.awake & s.active)
        if asleep.size:
            dF = np.linalg.norm(self._fm[asleep] - self._fm_sleep[asleep], axis=1)
            woke = asleep[dF > self.wake_force_fraction * s.mass[asleep] * np.linalg.norm(self.gravity.g)]
            self._wake(woke)

    def _wake_from_boundaries(self):
        s = self.state
        for b in self.boundaries:
            if b.moving and isinstance(b, Plane):
                asleep = np.flatnonzero(~s.awake & s.active)
                if asleep.size:
                    gap = (s.pos[asleep] - b.point) @ b.normal - s.radius[asleep]
                    touching = asleep[gap < self.skin]
                    self._wake(touching)

    def wake_all(self):
        s = self.state
        self._dirty = self._sleep_grid_dirty = True
        self._wake(np.flatnonzero(~s.awake & s.active & ~self._fixed))

    def _on_sleep(self):
        """New sleepers: re-bin the sleeping particles (O(N_sleep), once per sleep_check batch) and park
        the histories of listed pairs whose partners now both sleep; no new pair search is needed."""
        if self._dirty or self._sleep_grid_dirty or not hasattr(self, "_sgrid"):
            self._dirty = True
            self._sleep_grid_dirty = True
            return
        s = self.state
        self._sgrid = self._grid(np.flatnonzero(~s.awake & s.active).astype(np.int64))
        both = ~s.awake[self._pa] & ~s.awake[self._pb]
        if not both.any():
            return
        pair_hist = np.concatenate([self._hist, self._rhist], axis=1)
        park = both & np.any(pair_hist != 0.0, axis=1)
        if park.any():
            keys = (self._pa[park] << 32) | self._pb[park]
            at = np.searchsorted(self._frozen_keys, keys)
            self._frozen_keys = np.insert(self._frozen_keys, at, keys)
            self._frozen_hist = np.insert(self._frozen_hist, at, pair_hist[park], axis=0)
        keep = ~both
        self._pa, self._pb = self._pa[keep], self._pb[keep]
        self._hist, self._rhist = self._hist[keep], self._rhist[keep]
        self._touch = self._touch[keep]

    def _attach_woken(self, ids):
        """Add the pairs of freshly woken particles with sleeping ones (their pairs with awake particles
        are listed already), restoring parked histories: O(woken + awake pairs), no O(N) rebuild."""
        if self._dirty or self._sleep_grid_dirty or not hasattr(self, "_sgrid"):
            return  # a full rebuild is due anyway
        pa, pb = self._find(ids, _EMPTY_GRID, self._sgrid)
        keys = np.unique((pa << 32) | pb)
        old = (self._pa << 32) | self._pb
        if old.size and keys.size:
            loc = np.minimum(np.searchsorted(old, keys), old.size - 1)
            keys = keys[old[loc] != keys]
        if keys.size == 0:
            return
        hist = np.zeros((keys.size, 6))
        fk = self._frozen_keys
        if fk.size:
            loc = np.minimum(np.searchsorted(fk, keys), fk.size - 1)
            hit = fk[loc] == keys
            hist[hit] = self._frozen_hist[loc[hit]]
            keep = np.ones(fk.size, bool)
            keep[loc[hit]] = False
            self._frozen_keys, self._frozen_hist = fk[keep], self._frozen_hist[keep]
        allk = np.concatenate([old, keys])
        order = np.argsort(allk, kind="stable")
        merged = np.concatenate([np.concatenate([self._hist, self._rhist], axis=1), hist])[order]
        self._hist = np.ascontiguousarray(merged[:, :3])
        self._rhist = np.ascontiguousarray(merged[:, 3:])
        allk = allk[order]
        self._pa, self._pb = allk >> 32, allk & 0xFFFFFFFF
        self._touch = np.zeros(allk.size, bool)
