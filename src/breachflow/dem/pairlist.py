"""The DEM driver's neighbour list (:class:`~breachflow.dem.simulation.DemSimulation`, docs/theory.md, *DEM contact*): the pair
list, its rebuild and the pair histories it carries.

Pairs closer than ``skin`` are listed (hashed cell grid, :mod:`.pair_contacts`; dense bins, :mod:`.neighbours`)
and reused until some awake particle has moved more than ``skin/2`` (less the step-averaged law's reach
``dt/2 max|v|``: ``relist_after_drift``) or particles fell asleep / woke / were inserted. Each pair keeps its shear history across steps and across rebuilds; when both partners
sleep the history is parked in a sorted "frozen" store and restored when one wakes (:mod:`.sleeping`).
Each listed pair keeps a shear history (``hist``, m) and a rolling-moment history (``rhist``, N m, for
``rolling_friction`` > 0, :func:`.contact_law.rolling_law`); both are parked and restored together.
The numba kernels are in :mod:`.neighbours` and :mod:`.pair_contacts`; this module holds the driver's
bookkeeping around them: :class:`PairList`, the component ``DemSimulation.pairs``.
"""
from __future__ import annotations

import math

import numpy as np

from . import neighbours, pair_contacts

_EMPTY_I = np.zeros(0, np.int64)
_EMPTY_GRID = (np.zeros(2, np.int64), _EMPTY_I, _EMPTY_I, 0)


