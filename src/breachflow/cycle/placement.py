"""Placement plan: which masses are released where and when in each cycle (SPEC §7 step 3).

One mass per cycle (the report) or batches (a truck or skip dumps several at once). Release positions
from a placement strategy chosen by name (:mod:`~breachflow.cycle.strategies`): along a line across the
breach, random within a zone, a user list, or the closure strategies ``vertical`` (a sill raised over
the whole gap in layers) and ``horizontal`` (advancing from both breach heads), which read the current
pile; release height above the water surface (crane) or at the surface; size and density from
distributions; a placement rate (masses per hour) maps cycles to the wall-clock time of the closure
operation.

Randomness is drawn from ``numpy.random.default_rng([seed, g])``: cycle ``g``'s masses depend only
on the seed and ``g``, so a resumed run places exactly what an uninterrupted one would.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..units import to_si
from .strategies import PileView, placement_strategies

#: the built-in placement strategies (``placement_strategies.available()`` adds plug-ins)
POSITION_MODES = ("line", "zone", "list", "vertical", "horizontal")


@dataclass
class Release:
    """The masses of one cycle: centres (n, 3) m, radii (n,) m, densities (n,) kg/m³, time (s)."""

    pos: np.ndarray
    radius: np.ndarray
    density: np.ndarray
    time: float


@dataclass
class PlacementPlan:
    """Parameters (SI). ``diameter``: ``(low, high)`` for a uniform distribution, or a single value;
    ``density`` likewise. ``positions``: the placement strategy's name
    (:data:`~breachflow.cycle.strategies.placement_strategies`): ``"line"`` from ``start`` to ``stop``
    (x, y) m, masses spread along it cycle after cycle; ``"zone"`` uniform in the box
    ``zone = (x0, x1, y0, y1)``; ``"list"`` the user's ``points`` (x, y) in order, cycling;
    ``"vertical"`` / ``"horizontal"`` the closure strategies on the gap line ``start``→``stop`` (default
    the breach between its heads). ``release_height`` above the local water surface
    (m, 0 = at the surface: the sphere's bottom touches it); ``rate`` masses per hour of operation.
    """

    diameter: tuple = (1.0, 1.0)
    density: tuple = (2650.0, 2650.0)
    batch: int = 1
    positions: str = "line"
    start: tuple = (0.0, 0.0)
    stop: tuple = (0.0, 0.0)
    zone: tuple = (0.0, 0.0, 0.0, 0.0)
    points: list = field(default_factory=list)
    release_height: float = 1.0
    rate: float = 20.0 / 3600.0  # masses per second

    #: unit kind of each quantity key of ``[placement]`` (``from_config`` converts with these)
    KEY_KINDS = {"diameter": "length", "density": "density", "start": "length", "stop": "length",
                 "zone": "length", "points": "length", "release_height": "length", "rate": "1/s"}

    def __post_init__(self):
        self.diameter = tuple(np.broadcast_to(np.asarray(self.diameter, float), (2,)))
        self.density = tuple(np.broadcast_to(np.asarray(self.density, float), (2,)))
        if not (0 < self.diameter[0] <= self.diameter[1]) or not np.all(np.isfinite(self.diameter)):
            raise InputError(f"placement.diameter must be > 0 (low <= high), got {self.diameter}")
        if not (0 < self.density[0] <= self.density[1]):
            raise InputError(f"placement.density must be > 0 (low <= high), got {self.density}")
        if isinstance(self.batch, bool) or not isinstance(self.batch, (int, np.integer)):
            raise InputError(f"placement.batch must be a whole number of masses, got {self.batch!r}")
        if int(self.batch) < 1:
            raise InputError(f"placement.batch must be >= 1, got {self.batch}")
        self.batch = int(self.batch)
        if not isinstance(self.positions, str) or self.positions not in placement_strategies:
            raise InputError(f"placement.positions {self.positions!r} unknown; use one of "
                             f"{tuple(placement_strategies.available())}")
        if self.positions == "list" and not self.points:
            raise InputError("placement.positions = 'list' needs placement.points")
        if self.release_height < 0:
            raise InputError("placement.release_height must be >= 0")
        if not self.rate > 0:
            raise InputError(f"placement.rate must be > 0 masses per hour, got {self.rate}")

    @classmethod
    def from_config(cls, cfg: dict) -> "PlacementPlan":
        """Build from a TOML table with units, e.g. ``{diameter = ["1 m", "1.5 m"], rate = "30 1/hr"}``."""
        cfg = dict(cfg)
        allowed = set(cls.__dataclass_fields__)
        unknown = set(cfg) - allowed
        if unknown:
            raise InputError(f"placement: unknown key(s) {sorted(unknown)}; allowed: {sorted(allowed)}")

        def pair(key, kind):
            v = cfg[key]
            vals = v if isinstance(v, (list, tuple)) else [v]
            return tuple(to_si(x, name=f"placement.{key}", kind=kind, positive=True) for x in vals)

        kinds = cls.KEY_KINDS
        if "diameter" in cfg:
            cfg["diameter"] = pair("diameter", kinds["diameter"])
        if "density" in cfg:
            cfg["density"] = pair("density", kinds["density"])
        for key in ("start", "stop", "zone"):
            if key in cfg:
                cfg[key] = tuple(to_si(x, name=f"placement.{key}", kind="length", default_unit="m") for x in cfg[key])
        if "points" in cfg:
            cfg["points"] = [tuple(to_si(c, name="placement.points", kind="length", default_unit="m") for c in p)
                             for p in cfg["points"]]
        if "release_height" in cfg:
            cfg["release_height"] = to_si(cfg["release_height"], name="placement.release_height", kind="length",
                                          nonnegative=True)
        if "rate" in cfg:
            cfg["rate"] = to_si(cfg["rate"], name="placement.rate", kind=kinds["rate"], positive=True)
        return cls(**cfg)

    def check_inside(self, x_range, y_range) -> None:
        """Raise :class:`~breachflow.errors.InputError` naming the key when the release line, zone or points leave the
        horizontal extent ``x_range`` x ``y_range`` (m) of the field, before any run starts."""
        if self.uses_pile and self.start == self.stop:
            raise InputError(f"placement.start/stop: the gap line of positions = {self.positions!r} has zero length "
                             f"({self.start})")
        keys = {"zone": ("zone",), "list": ("points",)}.get(self.positions, ("start", "stop"))
        for key in keys:
            v = getattr(self, key)
            pts = ([(v[0], v[2]), (v[0], v[3]), (v[1], v[2]), (v[1], v[3])] if key == "zone" else
                   list(v) if key == "points" else [v])
            for px, py in pts:
                if not (x_range[0] <= px <= x_range[1] and y_range[0] <= py <= y_range[1]):
                    raise InputError(
                        f"placement.{key}: release point ({px:.6g} m, {py:.6g} m) lies outside the field "
                        f"(x {x_range[0]:.6g} .. {x_range[1]:.6g} m, y {y_range[0]:.6g} .. {y_range[1]:.6g} m)")

    @property
    def strategy(self):
        """The placement strategy object named by ``positions``."""
        return placement_strategies.create(self.positions)

    @property
    def uses_pile(self) -> bool:
        """Whether the strategy reads the current pile (:class:`~breachflow.cycle.strategies.PileView`)."""
        return bool(getattr(placement_strategies.get(self.positions), "uses_pile", False))

    def along_gap_line(self, xy) -> np.ndarray:
        """Distance (m) of the points *xy* (n, 2) along ``start``→``stop``, projected and kept on the segment."""
        start = np.asarray(self.start, float)
        seg = np.asarray(self.stop, float) - start
        length = float(np.hypot(*seg))
        if length == 0.0:
            return np.zeros(len(xy))
        return np.clip((np.asarray(xy, float) - start) @ (seg / length), 0.0, length)

    def operation_time(self, masses_placed: int) -> float:
        """Wall-clock time of the closure operation after *masses_placed* masses (s)."""
        return masses_placed / self.rate

    def release(self, g: int, seed: int, surface_at, pile: PileView | None = None) -> Release:
        """The masses released in cycle *g* (1-based). *surface_at(x, y)* gives the water-surface
        elevation (m) at release points (vectorised); *pile* the sill along the gap line before the
        release, for the strategies that read it (``uses_pile``)."""
        rng = np.random.default_rng([int(seed), int(g)])
        n = self.batch
        d = rng.uniform(self.diameter[0], self.diameter[1], n) if self.diameter[1] > self.diameter[0] else np.full(n, self.diameter[0])
        rho = rng.uniform(self.density[0], self.density[1], n) if self.density[1] > self.density[0] else np.full(n, self.density[0])
        k = (g - 1) * n + np.arange(n)  # running index of the masses
        xy = np.asarray(self.strategy.positions(self, k, d, rng, pile), float).reshape(n, 2)
        r = 0.5 * d
        base = np.asarray(surface_at(xy[:, 0], xy[:, 1]), float)
        if pile is not None:
            # a strategy that drops onto the pile: where the pile stands out of the water (a breach head
            # drawn down below the flood level), release above its crest, never inside a resting mass
            base = np.maximum(base, pile.crest_at(self.along_gap_line(xy)))
        z = base + self.release_height + r
        if not np.all(np.isfinite(z)):
            raise InputError(f"placement: release point(s) {xy[~np.isfinite(z)].tolist()} lie outside the field")
        # masses of one batch must not be spawned overlapping: stack them vertically if they would
        pos = np.column_stack([xy, z])
        for i in range(1, n):
            for j in range(i):
                dist = np.linalg.norm(pos[i] - pos[j])
                if dist < r[i] + r[j]:
                    pos[i, 2] = pos[j, 2] + r[i] + r[j] + 1e-3
        return Release(pos=pos, radius=r, density=rho, time=self.operation_time(int(k[-1]) + 1))
