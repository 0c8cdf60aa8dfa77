"""Delivery methods: how the masses of a closure reach the breach, and how fast (``[closure] method``).

A method has a capacity (tonnes per working hour), the unit masses it can carry, the placement
strategies it can work (where the masses land: ``vertical`` / ``line`` across the whole gap from the
water, ``horizontal`` from the breach heads), the working hours per day and the wind speed above which
it stops. The operation time of a closure follows from the tonnes delivered: ``work = tonnes /
capacity`` hours of work, spread over the working hours of each day and the calm spells of the wind
record (:class:`DeliveryClock`).

Built-in methods (registry :data:`delivery_methods`, entry-point group ``breachflow.delivery_methods``);
their defaults and sources are in the documentation page "The closure in time":

* ``split_barge`` — bottom-dumping barges along the closure line (vertical closure);
* ``barge_crane`` — a floating crane placing units from a barge (vertical closure);
* ``end_dumping`` — trucks tipping from the breach heads, the front advancing (horizontal closure);
* ``cableway`` — gondolas on a cable over the gap dropping units (vertical closure; Delta Works);
* ``helicopter`` — heavy-lift helicopters dropping big bags (any position).

A plug-in registers a class with the same fields (:class:`DeliveryMethod`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from ..registry import Registry

HOUR = 3600.0
DAY = 86400.0
TONNE = 1000.0


@runtime_checkable
class DeliveryMethodProtocol(Protocol):
    """What the timeline reads from a delivery method (SI)."""

    name: str
    capacity: float  #: kg/s of working time
    unit_mass: tuple  #: (lightest, heaviest) unit it handles, kg
    positions: tuple  #: placement strategies it can work
    working_hours: float  #: s of work per day
    wind_limit: float  #: m/s; work stops above

    def work_time(self, mass: float) -> float: ...


#: the delivery methods by name (``[closure] method``)
delivery_methods: Registry = Registry("delivery method", "breachflow.delivery_methods")


@dataclass
class DeliveryMethod:
    """A delivery method (SI). ``capacity`` kg per second of working time; ``unit_mass`` (low, high) kg;
    ``positions`` the placement strategies (``[placement] positions``) it can work; ``working_hours``
    seconds of work per calendar day; ``wind_limit`` m/s; ``closure`` ``"vertical"`` | ``"horizontal"``
    (how the dam grows); ``source`` where the defaults come from."""

    name: str = "custom"
    capacity: float = 350.0 * TONNE / HOUR
    unit_mass: tuple = (0.0, np.inf)
    positions: tuple = ("line", "vertical", "horizontal", "zone", "list")
    working_hours: float = 24.0 * HOUR
    wind_limit: float = 13.0
    closure: str = "vertical"
    source: str = ""

    #: keys of ``[closure]`` that override a method's default, and their unit kinds
    OVERRIDES = {"capacity": "kg/s", "working_hours": "time", "wind_limit": "speed", "unit_mass": "mass"}

    def __post_init__(self):
        if not (np.isfinite(self.capacity) and self.capacity > 0):
            raise InputError(f"[closure] capacity must be > 0 t/h, got {self.capacity * HOUR / TONNE!r} t/h")
        if not (0 < self.working_hours <= DAY):
            raise InputError(f"[closure] working_hours must be in (0, 24] h per day, got {self.working_hours / HOUR:g} h")
        if not self.wind_limit > 0:
            raise InputError(f"[closure] wind_limit must be > 0 m/s, got {self.wind_limit!r}")
        lo, hi = (float(v) for v in self.unit_mass)
        if not 0 <= lo <= hi:
            raise InputError(f"[closure] unit_mass must be [low, high] with 0 <= low <= high, got {self.unit_mass!r}")
        self.unit_mass = (lo, hi)

    def work_time(self, mass: float) -> float:
        """Working time (s) to deliver *mass* (kg)."""
        return float(mass) / self.capacity

    def with_overrides(self, **kw) -> "DeliveryMethod":
        """A copy with some fields replaced (``capacity`` kg/s, ``working_hours`` s, ``wind_limit`` m/s,
        ``unit_mass`` (low, high) kg)."""
        known = {f.name for f in fields(self)}
        bad = set(kw) - known
        if bad:
            raise InputError(f"delivery method: unknown field(s) {sorted(bad)}")
        return replace(self, **kw)

    def check_placement(self, plan) -> None:
        """Refuse a placement the method cannot do: a strategy it does not work, or units outside its range."""
        if plan.positions not in self.positions:
            raise InputError(f"[placement] positions = {plan.positions!r}: the delivery method {self.name!r} places "
                             f"masses by {', '.join(self.positions)} only")
        d = np.asarray(plan.diameter, float)
        rho = np.asarray(plan.density, float)
        m = np.pi / 6.0 * d ** 3 * rho
        lo, hi = float(m.min()), float(m.max())
        if lo < self.unit_mass[0] * (1 - 1e-9) or hi > self.unit_mass[1] * (1 + 1e-9):
            mix = getattr(plan, "mix", None)
            what = ("[placement] diameter/density: units of" if mix is None else
                    f"[placement] material = {_material_label(plan.material)}: its grading gives units of")
            raise InputError(f"{what} {lo / TONNE:.3g}–{hi / TONNE:.3g} t, but the "
                             f"delivery method {self.name!r} handles {self.unit_mass[0] / TONNE:g}–"
                             f"{self.unit_mass[1] / TONNE:g} t units ([closure] unit_mass overrides)")

    def describe(self) -> str:
        return (f"{self.name}: {self.capacity * HOUR / TONNE:,.0f} t/h, units {self.unit_mass[0] / TONNE:g}–"
                f"{self.unit_mass[1] / TONNE:g} t, {self.working_hours / HOUR:g} h/day, wind limit {self.wind_limit:g} m/s, "
                f"{self.closure} closure ({', '.join(self.positions)})")


def _material_label(material) -> str:
    """A closure material as the scenario names it: a name, a table's ``name``, or a list of them."""
    items = material if isinstance(material, (list, tuple)) else [material]
    names = [m.get("name", "?") if isinstance(m, dict) else getattr(m, "name", m) for m in items]
    return repr(names[0]) if len(names) == 1 else "[" + ", ".join(map(repr, names)) + "]"


