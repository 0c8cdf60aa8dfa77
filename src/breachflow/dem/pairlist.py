"""The DEM driver's neighbour list (:class:`~breachflow.dem.simulation.DemSimulation`, docs/theory.md, *DEM contact*): the pair
list, its rebuild and the pair histories it carries; the wrap / retirement check after each drift.

Pairs closer than ``skin`` are listed (hashed cell grid, :mod:`.pair_contacts`; dense bins, :mod:`.neighbours`)
and reused until some awake particle has moved more than ``skin/2`` (less the window-averaged law's reach
``dt/2 max|v|``: ``relist_after_drift``) or particles fell asleep / woke / were inserted. Each pair keeps its shear history across steps and across rebuilds; when both partners
sleep the history is parked in a sorted "frozen" store and restored when one wakes (:mod:`.sleeping`).
Each listed pair keeps a shear history (``_hist``, m) and a rolling-moment history (``_rhist``, N m, for
``rolling_friction`` > 0, :func:`.contact_law.rolling_law`); both are parked and restored together.
The numba kernels are in :mod:`.neighbours` and :mod:`.pair_contacts`; this module holds the driver's
bookkeeping around them, as a mixin of :class:`~breachflow.dem.simulation.DemSimulation`.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import PhysicsError
from . import neighbours, pair_contacts
from .contact_law import WINDOW_AVERAGED

_EMPTY_I = np.zeros(0, np.int64)
_EMPTY_GRID = (np.zeros(2, np.int64), _EMPTY_I, _EMPTY_I, 0)


class PairListMixin:
    """The neighbour list of :class:`~breachflow.dem.simulation.DemSimulation` (its methods are
    documented there): the pair list with its shear / rolling histories, its rebuild, the cell grids."""

    def after_drift(self, relist: bool = True):
        """Wrap periodic coordinates, retire particles that left the domain, refuse NaN; then, before the
        forces at these positions, rebuild the pair list if some awake particle moved more than ``skin/2``
        since the build (``relist_after_drift``; *relist* False: the caller does it, with the window's reach,
        once it knows the velocities the contact law will use)."""
        s = self.state
        nleft, bad = neighbours.wrap_and_check(self.idx, s.pos, s.vel, s.omega, self.geom, self.periodic, self._box,
                                             self._use_box, s.active, s.awake, self._tmp_ids)
        if bad >= 0:
            raise PhysicsError(
                f"particle {bad} has a non-finite position/velocity at t={self.t:.6g} s; the time step "
                f"{self._dt:.3g} s (stable limit {self.dt_limit:.3g} s) or the inputs are unstable")
        if nleft:
            self.left_domain.extend(int(i) for i in self._tmp_ids[:nleft])
            self.idx = self.idx[s.active[self.idx]]
            self._dirty = True
            self._sleep_grid_dirty = True
        if relist:
            self.relist_after_drift()

    def window_reach(self, window) -> float:
        """How far ahead in time (s) the contact law looks with the force *window* ``(lo, hi)`` in steps:
        ``max(-lo, hi) dt`` for the window-averaged law (it gives a force to a pair apart by less than
        ``max(-lo, hi) dt |v_rel . n|``, :func:`.contact_law.contact_law`), 0 for point values. Times the
        largest speed the law uses, the reach of :meth:`relist_after_drift`."""
        return max(-(window[0] * self._dt), window[1] * self._dt) if self._law == WINDOW_AVERAGED else 0.0

    def relist_after_drift(self, reach: float = 0.0):
        """The rebuild check of a step, after its drift and before its force evaluation, as LAMMPS' Verlet
        (``neighbor->decide()`` after the drift): a check before the drift lets the forces see positions up to
        ``skin/2 + |v| dt`` from the build, so two spheres that each moved nearly ``skin/2`` toward each
        other could touch while unlisted. *reach* (m, :meth:`window_reach` times the largest speed the law
        uses: the step displacement over ``dt`` for velocity Verlet, the predicted speed for predicted Verlet,
        as ``fluid_verlet_steps``): how far beyond its gap the window-averaged law looks for any particle.
        The list is rebuilt when ``moved + reach > skin/2``: an unlisted pair was more than ``skin`` apart
        at the build, so it is still more than ``2 reach >= max(-lo, hi) dt |v_rel . n|`` apart and gets no
        force in the window either (with ``moved`` alone, a pair apart by less than the reach got its
        partial-window force one step late).
        The rebuild is the compiled loop's (``fluid_verlet_steps``):
        :func:`.neighbours.rebuild` on the current sleeping grid, so both paths keep the same list; when
        awake particles left the domain in this drift (the grid of the sleepers is still right) the flags
        stay set for the next step's full rebuild, as after the compiled loop's LEFT event."""
        s = self.state
        if neighbours.displacement_since(self.idx, s.pos, self._pos_build, self.geom,
                                         self.periodic) + reach > 0.5 * self.skin:
            if self._sleep_grid_dirty and hasattr(self, "_sgrid"):
                self._rebuild_list()
            else:
                self._rebuild()

    def relist_inline(self) -> bool:
        """Whether the pair list can be rebuilt by :func:`.neighbours.rebuild` (also inside the compiled
        many-steps loops): the sleeping grid is current (no sleep, wake or retirement since it was built),
        or there is no sleeping particle and no parked history (then the grid is rebuilt empty), so no
        history has to be parked or restored."""
        s = self.state
        if not self._sleep_grid_dirty and hasattr(self, "_sgrid"):
            return True
        return bool(self.single_bin and self._frozen_keys.size == 0 and not (s.active & ~s.awake).any())

    def _relist(self):
        """The rebuild of :meth:`relist_inline`: the same compiled :func:`.neighbours.rebuild` as the
        many-steps loops, so the pair list is the same on both paths."""
        if self._sleep_grid_dirty:
            self._sgrid = self._grid(_EMPTY_I)
        self._rebuild_list()
        self._dirty = False
        self._sleep_grid_dirty = False

    def _rebuild_list(self):
        """:func:`.neighbours.rebuild` of the awake particles on the sleeping grid ``_sgrid`` as it is."""
        s = self.state
        bufs = getattr(self, "_pbufs", None) or neighbours.empty_buffers()
        self._pa, self._pb, self._hist, self._rhist, self._touch, self._pbufs = neighbours.rebuild(
            self.idx, s.pos, s.radius, 0.5 * self.skin, self.geom, self.periodic, self.ncell, bool(self.single_bin),
            self._sgrid, self._pa, self._pb, self._hist, self._rhist, self._pos_build, bufs)

    def _rebuild(self):
        """Rebuild the pair list: between events ``_relist``; after a sleep, wake or retirement (the
        sleeping grid is out of date) re-bin the sleepers, restore parked histories of pairs found again
        and park those of pairs whose partners now both sleep."""
        if self.relist_inline():
            return self._relist()
        s = self.state
        sleep_idx = np.flatnonzero(~s.awake & s.active).astype(np.int64)
        self._sgrid = self._grid(sleep_idx)
        self._agrid = self._grid(self.idx)
        pa, pb = self._find(self.idx, self._agrid, self._sgrid)
        n = pa.size
        keys = (pa[:n] << 32) | pb[:n]
        if self.single_bin and self._sgrid[1].size == 0:
            keys = np.sort(keys)  # one cell per particle, one grid: each pair is found once
        else:  # a woken particle may still sit in the (stale) sleeping grid as well as in the awake one
            keys = np.unique(keys)
        n = keys.size
        new_hist = np.zeros((n, 6))
        old_keys = (self._pa << 32) | self._pb
        old_hist = np.concatenate([self._hist, self._rhist], axis=1)  # (shear, rolling) per pair
        if self._frozen_keys.size:
            src_keys = np.concatenate([old_keys, self._frozen_keys])
            src_hist = np.concatenate([old_hist, self._frozen_hist])
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
            self._frozen_keys, self._frozen_hist = src_keys[park], src_hist[park]
        self._pa, self._pb = keys >> 32, keys & 0xFFFFFFFF
        self._hist = np.ascontiguousarray(new_hist[:, :3])
        self._rhist = np.ascontiguousarray(new_hist[:, 3:])
        self._touch = np.zeros(n, bool)
        self._pos_build[self.idx] = s.pos[self.idx]
        self._dirty = False
        self._sleep_grid_dirty = False

    def _find(self, search, grid_a, grid_s):
        s = self.state
        cap = max(64, 16 * search.size)
        while True:
            pa = np.empty(cap, np.int64)
            pb = np.empty(cap, np.int64)
            n = pair_contacts.find_pairs(search, s.pos, s.radius, 0.5 * self.skin, self.geom, self.periodic, self.ncell,
                                    *grid_a, *grid_s, self.single_bin, pa, pb)
            if n <= cap:
                return pa[:n], pb[:n]
            cap = int(n * 1.2) + 16

    def _grid(self, idx):
        est = max(1024, 16 * idx.size)
        bits = int(math.ceil(math.log2(est)))
        start, ep, ec = pair_contacts.build_grid(idx, self.state.pos, self.state.radius, 0.5 * self.skin, self.geom,
                                            self.periodic, self.ncell, bits, self.single_bin)
        return start, ep, ec, bits
