"""End criteria of the closure cycle (docs/theory.md, *The closure cycle*, report §4.4), each a named class with a threshold.

A criterion's ``evaluate(context)`` returns a :class:`CriterionResult` (value, threshold, units,
satisfied). The registry ``breachflow.criteria`` holds them by name; :class:`EndCriteria` combines a
list with ``"any"`` or ``"all"`` and a maximum number of cycles.

=====  ======================  ===============================================================
No.    name                    satisfied when
=====  ======================  ===============================================================
1      ``blocked_fraction``    resting masses block ≥ threshold of the breach cross-section
1      ``placed_volume``       solid volume of resting masses ≥ threshold (m³)
2      ``max_speed``           maximum fluid speed in the breach area (or anywhere) < threshold (m/s)
3      ``discharge_proxy``     max over subdomains of (max speed × open flow area) < threshold (m³/s)
3      ``breach_discharge``    absolute discharge through the breach section at the levee line < threshold (m³/s)
4      ``head_gradient``       max total-head gradient between neighbouring wet cells < threshold
5      ``stability``           re-running the assembly in the new flow moves no mass more than threshold (m)
6      ``speed_change``        change of the maximum speed since the previous cycle < threshold (m/s)
3      ``seepage_discharge``   its part through a porous pile (``remap = "porous"``) < threshold (m³/s)
3      ``overflow_discharge``  its part over the pile's crest < threshold (m³/s)
3      ``seepage_fraction``    seepage / open-breach discharge (before the first mass) < threshold
=====  ======================  ===============================================================

A porous rock-fill dam is closed when the overflow has stopped — its crest is above the water all across
the gap — and the seepage through it is small enough for the sealing with finer fill that follows (as at
the 2004 Jones Tract closure, where the rock-fill was sealed with finer underwater fill afterwards; Harder
2012, ASDSO Dam Safety 2012): ``mode = "all"`` with ``overflow_discharge`` and ``seepage_discharge`` (m³/s)
or ``seepage_fraction``; the run reports the remaining seepage as what the sealing must handle.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..swe.section import open_wet as _open_wet
from ..swe.section import snapshot_control_section, snapshot_discharge, snapshot_section_speeds
from ..registry import Registry
from ..units import to_si

G = 9.80665

criteria: Registry = Registry("end criterion", "breachflow.criteria")


@dataclass
class CycleContext:
    """What the criteria look at after cycle ``<g>``'s re-solve.

    ``snapshot``/``previous`` grid snapshots (SI); ``pos``/``radius``/``resting`` particle centres (N, 3),
    radii and rest mask; ``breach_x`` (x_min, x_max) and ``levee_y`` the breach cross-section at the
    levee centreline; ``flood_level`` the flood-side water-surface elevation; ``bottom`` the breach
    bottom elevation; ``stability_displacement`` the largest displacement of the stability re-run (m),
    None when it was not run.
    """

    cycle: int
    snapshot: object
    previous: object = None
    pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    resting: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    breach_x: tuple = (0.0, 0.0)
    levee_y: float = 0.0
    flood_level: float = 0.0
    bottom: float = 0.0
    stability_displacement: float | None = None
    #: discharge through the porous pile across the breach section (m³/s; 0 without a porous pile)
    seepage_discharge: float = 0.0
    #: the breach area ``(x0, x1, y0, y1)`` (m) where ``max_speed`` judges the flow (None: the whole domain)
    area: tuple | None = None
    #: breach discharge of the open breach, before the first mass (m³/s; NaN when unknown)
    open_breach_discharge: float = float("nan")
    #: +1 when the polder is at +y of the grid, -1 when the flood is (:func:`~breachflow.swe.section.flow_sign`)
    flow_sign: float = 1.0


@dataclass(frozen=True)
class CriterionResult:
    name: str
    value: float
    threshold: float
    units: str
    satisfied: bool
    description: str = ""


class Criterion:
    """Base: subclasses set ``name``, ``kind`` (unit kind of the threshold), ``units`` and ``compare``."""

    name = ""
    kind = "dimensionless"
    units = "1"
    compare = "below"  # or "above"
    description = ""

    def __init__(self, threshold):
        self.threshold = to_si(threshold, name=f"criteria.{self.name}", kind=self.kind,
                               default_unit=None if self.kind != "dimensionless" else "", nonnegative=True)

    def value(self, ctx: CycleContext) -> float:
        raise NotImplementedError

    def evaluate(self, ctx: CycleContext) -> CriterionResult:
        v = float(self.value(ctx))
        ok = bool(np.isfinite(v) and (v < self.threshold if self.compare == "below" else v >= self.threshold))
        return CriterionResult(self.name, v, self.threshold, self.units, ok, self.description)


def _speed(ds):
    return np.hypot(np.asarray(ds["u"].values, float), np.asarray(ds["v"].values, float))


def section_discharge(ds, x_range, y: float, sign: float = 1.0) -> float:
    """Discharge (m³/s) through the breach between ``x_range``, positive from the flood side into the polder:
    *sign* (:func:`~breachflow.swe.section.flow_sign`, ``ClosureSetup.flow_sign``; +1: the polder at +y)
    times the median over the breach channel's rows of ``Σ h v Δx`` over the open wet cells
    (:func:`breachflow.swe.section.channel_discharge`, also the ``swe`` solver's steady-state monitor).
    Every breach discharge a closure run reports, judges or integrates into the polder is this one."""
    return float(sign) * snapshot_discharge(ds, x_range, y) + 0.0  # + 0.0: no "-0.00" for a dry breach


def row_discharge(ds, x_range, y: float) -> float:
    """Discharge (m³/s) across the one grid row nearest *y* between ``x_range``: ``Σ h v Δx`` over its open
    wet cells (positive towards the protected side)."""
    x = np.asarray(ds["x"].values, float)
    j = int(np.argmin(np.abs(np.asarray(ds["y"].values, float) - y)))
    sel = (x >= x_range[0]) & (x <= x_range[1]) & _open_wet(ds)[j]
    dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
    hv = np.asarray(ds["depth"].values, float)[j, sel] * np.asarray(ds["v"].values, float)[j, sel]
    return float(np.sum(hv) * dx)


def seepage_in_section(ds, x_range, y: float, seepage_row: float, sign: float = 1.0) -> float:
    """The seepage through a porous pile as a part of the breach discharge (:func:`section_discharge`).

    The split into seepage and overflow is made per cell in the levee row through the pile
    (*seepage_row*, m³/s, of that row's :func:`row_discharge`); the breach discharge is the median over the
    channel's rows, a few % apart from the levee row's. Both must be in one section, or a closed pile
    shows an "overflow" of that difference (the default scene: 0.84 of 24 m³/s, against the 0.5 m³/s
    limit): the levee row's seepage share times the breach discharge. *seepage_row* is counted towards +y,
    the result like :func:`section_discharge` with the same *sign*."""
    q_row = row_discharge(ds, x_range, y)
    if seepage_row == 0.0 or abs(q_row) < 1e-12:
        return float(sign) * float(seepage_row) + 0.0
    share = min(abs(seepage_row / q_row), 1.0)
    return float(sign) * float(np.copysign(share * abs(snapshot_discharge(ds, x_range, y)), seepage_row))


def gap_section_speeds(ds, x_range, y: float) -> tuple[float, float]:
    """Flow speed in the gap: ``(max, mean)`` (m/s) on the exact section ``y`` between ``x_range`` (the
    section :func:`section_discharge` integrates over), interpolated between the grid rows that bracket it
    (:func:`breachflow.swe.section.section_speeds`). The mean is depth-weighted, ``Σ h |u| Δx / Σ h Δx`` —
    the mean velocity through the gap's wet flow area that closure design compares with the stones'
    critical speed (Izbash & Khaldre 1970); (0, 0) when no cell of the section is open."""
    return snapshot_section_speeds(ds, x_range, y)


def control_speed(ds, x_range, y: float) -> tuple[float, float]:
    """The breach's control section: ``(position, mean speed)`` (m, m/s), where the flow through the breach
    channel passes critical depth (:func:`breachflow.swe.section.control_section`). Its speed, the critical
    speed set by the unit discharge, is the gap speed the verdict check compares between grids
    (docs/verdict-check.md, *The gap speed that converges*)."""
    return snapshot_control_section(ds, x_range, y)


@criteria.register("blocked_fraction")
class BlockedFraction(Criterion):
    """docs/theory.md, *The closure cycle* criterion 1: fraction of the breach cross-section (the trapezoid between the breach
    bottom and the flood level at the levee centreline) covered by the sections of resting spheres
    with the plane y = levee_y (circles of radius sqrt(r² − dy²)), by rasterising the section."""

    name, kind, units, compare = "blocked_fraction", "dimensionless", "1", "above"
    description = "fraction of the breach cross-section blocked by resting masses"
    resolution = 200

    def value(self, ctx):
        x0, x1 = ctx.breach_x
        if not (x1 > x0 and ctx.flood_level > ctx.bottom):
            raise InputError("blocked_fraction: breach section has no area (breach_x or levels wrong)")
        xs = np.linspace(x0, x1, self.resolution)
        zs = np.linspace(ctx.bottom, ctx.flood_level, max(self.resolution // 4, 20))
        X, Z = np.meshgrid(xs, zs)
        blocked = np.zeros(X.shape, bool)
        sel = ctx.resting & (np.abs(ctx.pos[:, 1] - ctx.levee_y) < ctx.radius) if len(ctx.radius) else np.zeros(0, bool)
        for p, r in zip(ctx.pos[sel], ctx.radius[sel]):
            rc2 = r * r - (p[1] - ctx.levee_y) ** 2
            blocked |= (X - p[0]) ** 2 + (Z - p[2]) ** 2 <= rc2
        # below ground inside the section nothing flows: the section is the rectangle above the bottom
        return blocked.mean()


@criteria.register("placed_volume")
class PlacedVolume(Criterion):
    """docs/theory.md, *The closure cycle* criterion 1 (volume form): solid volume of resting masses, sum of 4/3 π r³ (m³)."""

    name, kind, units, compare = "placed_volume", "volume", "m3", "above"
    description = "solid volume of the resting masses"

    def value(self, ctx):
        return float(np.sum(4.0 / 3.0 * np.pi * ctx.radius[ctx.resting] ** 3))


@criteria.register("max_speed")
class MaxSpeed(Criterion):
    """docs/theory.md, *The closure cycle* criterion 2: max over wet open cells of ``|u|`` (m/s); e.g. 0.2 m/s for fine sands/silts.

    ``region = "breach"`` (default) judges the cells in the breach area (``CycleContext.area``: the levee
    footprint over the breach plus one mass diameter, :mod:`~breachflow.cycle.losses`), where the closure
    and its scour are; ``"domain"`` every cell, as the report's "anywhere". Far from the breach the speed
    says nothing about the closure: water a porous pile lets through runs off over the polder as a shallow
    sheet at metres per second (3.0 m/s 18.5 m behind the levee in the default scene), and a polder still
    draining keeps moving after an impervious closure. Without an area the whole domain is judged.
    """

    name, kind, units = "max_speed", "speed", "m s-1"
    description = ("maximum depth-averaged fluid speed in the breach area "
                   "({ threshold = ..., region = \"domain\" }: anywhere)")

    def __init__(self, threshold, region: str = "breach"):
        super().__init__(threshold)
        if region not in ("breach", "domain"):
            raise InputError(f"criteria.max_speed: region must be 'breach' or 'domain', got {region!r}")
        self.region = region

    def value(self, ctx):
        sel = _open_wet(ctx.snapshot)
        if self.region == "breach" and ctx.area is not None:
            x = np.asarray(ctx.snapshot["x"].values, float)
            y = np.asarray(ctx.snapshot["y"].values, float)
            x0, x1, y0, y1 = ctx.area
            sel = sel & ((y >= y0) & (y <= y1))[:, None] & ((x >= x0) & (x <= x1))[None, :]
        s = _speed(ctx.snapshot)[sel]
        return float(s.max()) if s.size else 0.0


@criteria.register("discharge_proxy")
class DischargeProxy(Criterion):
    """docs/theory.md, *The closure cycle* criterion 3: max over subdomains of (max speed × open flow area) (m³/s).

    Subdomains are boxes ``(x0, x1, y0, y1)`` (default: one box spanning the breach, ±2 breach lengths
    across the levee); the open flow area of a box is the largest over its grid rows of
    Σ h Δx over wet, unobstructed cells — the wetted cross-section transverse to the breach flow.
    """

    name, kind, units = "discharge_proxy", "discharge", "m3 s-1"
    description = "max over subdomains of (speed × open area)"

    def __init__(self, threshold, subdomains=None):
        super().__init__(threshold)
        self.subdomains = None if subdomains is None else [tuple(map(float, b)) for b in subdomains]

    def value(self, ctx):
        ds = ctx.snapshot
        x = np.asarray(ds["x"].values, float)
        y = np.asarray(ds["y"].values, float)
        dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
        boxes = self.subdomains
        if boxes is None:
            x0, x1 = ctx.breach_x
            w = x1 - x0
            boxes = [(x0, x1, ctx.levee_y - 2 * w, ctx.levee_y + 2 * w)]
        speed = _speed(ds)
        depth = np.asarray(ds["depth"].values, float)
        open_wet = _open_wet(ds)
        best = 0.0
        for bx0, bx1, by0, by1 in boxes:
            ix = (x >= bx0) & (x <= bx1)
            iy = (y >= by0) & (y <= by1)
            if not ix.any() or not iy.any():
                continue
            sub = np.ix_(iy, ix)
            ow = open_wet[sub]
            if not ow.any():
                continue
            area = float(np.max(np.sum(np.where(ow, depth[sub], 0.0), axis=1) * dx))
            best = max(best, float(speed[sub][ow].max()) * area)
        return best


@criteria.register("breach_discharge")
class BreachDischarge(Criterion):
    """docs/theory.md, *The closure cycle* criterion 3, direct form: ``|Q|`` through the breach section at the levee centreline,
    Σ h v Δx over the open wet cells of the row at ``levee_y`` between ``breach_x`` (m³/s). Unlike the
    maximum speed or the proxy it is not fooled by water still draining off the polder or moving in
    the deep flood-side basin once the pile has shut the breach."""

    name, kind, units = "breach_discharge", "discharge", "m3 s-1"
    description = "discharge through the breach section"

    def value(self, ctx):
        return abs(section_discharge(ctx.snapshot, ctx.breach_x, ctx.levee_y, ctx.flow_sign))


@criteria.register("head_gradient")
class HeadGradient(Criterion):
    """docs/theory.md, *The closure cycle* criterion 4: ``max |ΔH| / Δs`` between neighbouring wet open cells, ``H = η + |u|²/(2g)``."""

    name, kind, units = "head_gradient", "dimensionless", "1"
    description = "maximum total-head gradient between neighbouring gridpoints"

    def value(self, ctx):
        ds = ctx.snapshot
        H = np.asarray(ds["water_surface"].values, float) + _speed(ds) ** 2 / (2 * G)
        ok = _open_wet(ds)
        x = np.asarray(ds["x"].values, float)
        y = np.asarray(ds["y"].values, float)
        best = 0.0
        if x.size > 1:
            both = ok[:, 1:] & ok[:, :-1]
            g = np.abs(np.diff(H, axis=1)) / np.abs(np.diff(x))[None, :]
            if both.any():
                best = max(best, float(g[both].max()))
        if y.size > 1:
            both = ok[1:, :] & ok[:-1, :]
            g = np.abs(np.diff(H, axis=0)) / np.abs(np.diff(y))[:, None]
            if both.any():
                best = max(best, float(g[both].max()))
        return best


@criteria.register("stability")
class Stability(Criterion):
    """docs/theory.md, *The closure cycle* criterion 5: after remapping, re-running the DEM of the existing assembly in the new flow
    moves no mass more than the threshold (m). Not satisfied while the re-run has not been made."""

    name, kind, units = "stability", "length", "m"
    description = "largest displacement of the assembly re-run in the new flow"

    def value(self, ctx):
        return np.inf if ctx.stability_displacement is None else ctx.stability_displacement


@criteria.register("speed_change")
class SpeedChange(Criterion):
    """docs/theory.md, *The closure cycle* criterion 6: ``|max speed(g) − max speed(g−1)|`` (m/s): one more mass no longer helps."""

    name, kind, units = "speed_change", "speed", "m s-1"
    description = "change of the maximum fluid speed since the previous cycle"

    def value(self, ctx):
        if ctx.previous is None:
            return np.inf
        a = _speed(ctx.snapshot)[_open_wet(ctx.snapshot)]
        b = _speed(ctx.previous)[_open_wet(ctx.previous)]
        return abs((a.max() if a.size else 0.0) - (b.max() if b.size else 0.0))


class EndCriteria:
    """A combination of criteria: closure when ``any`` / ``all`` are satisfied; stop at ``max_cycles``.

    >>> ec = EndCriteria.from_config({"mode": "any", "max_cycles": 20, "max_speed": "0.2 m/s"})
    >>> [c.name for c in ec.items], ec.max_cycles
    (['max_speed'], 20)
    """

    def __init__(self, items, mode: str = "any", max_cycles: int = 50):
        if not isinstance(mode, str) or mode not in ("any", "all"):
            raise InputError(f"criteria.mode must be 'any' or 'all', got {mode!r}")
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, (int, np.integer)):
            raise InputError(f"criteria.max_cycles must be a whole number, got {max_cycles!r}")
        if int(max_cycles) < 1:
            raise InputError(f"criteria.max_cycles must be >= 1, got {max_cycles}")
        self.items = list(items)
        self.mode = mode
        self.max_cycles = int(max_cycles)

    @classmethod
    def from_config(cls, cfg: dict) -> "EndCriteria":
        cfg = dict(cfg)
        mode = cfg.pop("mode", "any")
        max_cycles = cfg.pop("max_cycles", 50)
        items = []
        for name, spec in cfg.items():
            c = criteria.get(name)
            items.append(c(**spec) if isinstance(spec, dict) else c(spec))
        return cls(items, mode, max_cycles)

    def needs(self, name: str) -> bool:
        return any(c.name == name for c in self.items)

    def evaluate(self, ctx: CycleContext) -> tuple[bool, list[CriterionResult], str]:
        """Return (closure achieved, results, governing criterion name or '')."""
        results = [c.evaluate(ctx) for c in self.items]
        ok = [r.satisfied for r in results]
        if not results:
            return False, results, ""
        done = any(ok) if self.mode == "any" else all(ok)
        governing = ""
        if done:
            governing = next(r.name for r in results if r.satisfied) if self.mode == "any" else "+".join(r.name for r in results)
        return done, results, governing


@criteria.register("seepage_discharge")
class SeepageDischarge(Criterion):
    """The part of the breach discharge through the porous pile (m³/s; ``remap = "porous"``)."""

    name, kind, units = "seepage_discharge", "discharge", "m3 s-1"
    description = "breach discharge through the porous pile"

    def value(self, ctx):
        return abs(ctx.seepage_discharge)


@criteria.register("seepage_fraction")
class SeepageFraction(Criterion):
    """The seepage through the porous pile as a fraction of the open breach's discharge (before the first
    mass; dimensionless). Not met while the open-breach discharge is unknown."""

    name, kind, units = "seepage_fraction", "dimensionless", "1"
    description = "seepage through the pile / discharge of the open breach"

    def value(self, ctx):
        q0 = abs(ctx.open_breach_discharge)
        return abs(ctx.seepage_discharge) / q0 if q0 > 0 else np.inf


@criteria.register("overflow_discharge")
class OverflowDischarge(Criterion):
    """The part of the breach discharge over the pile's crest and through open cells (m³/s): the breach
    discharge minus the seepage through the pile, both in the same section (:func:`seepage_in_section`)."""

    name, kind, units = "overflow_discharge", "discharge", "m3 s-1"
    description = "breach discharge over the crest"

    def value(self, ctx):
        q = section_discharge(ctx.snapshot, ctx.breach_x, ctx.levee_y, ctx.flow_sign)
        return max(abs(q) - abs(ctx.seepage_discharge), 0.0)

