"""Placement plan: which masses are released where and when in each cycle (docs/theory.md, *The closure cycle*).

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

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..units import to_si
from .strategies import PileView, placement_strategies

#: the built-in placement strategies (``placement_strategies.available()`` adds plug-ins)
POSITION_MODES = ("line", "zone", "list", "vertical", "horizontal")


@dataclass
class Release:
    """The masses of one cycle: centres (n, 3) m, radii (n,) m, densities (n,) kg/m³, time (s); ``material``
    (n,) the index of each mass's material in the plan's mix (:meth:`PlacementPlan.unit_parameters`), None
    for the spheres of ``diameter``."""

    pos: np.ndarray
    radius: np.ndarray
    density: np.ndarray
    time: float
    material: np.ndarray | None = None


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
    #: a closure material (:mod:`breachflow.materials`): a name (``"HMA_1000_3000"``), a table
    #: (``{name = "big_bag", mass_max = 5000}``) or a list of them; None or ``"sphere"``: spheres of
    #: ``diameter`` and ``density``
    material: object = None
    #: mass fractions of the delivered tonnage, one per material of a list (default: equal)
    fractions: tuple | None = None
    #: porosity of the dumped pile (-): the rock dam's pores in the seal's flow path and the pre-run estimate's
    #: tonnage; None: the material's (tonnage-weighted for a mix; spheres
    #: :data:`~breachflow.scenario.stone.DUMPED_POROSITY`)
    porosity: float | None = None
    #: side slopes of the dumped dam, H per V (the pre-run estimate's dam and the seal's upstream face); None:
    #: :data:`~breachflow.scenario.stone.DEFAULT_SIDE_SLOPE`
    side_slope: float | None = None

    #: unit kind of each quantity key of ``[placement]`` (``from_config`` converts with these)
    KEY_KINDS = {"diameter": "length", "density": "density", "start": "length", "stop": "length",
                 "zone": "length", "points": "length", "release_height": "length", "rate": "1/s",
                 "porosity": "dimensionless", "side_slope": "dimensionless"}

    def __post_init__(self):
        self._mix = None
        if self.material is not None and self.material != "sphere":
            from ..materials import MaterialMix

            mats = self.material if isinstance(self.material, (list, tuple)) else [self.material]
            if self.fractions is not None and len(self.fractions) != len(mats):
                raise InputError(f"placement.fractions: give one fraction per material ({len(mats)}), "
                                 f"got {list(self.fractions)}")
            self._mix = MaterialMix(mats, self.fractions)
            # the range of the DEM spheres' diameters and densities (wall offsets, breach area, sanity checks)
            mass, rho, _ = self._mix.sample(np.random.default_rng(0), 4096)
            from ..materials import sphere_diameter

            d = sphere_diameter(mass, rho)
            self.diameter = (float(d.min()), float(d.max()))
            self.density = (float(rho.min()), float(rho.max()))
        elif self.fractions is not None:
            raise InputError("placement.fractions needs placement.material")
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
        if self.porosity is not None and not 0.0 < self.porosity < 1.0:
            raise InputError(f"placement.porosity must be in (0, 1), got {self.porosity!r}")
        if self.side_slope is not None and not self.side_slope >= 0.0:
            raise InputError(f"placement.side_slope must be >= 0 (H per V), got {self.side_slope!r}")

    @property
    def pile_porosity(self) -> float:
        """Porosity of the dumped pile: ``porosity`` if given, else the material's (tonnage-weighted over a mix),
        else :data:`~breachflow.scenario.stone.DUMPED_POROSITY` (spheres)."""
        from ..scenario.stone import DUMPED_POROSITY

        if self.porosity is not None:
            return float(self.porosity)
        if self._mix is not None:
            return float(np.dot(self._mix.fractions, [m.porosity for m in self._mix.materials]))
        return DUMPED_POROSITY

    @property
    def dam_side_slope(self) -> float:
        """Side slopes of the dumped dam (H per V): ``side_slope`` if given, else
        :data:`~breachflow.scenario.stone.DEFAULT_SIDE_SLOPE`."""
        from ..scenario.stone import DEFAULT_SIDE_SLOPE

        return DEFAULT_SIDE_SLOPE if self.side_slope is None else float(self.side_slope)

    @classmethod
    def from_config(cls, cfg: dict) -> "PlacementPlan":
        """Build from a TOML table with units, e.g. ``{diameter = ["1 m", "1.5 m"], rate = "30 1/hr"}``."""
        cfg = dict(cfg)
        allowed = set(cls.__dataclass_fields__)
        unknown = set(cfg) - allowed
        if unknown:
            raise InputError(f"placement: unknown key(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
        if cfg.get("material") not in (None, "sphere") and ({"diameter", "density"} & set(cfg)):
            raise InputError(f"placement.material = {cfg['material']!r} sets the units' sizes and density; leave out "
                             f"placement.{' and placement.'.join(sorted({'diameter', 'density'} & set(cfg)))}")
        if "fractions" in cfg:
            fr = cfg["fractions"]
            if not isinstance(fr, (list, tuple)) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                           for v in fr):
                raise InputError(f"placement.fractions must be a list of numbers, got {fr!r}")
            cfg["fractions"] = tuple(float(v) for v in fr)

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
        if "porosity" in cfg:
            cfg["porosity"] = to_si(cfg["porosity"], name="placement.porosity", kind="dimensionless",
                                    default_unit="", positive=True)
        if "side_slope" in cfg:
            cfg["side_slope"] = to_si(cfg["side_slope"], name="placement.side_slope", kind="dimensionless",
                                      default_unit="", nonnegative=True)
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
    def mix(self):
        """The :class:`~breachflow.materials.MaterialMix` of ``material`` (None: spheres of ``diameter``)."""
        return self._mix

    def dem_parameters(self) -> dict | None:
        """What the material sets in the DEM and the fluid forces (friction, rolling friction, drag and lift
        coefficients), None for spheres."""
        return None if self._mix is None else self._mix.dem_parameters()

    def unit_parameters(self) -> list[dict] | None:
        """Per material of ``material`` (the index a :class:`Release` carries): friction, rolling friction,
        drag and lift coefficients each of its masses carries (:meth:`~breachflow.materials.MaterialMix.unit_parameters`);
        None for spheres."""
        return None if self._mix is None else self._mix.unit_parameters()

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

    def release(self, g: int, seed: int, surface_at, pile: PileView | None = None,
                placed: tuple[np.ndarray, np.ndarray] | None = None) -> Release:
        """The masses released in cycle *g* (1-based). *surface_at(x, y)* gives the water-surface
        elevation (m) at release points (vectorised); *pile* the sill along the gap line before the
        release, for the strategies that read it (``uses_pile``); *placed* the centres (m, 3) and radii (m,)
        of the masses already in the breach, above which a new mass is released where it would otherwise
        start inside one (a crane lowers its load onto the pile, it does not push it into the pile)."""
        rng = np.random.default_rng([int(seed), int(g)])
        n = self.batch
        which = None
        if self._mix is not None:
            from ..materials import sphere_diameter

            mass, rho, which = self._mix.sample(rng, n)
            d = sphere_diameter(mass, rho)  # the volume-equivalent sphere of each unit
        else:
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
        pos = destack(np.column_stack([xy, z]), r)
        if placed is not None and len(placed[1]):
            for _ in range(len(r) + 1):  # each pass only lifts; a lift can only make a new overlap in the batch
                before = pos[:, 2].copy()
                pos = destack(clear_of(pos, r, *placed), r)
                if np.array_equal(pos[:, 2], before):
                    break
        return Release(pos=pos, radius=r, density=rho, time=self.operation_time(int(k[-1]) + 1), material=which)


def clear_of(pos: np.ndarray, r: np.ndarray, placed_pos: np.ndarray, placed_r: np.ndarray) -> np.ndarray:
    """Lift each new mass (centres *pos* (n, 3), radii *r*) clear of the masses already placed (*placed_pos*
    (m, 3), *placed_r*): where it would start inside a placed mass *j* at horizontal distance ``d < r + r_j``,
    it is put on top of it, ``z = z_j + sqrt((r + r_j)^2 - d^2) + 1 mm`` (touching it). The placed masses
    are visited from the lowest up, so that a lift never pushes a mass into one below it. A mass spawned
    inside another is pushed out by the contact law with the whole overlap's elastic energy, about
    ``k_n delta^2 / 2``, and can be shot out of the breach: a loss that no flow caused. *pos* is changed in
    place and returned."""
    placed_pos = np.asarray(placed_pos, float).reshape(-1, 3)
    placed_r = np.asarray(placed_r, float).ravel()
    if placed_r.size == 0:
        return pos
    for i in range(len(pos)):
        reach = r[i] + placed_r
        d2 = (placed_pos[:, 0] - pos[i, 0]) ** 2 + (placed_pos[:, 1] - pos[i, 1]) ** 2
        near = np.flatnonzero(d2 < reach ** 2)
        if near.size == 0:
            continue
        near = near[np.argsort(placed_pos[near, 2], kind="stable")]
        half = np.sqrt(reach[near] ** 2 - d2[near])  # vertical half-extent of the overlap at that distance
        zi = float(pos[i, 2])
        for zj, hj in zip(placed_pos[near, 2].tolist(), half.tolist()):
            if abs(zi - zj) < hj:
                zi = zj + hj + 1e-3
        pos[i, 2] = zi
    return pos


def destack(pos: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Lift the masses of one batch so that none is spawned overlapping another: mass *i* is compared with
    the masses ``j < i`` in order and, where they overlap, put on top of *j* (``z_j + r_i + r_j + 1 mm``).

    Only masses whose horizontal distance is below ``r_i + r_j`` can overlap, so each mass is compared only
    with the earlier masses of the horizontal cells (side ``2 max(r)``) around it — the same comparisons in
    the same order as against every earlier mass, without the quadratic cost for a batch spread over the
    release line or zone. *pos* (n, 3) is changed in place and returned."""
    n = len(pos)
    if n < 2:
        return pos
    cell = 2.0 * float(np.max(r))
    keys = np.floor(pos[:, :2] / cell).astype(np.int64)
    grid: dict[tuple[int, int], list[int]] = {}
    px, py, pz, rr = pos[:, 0].tolist(), pos[:, 1].tolist(), pos[:, 2].tolist(), np.asarray(r, float).tolist()
    for i in range(n):
        cx, cy = int(keys[i, 0]), int(keys[i, 1])
        near = []
        for ox in (-1, 0, 1):
            near.extend(grid.get((cx + ox, cy - 1), ()))
            near.extend(grid.get((cx + ox, cy), ()))
            near.extend(grid.get((cx + ox, cy + 1), ()))
        if near:
            near.sort()
            xi, yi, zi, ri = px[i], py[i], pz[i], rr[i]
            for j in near:
                if math.sqrt((xi - px[j]) ** 2 + (yi - py[j]) ** 2 + (zi - pz[j]) ** 2) < ri + rr[j]:
                    zi = pz[j] + ri + rr[j] + 1e-3
            pz[i] = zi
        grid.setdefault((cx, cy), []).append(i)
    pos[:, 2] = pz
    return pos
