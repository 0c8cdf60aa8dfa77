"""The time-coupling keys of ``[closure]`` (``method``, ``start``, ``breach_date`` and the method's
overrides) and the :class:`~breachflow.cycle.timeline.Timeline` of a parsed scenario."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import BreachflowError, InputError

#: keys of ``[closure]`` read here
TIMELINE_KEYS = ("method", "start", "breach_date", "capacity", "working_hours", "wind_limit", "unit_mass", "flood")
#: ``[closure] flood``: the flood and polder levels follow ``[flood]`` / ``[polder]``, or are held frozen
FLOOD_MODES = ("follow", "frozen")


@dataclass
class TimelineKeys:
    """The time-coupling keys of ``[closure]`` (SI). ``method`` None: no timeline (the deprecated
    ``[placement] rate`` gives the operation time)."""

    method: str | None = None
    start: float = 0.0
    breach_date: str | None = None
    overrides: dict | None = None
    #: ``"frozen"``: the method's clock only, the flood and polder levels held (cycle/frozen_timeline.py)
    flood: str = "follow"

    @classmethod
    def from_table(cls, table, ctx) -> "TimelineKeys":
        # every key is read first (the scenario reference records them), then checked
        method = ctx.raw(table, "method")
        start = ctx.quantity(table, "start", "time", default="0 h", nonnegative=True)
        date = ctx.raw(table, "breach_date")
        flood = ctx.raw(table, "flood", default="follow")
        over = {}
        for key, kind in (("capacity", "kg/s"), ("working_hours", "time"), ("wind_limit", "speed")):
            if key in table:
                if key == "wind_limit" and isinstance(table[key], str) and table[key].strip().lower() in ("land", "ship"):
                    from ...scenario.wind import crane_limit

                    over[key] = float(crane_limit(table[key]))
                    continue
                over[key] = ctx.quantity(table, key, kind, positive=True)
        unit_mass = ctx.raw(table, "unit_mass", types=(list,))
        if method:
            from ..delivery import delivery_methods

            try:
                delivery_methods.get(method)
            except InputError as exc:
                raise ctx.error(str(exc), "method") from None
        elif any(k in table for k in TIMELINE_KEYS if k != "method"):
            key = next(k for k in TIMELINE_KEYS if k in table and k != "method")
            raise ctx.error("needs method (the delivery method, e.g. \"split_barge\") to couple the closure to time", key)
        if flood not in FLOOD_MODES:
            raise ctx.error(f"flood must be one of {FLOOD_MODES} (\"frozen\": the flood and polder levels held, the "
                            f"operation time from the method), got {flood!r}", "flood")
        if np.ndim(np.asarray(getattr(start, "values", start))) != 0:
            raise ctx.error("one start time per run (sweep it with the feasibility pipeline or an ensemble)", "start")
        if date is not None:
            try:
                np.datetime64(date, "s")
            except ValueError:
                raise ctx.error(f"not an ISO date-time: {date!r} (e.g. \"2004-06-03T07:50\")", "breach_date") from None
        if unit_mass is not None:
            if len(unit_mass) != 2:
                raise ctx.error(f"unit_mass must be [lightest, heaviest], got {unit_mass!r}", "unit_mass")
            over["unit_mass"] = tuple(float(v) for v in ctx.quantity({"unit_mass": unit_mass}, "unit_mass", "mass").values)
        over = {k: (v if isinstance(v, tuple) else float(v)) for k, v in over.items()}
        if method and over:
            from ..delivery import delivery_method

            try:
                delivery_method(method, **over)
            except BreachflowError as exc:
                key = next((k for k in over if k in str(exc)), None)
                raise ctx.error(str(exc).removeprefix("[closure] "), key) from None
        return cls(method or None, float(getattr(start, "values", start)), date, over or None, flood)

    @staticmethod
    def schema_keys() -> dict:
        """JSON-schema entries of the keys (for the scenario reference)."""
        from ...scenario.reference import quantity_schema
        from ..delivery import delivery_methods

        def q(kind, desc, **kw):
            spec = quantity_schema(kind, sweep=False, **kw)
            spec["description"] = desc
            return spec

        return {
            "method": {"type": "string", "enum": list(delivery_methods.available()),
                       "description": "delivery method (cycle/delivery.py): couples the closure to time (operation "
                                      "time from tonnes / capacity, flood stage and polder level per cycle)"},
            "start": q("time", "start of the closure after the breach (default 0 h)", default="0 h", nonnegative=True),
            "breach_date": {"type": "string", "description": "ISO date-time of the breach: dates in the closure plan "
                                                             "and CF time units 'seconds since' it"},
            "capacity": q("kg/s", "override of the method's capacity, e.g. \"1000 t/hr\"", positive=True),
            "working_hours": q("time", "override of the method's working hours per day, e.g. \"12 h\"", positive=True),
            "wind_limit": q("speed", "override of the method's wind limit (a speed, or \"land\" / \"ship\")",
                            positive=True),
            "unit_mass": {"type": "array", "items": {"type": "string"}, "minItems": 2, "maxItems": 2,
                          "description": "override of the unit masses the method handles: [lightest, heaviest]"},
            "flood": {"type": "string", "enum": list(FLOOD_MODES), "default": "follow",
                      "description": "\"follow\": each cycle at the flood stage and polder level of its operation time; "
                                     "\"frozen\": the flood and polder held at the site's flood level and the polder's "
                                     "initial level, only the operation time follows the method (always so for "
                                     "an ingested flow model)"},
        }


def shifted_boundaries(boundaries: dict, delta: float) -> dict:
    """*boundaries* with every prescribed level raised by *delta* (m; a callable level keeps its shape)."""
    from dataclasses import replace

    if delta == 0.0:
        return boundaries
    out = {}
    for side, bcs in boundaries.items():
        new = []
        for bc in bcs:
            if bc.kind == "level" and bc.level is not None:
                lv = bc.level
                level = (lambda s, f=lv, d=delta: np.asarray(f(s), float) + d) if callable(lv) else np.asarray(lv, float) + delta
                bc = replace(bc, level=level)
            new.append(bc)
        out[side] = new
    return out


def polder_terrain(section, domain=None, breach_centre=(0.0, 0.0), protected_sign: float = 1.0):
    """The terrain of ``[polder] storage = "terrain"``: ``(bed, x, y, seed_xy, protected_mask)`` of the
    GeoTIFF ``[polder] terrain`` (no seed or mask: the section gives them), else of the flow model's
    *domain*: its bed, the protected side of the levee centreline (``protected_sign`` +1: at larger y) and
    the breach's landside cell (one cell landward of the centreline at the breach's centre)."""
    if section.terrain is not None:
        from ...site.terrain import load_terrain

        t = load_terrain(section.terrain)
        return np.asarray(t.z, float), np.asarray(t.x, float), np.asarray(t.y, float), None, None
    if domain is None:
        return None
    x, y = np.asarray(domain.x, float), np.asarray(domain.y, float)
    xc, yc = float(breach_centre[0]), float(breach_centre[1])
    dy = abs(float(y[1] - y[0]))
    protected = np.broadcast_to(((y - yc) * protected_sign > 0)[:, None], (y.size, x.size))
    return np.asarray(domain.bed, float), x, y, (xc, yc + protected_sign * dy), protected


def build_timeline(scenario, keys: TimelineKeys, *, site_level: float, ground: float, bottom: float,
                   length: float, wall_slope: float, built=None, levee=None, placement=None, terrain=None,
                   frozen: bool = False):
    """The :class:`~breachflow.cycle.timeline.Timeline` of a scenario with ``[closure] method``: the flood
    stage (the site's stage series, else ``[flood]``, else the site's constant level), the polder
    (``[polder]``; required), the delivery method with its overrides, the breach growth before the start
    (``[breach] growth``) and the wind record (``[wind]``). *terrain*: :func:`polder_terrain`, for
    ``[polder] storage = "terrain"``. *frozen*: the levels will be held (the polder is then optional: without
    ``[polder]`` a polder of unknown area, ``polder.area`` inf, that never rises)."""
    from ..delivery import delivery_method
    from ..timeline import FloodStage, Timeline, flood_stage_from_section

    if "polder" not in scenario and frozen:
        from ...scenario.polder import Polder

        polder = Polder(area=float("inf"), initial_level=ground)
    elif "polder" not in scenario:
        raise InputError("[closure] method: the closure in time needs a [polder] section (area, pump_capacity, "
                         "initial_level) for the protected-side level")
    else:
        polder = scenario["polder"].polder(ground, terrain)
    if built is not None and built.stage is not None:
        stage = FloodStage(built.level_at, "the site's stage series")
    elif "flood" in scenario:
        stage = flood_stage_from_section(scenario["flood"], ground)
    else:
        stage = FloodStage.constant(site_level)
    method = delivery_method(keys.method, **(keys.overrides or {}))
    if placement is not None:
        method.check_placement(placement)
    growth = None
    b = scenario.get("breach")
    if b is not None and b.growth is not None:
        from ...scenario.growth import breach_length

        eq = b.growth if isinstance(b.growth, str) else b.growth[0]
        if eq == "all":
            raise InputError("[breach] growth: the closure in time takes one growth equation, not 'all'")
        h_w = max(stage(0.0) - ground, 1e-3)

        def growth(t, eq=eq, h=h_w):
            return float(breach_length(eq, f"{max(t, 0.0)!r} s", surge_height=f"{h!r} m", levee=levee))
    wind = None
    if "wind" in scenario:
        from ...scenario.wind import WindRecord

        w = scenario["wind"]
        rec = WindRecord.from_csv(w.record, crest_time=w.crest_time)
        t0 = float(getattr(scenario["flood"], "breach_time", 0.0) or 0.0) if "flood" in scenario else 0.0
        wind = (np.asarray(rec.times, float) - t0, np.asarray(rec.speed, float))
    date = np.datetime64(keys.breach_date, "s") if keys.breach_date else None
    return Timeline(stage=stage, polder=polder, method=method, start=keys.start, bottom=bottom, length=length,
                    wall_slope=wall_slope, growth=growth, wind=wind, breach_date=date, ground=ground)