class PairList:
    """The neighbour list of a :class:`~breachflow.dem.simulation.DemSimulation` (its ``pairs``).

    It reads the scene it serves (*sim*: particle state, awake ids ``idx``, ``skin``, cell geometry) and
    owns the list: ``pa``/``pb`` (sorted pair ids), ``hist`` (shear history, m) and ``rhist`` (rolling
    history, N m) per pair, ``touch``; ``frozen_keys``/``frozen_hist`` (histories parked while both
    partners sleep); ``pos_build`` (positions at the last build); ``sgrid`` (cell grid of the sleeping
    particles, None before the first build), ``agrid``, ``bufs`` (the compiled rebuild's buffers); and
    the flags ``dirty`` (rebuild at the next step) and ``sleep_grid_dirty`` (the sleeping grid is out
    of date: a sleep, wake, insertion or retirement since it was built)."""

    def __init__(self, sim):
        self.sim = sim
        self.pa = self.pb = _EMPTY_I
        self.hist = np.zeros((0, 3))
        self.rhist = np.zeros((0, 3))
        self.touch = np.zeros(0, bool)
        self.frozen_keys = np.zeros(0, np.int64)
        self.frozen_hist = np.zeros((0, 6))  # parked (shear, rolling) histories
        self.pos_build = np.zeros((0, 3))
        self.sgrid = None
        self.agrid = None
        self.bufs = None
        self.dirty = True
        self.sleep_grid_dirty = True

    def resize(self, n: int) -> None:
        """Room for *n* particles (``pos_build`` grows, keeping its rows)."""
        new = np.zeros((n, 3))
        new[: self.pos_build.shape[0]] = self.pos_build
        self.pos_build = new

    def invalidate(self) -> None:
        """An event (insertion, sleep, wake, retirement, new geometry): full rebuild at the next step."""
        self.dirty = True
        self.sleep_grid_dirty = True

    def relist_after_drift(self, reach: float = 0.0):
        """The rebuild check of a step, after its drift and before its force evaluation, as LAMMPS' Verlet
        (``neighbor->decide()`` after the drift): a check before the drift lets the forces see positions up to
        ``skin/2 + |v| dt`` from the build, so two spheres that each moved nearly ``skin/2`` toward each
        other could touch while unlisted. *reach* (m, :meth:`DemSimulation.interval_reach <breachflow.dem.simulation.DemSimulation.interval_reach>` times the largest speed the law
        uses: the step displacement over ``dt`` for velocity Verlet, the predicted speed for predicted Verlet,
        as ``fluid_verlet_steps``): how far beyond its gap the step-averaged law looks for any particle.
        The list is rebuilt when ``moved + reach > skin/2``: an unlisted pair was more than ``skin`` apart
        at the build, so it is still more than ``2 reach >= max(-lo, hi) dt |v_rel . n|`` apart and gets no
        force in the interval either (with ``moved`` alone, a pair apart by less than the reach got its
        partial-interval force one step late).
        The rebuild is the compiled loop's (``fluid_verlet_steps``):
        :func:`.neighbours.rebuild` on the current sleeping grid, so both paths keep the same list; when
        awake particles left the domain in this drift (the grid of the sleepers is still right) the flags
        stay set for the next step's full rebuild, as after the compiled loop's LEFT event."""
        sim = self.sim
        s = sim.state
        if neighbours.displacement_since(sim.idx, s.pos, self.pos_build, sim.geom,
                                         sim.periodic) + reach > 0.5 * sim.skin:
            if self.sleep_grid_dirty and self.sgrid is not None:
                self.rebuild_list()
            else:
                self.rebuild()

    def relist_inline(self) -> bool:
        """Whether the pair list can be rebuilt by :func:`.neighbours.rebuild` (also inside the compiled
        many-steps loops): the sleeping grid is current (no sleep, wake or retirement since it was built),
        or there is no sleeping particle and no parked history (then the grid is rebuilt empty), so no
        history has to be parked or restored."""
        sim = self.sim
        s = sim.state
        if not self.sleep_grid_dirty and self.sgrid is not None:
            return True
        return bool(sim.single_bin and self.frozen_keys.size == 0 and not (s.active & ~s.awake).any())

    def relist(self):
        """The rebuild of :meth:`relist_inline`: the same compiled :func:`.neighbours.rebuild` as the
        many-steps loops, so the pair list is the same on both paths."""
        if self.sleep_grid_dirty:
            self.sgrid = self.grid(_EMPTY_I)
        self.rebuild_list()
        self.dirty = False
        self.sleep_grid_dirty = False

    def rebuild_list(self):
        """:func:`.neighbours.rebuild` of the awake particles on the sleeping grid ``sgrid`` as it is."""
        sim = self.sim
        s = sim.state
        bufs = self.bufs or neighbours.empty_buffers()
        self.pa, self.pb, self.hist, self.rhist, self.touch, self.bufs = neighbours.rebuild(
            sim.idx, s.pos, s.radius, 0.5 * sim.skin, sim.geom, sim.periodic, sim.ncell, bool(sim.single_bin),
            self.sgrid, self.pa, self.pb, self.hist, self.rhist, self.pos_build, bufs)

    def rebuild(self):
        """Rebuild the pair list: between events ``relist``; after a sleep, wake or retirement (the
        sleeping grid is out of date) re-bin the sleepers, restore parked histories of pairs found again
        and park those of pairs whose partners now both sleep."""
        sim = self.sim
        if self.relist_inline():
            return self.relist()
        s = sim.state
        sleep_idx = np.flatnonzero(~s.awake & s.active).astype(np.int64)
        self.sgrid = self.grid(sleep_idx)
        self.agrid = self.grid(sim.idx)
        pa, pb = self.find(sim.idx, self.agrid, self.sgrid)
        n = pa.size
        keys = (pa[:n] << 32) | pb[:n]
        if sim.single_bin and self.sgrid[1].size == 0:
            keys = np.sort(keys)  # one cell per particle, one grid: each pair is found once
        else:  # a woken particle may still sit in the (stale) sleeping grid as well as in the awake one
            keys = np.unique(keys)
        n = keys.size
        new_hist = np.zeros((n, 6))
        old_keys = (self.pa << 32) | self.pb
        old_hist = np.concatenate([self.hist, self.rhist], axis=1)  # (shear, rolling) per pair
        if self.frozen_keys.size:
            src_keys = np.concatenate([old_keys, self.frozen_keys])
            src_hist = np.concatenate([old_hist, self.frozen_hist])
            o = np.argsort(src_keys, kind="stable")
            src_keys, src_hist = src_keys[o], src_hist[o]
        else:
            src_keys, src_hist = old_keys, old_hist  # old list is sorted
        if src_keys.size and n:
            loc = np.minimum(np.searchsorted(src_keys, keys), src_keys.size - 1)
            hit = src_keys[loc] == keys
            new_hist[hit] = src_hist[loc[hit]]
        if src_keys.size:  # park the histories of pairs that are now between two sleeping particles
            in_new = np.zeros(src_keys.size, bool)
            if n:
                loc2 = np.minimum(np.searchsorted(keys, src_keys), max(n - 1, 0))
                in_new = keys[loc2] == src_keys
            a, b = src_keys >> 32, src_keys & 0xFFFFFFFF
            park = (~in_new & ~s.awake[a] & ~s.awake[b] & s.active[a] & s.active[b]
                    & np.any(src_hist != 0.0, axis=1))
            self.frozen_keys, self.frozen_hist = src_keys[park], src_hist[park]
        self.pa, self.pb = keys >> 32, keys & 0xFFFFFFFF
        self.hist = np.ascontiguousarray(new_hist[:, :3])
        self.rhist = np.ascontiguousarray(new_hist[:, 3:])
        self.touch = np.zeros(n, bool)
        self.pos_build[sim.idx] = s.pos[sim.idx]
        self.dirty = False
        self.sleep_grid_dirty = False

    def find(self, search, grid_a, grid_s):
        sim = self.sim
        s = sim.state
        cap = max(64, 16 * search.size)
        while True:
            pa = np.empty(cap, np.int64)
            pb = np.empty(cap, np.int64)
            n = pair_contacts.find_pairs(search, s.pos, s.radius, 0.5 * sim.skin, sim.geom, sim.periodic, sim.ncell,
                                    *grid_a, *grid_s, sim.single_bin, pa, pb)
            if n <= cap:
                return pa[:n], pb[:n]
            cap = int(n * 1.2) + 16

    def grid(self, idx):
        sim = self.sim
        est = max(1024, 16 * idx.size)
        bits = int(math.ceil(math.log2(est)))
        start, ep, ec = pair_contacts.build_grid(idx, sim.state.pos, sim.state.radius, 0.5 * sim.skin, sim.geom,
                                            sim.periodic, sim.ncell, bits, sim.single_bin)
        return start, ep, ec, bits

    def on_sleep(self):
        """New sleepers: re-bin the sleeping particles (O(N_sleep), once per sleep_check batch) and park
        the histories of listed pairs whose partners now both sleep; no new pair search is needed."""
        if self.dirty or self.sleep_grid_dirty or self.sgrid is None:
            self.dirty = True
            self.sleep_grid_dirty = True
            return
        s = self.sim.state
        self.sgrid = self.grid(np.flatnonzero(~s.awake & s.active).astype(np.int64))
        both = ~s.awake[self.pa] & ~s.awake[self.pb]
        if not both.any():
            return
        pair_hist = np.concatenate([self.hist, self.rhist], axis=1)
        park = both & np.any(pair_hist != 0.0, axis=1)
        if park.any():
            keys = (self.pa[park] << 32) | self.pb[park]
            at = np.searchsorted(self.frozen_keys, keys)
            self.frozen_keys = np.insert(self.frozen_keys, at, keys)
            self.frozen_hist = np.insert(self.frozen_hist, at, pair_hist[park], axis=0)
        keep = ~both
        self.pa, self.pb = self.pa[keep], self.pb[keep]
        self.hist, self.rhist = self.hist[keep], self.rhist[keep]
        self.touch = self.touch[keep]

    def attach_woken(self, ids):
        """Add the pairs of freshly woken particles with sleeping ones (their pairs with awake particles
        are listed already), restoring parked histories: O(woken + awake pairs), no O(N) rebuild."""
        if self.dirty or self.sleep_grid_dirty or self.sgrid is None:
            return  # a full rebuild is due anyway
        pa, pb = self.find(ids, _EMPTY_GRID, self.sgrid)
        keys = np.unique((pa << 32) | pb)
        old = (self.pa << 32) | self.pb
        if old.size and keys.size:
            loc = np.minimum(np.searchsorted(old, keys), old.size - 1)
            keys = keys[old[loc] != keys]
        if keys.size == 0:
            return
        hist = np.zeros((keys.size, 6))
        fk = self.frozen_keys
        if fk.size:
            loc = np.minimum(np.searchsorted(fk, keys), fk.size - 1)
            hit = fk[loc] == keys
            hist[hit] = self.frozen_hist[loc[hit]]
            keep = np.ones(fk.size, bool)
            keep[loc[hit]] = False
            self.frozen_keys, self.frozen_hist = fk[keep], self.frozen_hist[keep]
        allk = np.concatenate([old, keys])
        order = np.argsort(allk, kind="stable")
        merged = np.concatenate([np.concatenate([self.hist, self.rhist], axis=1), hist])[order]
        self.hist = np.ascontiguousarray(merged[:, :3])
        self.rhist = np.ascontiguousarray(merged[:, 3:])
        allk = allk[order]
        self.pa, self.pb = allk >> 32, allk & 0xFFFFFFFF
        self.touch = np.zeros(allk.size, bool)
