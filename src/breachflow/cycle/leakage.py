"""A closure is done when what still flows through the dam is less than the polder can take.

The flow left through the dam (overflow + seepage, the breach discharge ``Q`` through the breach section) is
stated as the rise of the polder's water level per day, ``86 400 Q / A_P`` (m/day, polder area ``A_P``), and
against the pump capacity ``Q_P``: the polder takes the leakage when the net rise ``86 400 (Q - Q_P) / A_P``
is at most the allowed rise per day (:func:`polder_leakage_check`). The registered end criterion
``polder_leakage`` (threshold: the allowed rise, e.g. ``"1 cm/day"``) reads the polder's area and pump
capacity from the scenario's ``[polder]`` (or from its own ``area`` / ``pump_capacity`` keys); without them
it falls back to the older criterion ``seepage_fraction < 0.3`` (seepage through the pile below 30 % of the
open breach's discharge) and says so.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from ..errors import BreachflowWarning, InputError
from ..units import to_si
from .criteria import Criterion, CriterionResult, SeepageFraction, criteria, section_discharge

SECONDS_PER_DAY = 86400.0
#: allowed net polder rise of the default criterion (m/day): a choice to state, not a standard — set it for
#: the polder at hand (``[criteria] polder_leakage = "… cm/day"``)
DEFAULT_ALLOWED_RISE = 0.01
#: the old criterion the fallback uses when the polder is unknown (seepage / open-breach discharge)
FALLBACK_SEEPAGE_FRACTION = 0.3


@dataclass(frozen=True)
class LeakageVerdict:
    """The leakage (m³/s) as polder rise per day (gross and net of pumping, m/day), as a multiple of the pump
    capacity (``inf`` without pumps), and whether the polder takes it."""

    leakage: float
    rise_per_day: float
    net_rise_per_day: float
    pump_ratio: float
    acceptable: bool


def polder_leakage_check(leakage: float, area: float, pump_capacity: float,
                         allowed_rise_per_day: float) -> LeakageVerdict:
    """Judge a *leakage* (m³/s) into a polder of *area* (m²) with pumps of *pump_capacity* (m³/s): rise
    ``86 400 |Q| / A`` m/day, net rise ``86 400 max(|Q| - Q_P, 0) / A``; acceptable when the net rise is at
    most *allowed_rise_per_day* (m/day)."""
    q, a, p, allowed = abs(float(leakage)), float(area), float(pump_capacity), float(allowed_rise_per_day)
    if not (math.isfinite(a) and a > 0):
        raise InputError(f"polder area must be > 0 m^2, got {area!r}")
    if not (math.isfinite(p) and p >= 0):
        raise InputError(f"pump capacity must be >= 0 m^3/s, got {pump_capacity!r}")
    if not (math.isfinite(allowed) and allowed >= 0):
        raise InputError(f"allowed polder rise must be >= 0 m/day, got {allowed_rise_per_day!r}")
    rise = SECONDS_PER_DAY * q / a
    net = SECONDS_PER_DAY * max(q - p, 0.0) / a
    ratio = q / p if p > 0 else (math.inf if q > 0 else 0.0)
    return LeakageVerdict(q, rise, net, ratio, bool(net <= allowed))


def _polder_of(scenario):
    """``(area m², pump capacity m³/s)`` of the scenario's polder, or None: ``scenario.polder`` when the
    scenario has that attribute, else its ``[polder]`` section."""
    pol = getattr(scenario, "polder", None)
    if pol is None and hasattr(scenario, "get"):
        try:
            pol = scenario.get("polder")
        except Exception:  # noqa: BLE001 - a scenario without the section
            pol = None
    if pol is None:
        return None
    area = getattr(pol, "area", None)
    pump = getattr(pol, "pump_capacity", 0.0) or 0.0
    try:
        area, pump = float(area), float(pump)
    except (TypeError, ValueError):  # a swept polder (DataArray): one run judges one polder
        return None
    return (area, pump) if area > 0 else None


@criteria.register("polder_leakage")
class PolderLeakage(Criterion):
    """Net polder rise per day from the flow left through the dam (m/day; :func:`polder_leakage_check`).

    Threshold: the allowed rise (``"1 cm/day"``); keys ``area`` and ``pump_capacity`` override the scenario's
    ``[polder]``. Without a polder it judges ``seepage_fraction < 0.3`` instead (a warning says so)."""

    name, kind, units, compare = "polder_leakage", "speed", "m day-1", "below"
    description = "net polder rise per day from the leakage through the dam (pumping deducted)"

    def __init__(self, threshold=f"{DEFAULT_ALLOWED_RISE} m/day", area=None, pump_capacity=None):
        self.threshold = to_si(threshold, name="criteria.polder_leakage", kind="speed",
                               nonnegative=True) * SECONDS_PER_DAY
        self.area = None if area is None else to_si(area, name="criteria.polder_leakage.area", kind="area",
                                                     positive=True)
        self.pump_capacity = None if pump_capacity is None else to_si(
            pump_capacity, name="criteria.polder_leakage.pump_capacity", kind="discharge", nonnegative=True)
        self._fallback = None

    def bind_scenario(self, scenario) -> None:
        """Take the polder's area and pump capacity from *scenario* where not given; without them switch to
        the fallback ratio criterion and warn."""
        pol = _polder_of(scenario)
        if self.area is None and pol is not None:
            self.area = pol[0]
        if self.pump_capacity is None:
            self.pump_capacity = pol[1] if pol is not None else 0.0
        if self.area is None:
            self._use_fallback()

    def _use_fallback(self):
        if self._fallback is None:
            self._fallback = SeepageFraction(FALLBACK_SEEPAGE_FRACTION)
            warnings.warn(f"[criteria] polder_leakage: no polder area ([polder] area); the closure is judged by "
                          f"seepage_fraction < {FALLBACK_SEEPAGE_FRACTION:g} of the open breach's discharge instead",
                          BreachflowWarning, stacklevel=3)

    @property
    def fallback(self) -> bool:
        return self._fallback is not None

    def verdict(self, ctx) -> LeakageVerdict:
        q = section_discharge(ctx.snapshot, ctx.breach_x, ctx.levee_y)
        return polder_leakage_check(q, self.area, self.pump_capacity or 0.0, self.threshold)

    def value(self, ctx):
        return self.verdict(ctx).net_rise_per_day

    def evaluate(self, ctx) -> CriterionResult:
        if self.area is None:
            self._use_fallback()
        if self._fallback is not None:
            r = self._fallback.evaluate(ctx)
            return CriterionResult(r.name, r.value, r.threshold, r.units, r.satisfied,
                                   f"{r.description} (no polder area: fallback of polder_leakage)")
        v = self.verdict(ctx)
        pump = (f"{v.pump_ratio:.3g} x the pump capacity {self.pump_capacity:.3g} m3/s" if self.pump_capacity
                else "no pumps")
        return CriterionResult(self.name, v.net_rise_per_day, self.threshold, self.units, v.acceptable,
                               f"leakage {v.leakage:.4g} m3/s = polder rise {v.rise_per_day:.3g} m/day over "
                               f"{self.area:.4g} m2 ({pump}); net {v.net_rise_per_day:.3g} m/day")
