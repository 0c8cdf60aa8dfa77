"""Placement strategies: where a cycle's masses are dropped (docs/theory.md, *The closure cycle*), chosen by name.

``[placement] positions`` names an entry of :data:`placement_strategies`; each is a class with one
method, ``positions(plan, k, d, rng, pile) -> (n, 2)`` release points (x, y) in m of the masses with
running indices *k* and diameters *d*, drawing any randomness from *rng* (``default_rng([seed, g])``, so
a resumed run places what an uninterrupted one would).

Today's modes

``line``   golden-ratio sequence along ``start``→``stop`` (successive masses fill it evenly), 5 % scatter;
``zone``   uniform in the box ``zone``;
``list``   the user's ``points`` in order, cycling.

The two strategies closure engineering distinguishes (Izbash & Khaldre 1970; Huis in 't Veld 1987,
*The closure of tidal basins*) — vertical and horizontal closure — act on the current pile, so they
read the sill along the gap line ``start``→``stop`` (default the breach between its heads, one radius in
from each wall) through a :class:`PileView` the driver hands them — not the driver itself:

``vertical``   a sill raised over the whole gap in layers: the gap is divided into slots one largest
               diameter wide (× :data:`SPACING`); each mass goes to the slot whose mean crest is lowest
               (compared in bands of a quarter diameter, so a layer is completed before the next starts), ties taken in a
               golden-ratio order so that a batch is spread over the whole width; a chosen slot counts
               one diameter higher for the rest of the batch.
``horizontal`` advance from both breach heads: masses alternate between the two heads (running index
               even: the ``start`` side, odd: the ``stop`` side), dropped at the first point of the gap
               line, counted from that head, whose crest is still below the water level (the head of the
               pile); several masses on one side in a batch go in rows across the line (0, +D, −D,
               D the largest diameter × :data:`SPACING`) and then one D further into the gap, never past the
               middle of the open gap.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..registry import Registry
from .crest import CREST_STEP, crest_profile, stations

#: registry of placement strategies (entry-point group ``breachflow.placement_strategies``)
placement_strategies: Registry = Registry("placement strategy", "breachflow.placement_strategies")

GOLDEN = 0.6180339887498949
#: spacing of the slots and rows of ``vertical`` / ``horizontal`` in largest diameters: with the 5 %
#: scatter, masses of one batch are released side by side, not overlapping (and stacked on release)
SPACING = 1.15


@dataclass
class PileView:
    """The sill along the gap line that a strategy reads (SI).

    ``s`` distance (m) of each sample from ``start`` along ``start``→``stop`` (0 … L, increasing);
    ``crest`` the highest point (m) of terrain or resting pile within ``band`` of the line at each sample
    (the top of the sill there); ``level`` the water level (m) a closed column reaches (flood side)."""

    s: np.ndarray
    crest: np.ndarray
    level: float

    @classmethod
    def from_grid(cls, x, y, bed, top, start, stop, band: float, level: float) -> "PileView":
        """Sample ``max(bed, top)`` (grids (ny, nx) on cell centres *x*, *y*; *top* −inf where no pile) along
        the segment *start*→*stop*: every cell centre within *band* (m) of the segment is binned to the
        nearest of samples spaced one cell apart; a sample's crest is the highest value in its bin (a bin
        no cell falls in takes its neighbour's)."""
        start, stop = np.asarray(start, float), np.asarray(stop, float)
        seg = stop - start
        length = float(np.hypot(*seg))
        if length == 0.0:
            return cls(np.zeros(1), np.full(1, float(np.max(bed))), float(level))
        u = seg / length
        X, Y = np.meshgrid(np.asarray(x, float), np.asarray(y, float))
        along = (X - start[0]) * u[0] + (Y - start[1]) * u[1]
        across = -(X - start[0]) * u[1] + (Y - start[1]) * u[0]
        h = min(abs(x[1] - x[0]) if len(x) > 1 else 1.0, abs(y[1] - y[0]) if len(y) > 1 else 1.0)
        n = max(int(np.ceil(length / h)), 1) + 1
        s = np.linspace(0.0, length, n)
        near = (np.abs(across) <= band) & (along >= -0.5 * h) & (along <= length + 0.5 * h)
        z = np.maximum(np.asarray(bed, float), np.asarray(top, float))[near]
        idx = np.clip(np.rint(along[near] / (length / (n - 1))).astype(int), 0, n - 1)
        crest = np.full(n, -np.inf)
        np.maximum.at(crest, idx, z)
        if not np.isfinite(crest).any():
            crest[:] = float(np.max(bed))
        for i in np.flatnonzero(~np.isfinite(crest)):  # empty bins: nearest filled sample
            filled = np.flatnonzero(np.isfinite(crest))
            crest[i] = crest[filled[np.argmin(np.abs(filled - i))]]
        return cls(s, crest, float(level))

    @classmethod
    def from_masses(cls, x, y, bed, pos, radius, members, start, stop, band: float, level: float,
                    step: float = CREST_STEP) -> "PileView":
        """The sill along *start*→*stop* read from the masses (:func:`~breachflow.cycle.crest.crest_profile`):
        every *step* m, the highest top ``z + r`` of a member (*pos* (n, 3), *radius* (n,), *members* (n,) bool)
        centred within *band* (m) of the line whose silhouette covers the point, or the terrain there
        (:meth:`from_grid` of *bed* alone, linear between its samples) where that is higher. The same reading
        whatever the grid's cells: a notch narrower than a cell is seen."""
        terrain = cls.from_grid(x, y, bed, np.full(np.shape(bed), -np.inf), start, stop, band, level)
        start, stop = np.asarray(start, float), np.asarray(stop, float)
        length = float(np.hypot(*(stop - start)))
        if length == 0.0:
            return terrain
        u = (stop - start) / length
        s = stations(length, step)
        pos = np.asarray(pos, float).reshape(-1, 3)
        m = min(len(pos), len(radius), len(members))
        pos, r = pos[:m], np.asarray(radius, float)[:m]
        along = (pos[:, 0] - start[0]) * u[0] + (pos[:, 1] - start[1]) * u[1]
        across = -(pos[:, 0] - start[0]) * u[1] + (pos[:, 1] - start[1]) * u[0]
        near = np.asarray(members[:m], bool) & np.isfinite(pos).all(axis=1) & (np.abs(across) <= band)
        crest = crest_profile(s, np.interp(s, terrain.s, terrain.crest), along[near], pos[near, 2] + r[near], r[near])
        return cls(s, crest, float(level))

    def crest_at(self, s) -> np.ndarray:
        return np.interp(s, self.s, self.crest)