def _builtin(name, **defaults):
    cls = type(name.title().replace("_", ""), (DeliveryMethod,), {"__doc__": defaults.get("source", "")})

    def make(**kw):
        return cls(**{"name": name, **defaults, **kw})

    make.defaults = dict(defaults)
    make.__doc__ = defaults.get("source", "")
    delivery_methods.register(name, make)
    return make


split_barge = _builtin("split_barge", capacity=1000.0 * TONNE / HOUR, unit_mass=(0.0, 15.0 * TONNE),
         positions=("line", "vertical", "zone", "list"), working_hours=24.0 * HOUR, wind_limit=25.0,
         closure="vertical",
         source="order of magnitude (no single published figure): several split barges of some 1,000 t each, one "
                "dumped every hour or so; wind limit of ship cranes (report §2.4)")
barge_crane = _builtin("barge_crane", capacity=400.0 * TONNE / HOUR, unit_mass=(0.0, 20.0 * TONNE),
         positions=("line", "vertical", "zone", "list"), working_hours=24.0 * HOUR, wind_limit=25.0,
         closure="vertical",
         source="order of magnitude as the Jones Tract closure (2004, rock placed from barges, 300–400 t/h); "
                "wind limit of ship cranes (report §2.4)")
end_dumping = _builtin("end_dumping", capacity=350.0 * TONNE / HOUR, unit_mass=(0.0, 15.0 * TONNE),
         positions=("horizontal",), working_hours=24.0 * HOUR, wind_limit=13.0, closure="horizontal",
         source="Jones Tract 2004: more than 200,000 t in about 27 days, 300–400 t/h (Harder 2012); wind limit "
                "of land cranes (report §2.4)")
cableway = _builtin("cableway", capacity=300.0 * TONNE / HOUR, unit_mass=(0.0, 10.0 * TONNE),
         positions=("line", "vertical"), working_hours=24.0 * HOUR, wind_limit=13.0, closure="vertical",
         source="Grevelingen cableway (1963-64): gondolas of 10 t, together about 300 t/h, night work "
                "(Delta Works); the Brouwersdam cableway was built for 1,200 t/h at 12 h/day")
helicopter = _builtin("helicopter", capacity=20.0 * TONNE / HOUR, unit_mass=(1.0 * TONNE, 10.0 * TONNE),
         positions=("line", "vertical", "horizontal", "zone", "list"), working_hours=12.0 * HOUR, wind_limit=13.0,
         closure="vertical",
         source="17th Street Canal 2005: 1.4 t (3,000 lb) bags dropped about every five minutes by one helicopter "
                "(~17 t/h), 9 t bags by heavy-lift helicopters; daylight work assumed")


def delivery_method(name: str, **overrides) -> DeliveryMethod:
    """The delivery method *name* with its defaults, some replaced by *overrides* (SI)."""
    factory = delivery_methods.get(name)
    method = factory()
    return method.with_overrides(**overrides) if overrides else method


@dataclass
class DeliveryClock:
    """Calendar time of a delivery: work happens during ``working_hours`` of each day (counted from the
    closure's start) and while the wind is at or below the method's limit.

    ``wind``: ``(times s since the breach, speeds m/s)`` or None (always calm). ``step``: resolution of
    the calendar (s) when work is interrupted; with round-the-clock work and no wind record the
    calendar time is the working time exactly."""

    method: DeliveryMethod
    start: float = 0.0
    wind: tuple | None = None
    step: float = 60.0
    _grid: tuple = field(default=None, init=False, repr=False)

    @property
    def continuous(self) -> bool:
        return self.wind is None and self.method.working_hours >= DAY

    def working(self, t) -> np.ndarray:
        """Whether work goes on at the times *t* (s since the breach)."""
        t = np.asarray(t, float)
        ok = (t >= self.start) & (np.mod(t - self.start, DAY) < self.method.working_hours)
        if self.wind is not None:
            wt, ws = self.wind
            speed = np.interp(t, wt, ws)
            ok &= speed <= self.method.wind_limit
        return ok

    def time_after(self, work: float) -> float:
        """Calendar time (s since the breach) at which *work* seconds of work are done from ``start``."""
        work = float(work)
        if work <= 0:
            return float(self.start)
        if self.continuous:
            return float(self.start + work)
        horizon = max(2.0 * DAY, 4.0 * work * DAY / self.method.working_hours)
        for _ in range(12):
            if self._grid is None or self._grid[0][-1] < self.start + horizon:
                t = self.start + np.arange(0.0, horizon + self.step, self.step)
                done = np.concatenate([[0.0], np.cumsum(self.working(t[:-1] + 0.5 * self.step) * self.step)])
                self._grid = (t, done)
            t, done = self._grid
            if done[-1] >= work:
                i = int(np.searchsorted(done, work))
                return float(t[i - 1] + (work - done[i - 1]))
            horizon *= 2.0
        raise InputError(f"[closure] method {self.method.name!r}: the wind never falls below its limit of "
                         f"{self.method.wind_limit:g} m/s long enough to deliver the masses")