class FixedStrategy:
    """Base of the strategies that do not look at the pile (``uses_pile = False``)."""

    uses_pile = False


@placement_strategies.register("line")
class Line(FixedStrategy):
    """Golden-ratio sequence along ``start``→``stop`` with a scatter of 5 % of the batch's mean diameter."""

    def positions(self, plan, k, d, rng, pile=None):
        f = np.mod(0.5 + k * GOLDEN, 1.0)
        start, stop = np.asarray(plan.start), np.asarray(plan.stop)
        xy = start[None, :] + f[:, None] * (stop - start)[None, :]
        return xy + rng.normal(0.0, 0.05 * d.mean(), (len(k), 2))  # no two drops identical


@placement_strategies.register("zone")
class Zone(FixedStrategy):
    """Uniform in the box ``zone = (x0, x1, y0, y1)``."""

    def positions(self, plan, k, d, rng, pile=None):
        x0, x1, y0, y1 = plan.zone
        return np.column_stack([rng.uniform(x0, x1, len(k)), rng.uniform(y0, y1, len(k))])


@placement_strategies.register("list")
class PointList(FixedStrategy):
    """The user's ``points`` in order, cycling."""

    def positions(self, plan, k, d, rng, pile=None):
        pts = np.asarray(plan.points, float)
        return pts[k % len(pts)]


def band(plan) -> float:
    """Half-width (m) of the dam section across the gap line that the strategies place in and read:
    release points lie within ``SPACING`` largest diameters of the line, their masses half a diameter
    further."""
    return (SPACING + 0.5) * float(plan.diameter[1])


class GapLineStrategy:
    """Base of the strategies that read the pile along the gap line ``start``→``stop`` (``uses_pile = True``)."""

    uses_pile = True

    @staticmethod
    def frame(plan):
        start, stop = np.asarray(plan.start, float), np.asarray(plan.stop, float)
        length = float(np.hypot(*(stop - start)))
        u = (stop - start) / length if length > 0 else np.array([1.0, 0.0])
        return start, u, np.array([-u[1], u[0]]), length

    def to_xy(self, plan, s, off, d, rng):
        """Points at distance *s* along the line and *off* across it, with 5 % scatter along and across;
        *s* is kept on the line (inside the gap), *off* within :func:`band` of it."""
        start, u, nrm, length = self.frame(plan)
        jitter = rng.normal(0.0, 0.05 * d.mean(), (len(s), 2))
        s = np.clip(s + jitter[:, 0], 0.0, length)
        reach = SPACING * float(plan.diameter[1])
        off = np.clip(off + jitter[:, 1], -reach, reach)
        return start[None, :] + s[:, None] * u[None, :] + off[:, None] * nrm[None, :]

    @staticmethod
    def need(pile):
        if pile is None:
            raise InputError("this placement strategy needs the pile state (PileView) of the cycle")


@placement_strategies.register("vertical")
class Vertical(GapLineStrategy):
    """Layers over the whole gap: each mass to the lowest slot of the sill (see the module text)."""

    def positions(self, plan, k, d, rng, pile=None):
        self.need(pile)
        _, _, _, length = self.frame(plan)
        dm = float(plan.diameter[1])
        n_slots = max(int(np.floor(length / (SPACING * dm))) + 1, 1)
        centres = np.linspace(0.0, length, n_slots) if n_slots > 1 else np.array([0.5 * length])
        # slot crest: the mean sill height over the slot (the samples within half a slot of its centre)
        half = 0.5 * (centres[1] - centres[0]) if n_slots > 1 else 0.5 * length + 1e-9
        height = np.array([np.mean(pile.crest[np.abs(pile.s - c) <= half + 1e-9]) if np.any(np.abs(pile.s - c) <= half + 1e-9)
                           else float(pile.crest_at(c)) for c in centres])
        spread = _golden_rank(n_slots)
        s = np.empty(len(k))
        for i in range(len(k)):
            band = np.floor((height - height.min()) / (0.25 * dm) + 1e-9)
            pick = int(np.lexsort((spread, band))[0])
            s[i] = centres[pick]
            height[pick] += dm
        return self.to_xy(plan, s, np.zeros(len(k)), d, rng)


def _golden_rank(n: int) -> np.ndarray:
    """Rank of each of *n* evenly spaced slots in the golden-ratio sequence ``frac(0.5 + j φ)``: the slot
    nearest each term, in turn, takes the next rank — successive ranks spread over the width."""
    rank = np.full(n, n, int)
    r, j = 0, 0
    while r < n and j < 64 * n:
        slot = min(int(np.mod(0.5 + j * GOLDEN, 1.0) * n), n - 1)
        if rank[slot] == n:
            rank[slot] = r
            r += 1
        j += 1
    rank[rank == n] = np.arange(r, n)[: int((rank == n).sum())]
    return rank


@placement_strategies.register("horizontal")
class Horizontal(GapLineStrategy):
    """Advance from both breach heads, narrowing the gap (see the module text)."""

    def positions(self, plan, k, d, rng, pile=None):
        self.need(pile)
        _, _, _, length = self.frame(plan)
        dm = float(plan.diameter[1])
        open_ = np.flatnonzero(pile.crest < pile.level)
        if open_.size:
            a, b = float(pile.s[open_[0]]), float(pile.s[open_[-1]])
        else:  # the whole line reaches the level: top up the lowest point
            a = b = float(pile.s[int(np.argmin(pile.crest))])
        mid = 0.5 * (a + b)
        left = (k % 2) == 0
        s = np.empty(len(k))
        off = np.zeros(len(k))
        rows = np.array([0.0, 1.0, -1.0]) * SPACING * dm
        for side, head, sign, lim in ((left, a, 1.0, lambda v: min(v, mid)), (~left, b, -1.0, lambda v: max(v, mid))):
            for j, i in enumerate(np.flatnonzero(side)):
                s[i] = lim(head + sign * (j // 3) * SPACING * dm)
                off[i] = rows[j % 3]
        return self.to_xy(plan, np.clip(s, 0.0, length), off, d, rng)
