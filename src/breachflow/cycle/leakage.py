"""A closure is done when what still flows through the dam is less than the polder can take.

The flow left through the dam (overflow + seepage, the breach discharge ``Q`` through the breach section) is
stated as the rise of the polder's water level per day, ``86 400 Q / A_P`` (m/day, polder area ``A_P``), and
against the pump capacity ``Q_P``: the polder takes the leakage when the net rise ``86 400 (Q - Q_P) / A_P``
is at most the allowed rise per day (:func:`polder_leakage_check`). The registered end criterion
``polder_leakage`` (threshold: the allowed rise, e.g. ``"1 cm/day"``) reads the polder's area and pump
capacity from the scenario's ``[polder]`` (or from its own ``area`` / ``pump_capacity`` keys); without them
it falls back to the older criterion ``seepage_fraction < 0.3`` (seepage through the pile below 30 % of the
open breach's discharge) and says so.

Sealing. With ``seal = ["sand", "gravel", "quarry_run"]`` (finest first; names of
:data:`breachflow.materials.seal.DEFAULT_SEAL_GRADINGS` or tables ``{name, d15, d50, d85, porosity,
density}``) the criterion judges the dam *after* a seal on its upstream face: once the overflow alone is
below what the polder takes, it finds the thinnest seal layer (up to ``max_seal_thickness``, with each
filter ``filter_thickness`` thick) that brings the seepage down far enough (1-D Forchheimer flow through the
layers in series, :mod:`breachflow.materials.seal`) and reports its thickness and tonnage per layer. The
dam's flow path is its mean width, the bulk volume of the resting masses over the gap width and the wetted
height; the head is the flood level minus the water level behind the dam. The filter rules between the
layers and the rock are checked when the scenario is read. A layer can also be a rock grading of the
materials registry (``"LMA_40_200"``, its D_n15/D_n50/D_n85). A last entry ``"auto"`` is replaced, once the
dam's rock is known, by the shortest run of EN 13383 gradings that passes both rules up to it
(:func:`~breachflow.materials.seal.bridge_filters`); when there is none the run ends before its first cycle with
the verdict "no seal designable" (:func:`undesignable_seal`).

When the rock dam is closed this way, the seal is placed in the flow model's pile and re-solved until the
leakage read from the flow meets the criterion (:mod:`breachflow.cycle.sealing`; keys ``seal_method``,
``seal_capacity``, ``seal_available``, ``seal_steps``, ``seal_leakage``); the run is closed only if it does.
The rock stage ends only on a steady re-solve with the pile's crest, read from the units, above the flood
level all along the gap (:mod:`breachflow.cycle.rock_end`; keys ``rock_end`` and ``steady_cap``).
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
#: the old criterion the fallback uses when the polder is unknown (seepage / open-breach discharge); the
#: default of the key ``fallback_fraction``
FALLBACK_SEEPAGE_FRACTION = 0.3
#: the smallest factor by which a seal re-solved in the flow model is thickened between two re-solves while
#: the polder does not take the leakage (:func:`breachflow.cycle.sealing.seal_dam`); the key ``seal_growth``
SEAL_GROWTH = 1.25


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

    def __init__(self, threshold=f"{DEFAULT_ALLOWED_RISE} m/day", area=None, pump_capacity=None, seal=None,
                 filter_thickness="0.5 m", max_seal_thickness="2 m", face_slope=None, law=None,
                 seal_method=None, seal_capacity=None, seal_available=None, seal_steps=6,
                 seal_leakage="series", seal_compare=False, rock_end="emergent", steady_cap=None,
                 fallback_fraction=FALLBACK_SEEPAGE_FRACTION, retention_limit=None, permeability_limit=None,
                 seal_growth=SEAL_GROWTH):
        from ..materials.seal import PERMEABILITY_LIMIT, RETENTION_LIMIT

        self.threshold = to_si(threshold, name="criteria.polder_leakage", kind="speed",
                               nonnegative=True) * SECONDS_PER_DAY
        self.area = None if area is None else to_si(area, name="criteria.polder_leakage.area", kind="area",
                                                     positive=True)
        self.pump_capacity = None if pump_capacity is None else to_si(
            pump_capacity, name="criteria.polder_leakage.pump_capacity", kind="discharge", nonnegative=True)
        self._fallback = None
        # the fallback without a polder, the filter rules between the layers and the seal's thickening: keys
        # with their defaults stated once (FALLBACK_SEEPAGE_FRACTION, materials.seal, SEAL_GROWTH)
        self.fallback_fraction = to_si(fallback_fraction, name="criteria.polder_leakage.fallback_fraction",
                                       kind="dimensionless", default_unit="", positive=True)
        self.retention_limit = to_si(RETENTION_LIMIT if retention_limit is None else retention_limit,
                                     name="criteria.polder_leakage.retention_limit", kind="dimensionless",
                                     default_unit="", positive=True)
        self.permeability_limit = to_si(PERMEABILITY_LIMIT if permeability_limit is None else permeability_limit,
                                        name="criteria.polder_leakage.permeability_limit", kind="dimensionless",
                                        default_unit="", positive=True)
        self.seal_growth = to_si(seal_growth, name="criteria.polder_leakage.seal_growth", kind="dimensionless",
                                 default_unit="")
        if not self.seal_growth > 1.0:
            raise InputError(f"criteria.polder_leakage.seal_growth must be > 1 (the seal grows between re-solves), "
                             f"got {seal_growth!r}")
        from ..materials.seal import AUTO_FILTERS

        seal = None if seal is None else (seal if isinstance(seal, list) else [seal])
        # a last entry "auto": the filters from the last named layer to the dam's rock are chosen by the filter
        # rules among the EN 13383 gradings when the rock is known (bind_rock)
        self.auto_filters = bool(seal) and seal[-1] == AUTO_FILTERS
        if seal and AUTO_FILTERS in seal:
            if not self.auto_filters or seal.index(AUTO_FILTERS) == 0 or seal.count(AUTO_FILTERS) > 1:
                raise InputError(f"criteria.polder_leakage.seal: {AUTO_FILTERS!r} may only end a list of named layers "
                                 f"(e.g. [\"sand\", \"gravel\", \"quarry_run\", \"{AUTO_FILTERS}\"]), got {seal!r}")
            seal = seal[:-1]
        self.named_layers = None if seal is None else [_grading(g) for g in seal]
        self.seal_layers = None if self.named_layers is None else list(self.named_layers)
        #: why no seal can be designed for the dam's rock (``"auto"`` found no filters), else None
        self.undesignable = None
        self.filter_thickness = to_si(filter_thickness, name="criteria.polder_leakage.filter_thickness",
                                      kind="length", positive=True)
        self.max_seal_thickness = to_si(max_seal_thickness, name="criteria.polder_leakage.max_seal_thickness",
                                        kind="length", positive=True)
        # the upstream face's slope (H per V): the dam's side slopes ([placement] side_slope) unless given here
        self.face_slope = None if face_slope is None else to_si(
            face_slope, name="criteria.polder_leakage.face_slope", kind="dimensionless", default_unit="",
            nonnegative=True)
        self.law = law
        self.rock = None
        self.seal_plan = None
        # the seal in the flow model (cycle.sealing): its delivery method and capacity, the tonnes available
        # and the number of re-solves allowed to thicken it
        if seal_method is not None:
            from .delivery import delivery_method

            delivery_method(str(seal_method))  # an unknown name is refused when the scenario is read
        self.seal_method = None if seal_method is None else str(seal_method)
        self.seal_capacity = None if seal_capacity is None else to_si(
            seal_capacity, name="criteria.polder_leakage.seal_capacity", kind="kg/s", positive=True)
        self.seal_available = None if seal_available is None else to_si(
            seal_available, name="criteria.polder_leakage.seal_available", kind="mass", positive=True) / 1000.0
        self.seal_steps = int(seal_steps)
        if seal_leakage not in ("flow_model", "series"):
            raise InputError(f"criteria.polder_leakage.seal_leakage = {seal_leakage!r}; use 'flow_model' (the "
                             f"re-solved breach discharge) or 'series' (1-D layers with the re-solved levels)")
        self.seal_leakage = seal_leakage
        self.seal_compare = bool(seal_compare)
        # when the rock stage may end (cycle.rock_end): the rule and the simulated time a judging re-solve may take
        from .rock_end import ROCK_END_RULES, STEADY_CAP

        if rock_end not in ROCK_END_RULES:
            raise InputError(f"criteria.polder_leakage.rock_end = {rock_end!r}; use one of {ROCK_END_RULES}")
        self.rock_end = rock_end
        self.steady_cap = STEADY_CAP if steady_cap is None else to_si(
            steady_cap, name="criteria.polder_leakage.steady_cap", kind="time", positive=True)
        if self.seal_steps < 1:
            raise InputError(f"criteria.polder_leakage.seal_steps must be >= 1, got {seal_steps!r}")

    #: the keys of ``[criteria] polder_leakage = { ... }``: unit kind (or TOML type) and meaning; the defaults are
    #: those of ``__init__`` (:meth:`option_schema`)
    KEYS = {
        "threshold": ("speed", "allowed net polder rise (e.g. \"1 cm/day\")"),
        "area": ("area", "polder area; default [polder] area"),
        "pump_capacity": ("discharge", "pump capacity; default [polder] pump_capacity, else 0"),
        "fallback_fraction": ("dimensionless", "without a polder area: the closure is judged by seepage through "
                                               "the pile below this fraction of the open breach's discharge"),
        "seal": ("array", "seal layers, finest first: names or tables {name, d15, d50, d85, porosity, density}; a "
                          "last entry \"auto\" adds the shortest run of EN 13383 gradings up to the dam's rock "
                          "that passes the filter rules"),
        "filter_thickness": ("length", "thickness of each filter layer between the seal and the rock"),
        "max_seal_thickness": ("length", "thickest seal allowed"),
        "face_slope": ("dimensionless", "slope of the dam's upstream face (H per V) the seal covers; default "
                                        "[placement] side_slope"),
        "retention_limit": ("dimensionless", "filter rule: largest D15 of a layer / D85 of the finer layer "
                                             "upstream of it (Terzaghi)"),
        "permeability_limit": ("dimensionless", "filter rule: smallest D15 of a layer / D15 of the finer layer "
                                                "upstream of it (Terzaghi)"),
        "law": ("string", "porous flow law of the layers (breachflow.porous_laws): ergun | van_gent | ergun_dilute"),
        "seal_method": ("string", "delivery method of the seal material"),
        "seal_capacity": ("kg/s", "delivery capacity of the seal material (e.g. \"300 t/hr\")"),
        "seal_available": ("mass", "seal material available"),
        "seal_steps": ("integer", "re-solves allowed to thicken the seal"),
        "seal_growth": ("dimensionless", "smallest factor by which the seal is thickened between re-solves (> 1)"),
        "seal_leakage": ("string", "how the leakage after the seal is read: series | flow_model"),
        "seal_compare": ("boolean", "also re-solve the seal with the flow through it left to the flow model"),
        "rock_end": ("string", "when the rock stage may end (breachflow.cycle.rock_end)"),
        "steady_cap": ("time", "simulated time a judging re-solve may take"),
    }

    @classmethod
    def option_schema(cls) -> dict:
        """JSON-schema properties of the keyword table, defaults from the signature of ``__init__``."""
        import inspect

        from ..scenario.reference import quantity_schema
        from ..units import SI_UNITS

        sig = inspect.signature(cls.__init__).parameters
        defaults = {"retention_limit": "RETENTION_LIMIT", "permeability_limit": "PERMEABILITY_LIMIT"}
        out = {}
        for key, (kind, text) in cls.KEYS.items():
            default = sig[key].default
            if key in defaults:
                from ..materials import seal as _seal

                default = getattr(_seal, defaults[key])
            if kind in ("array", "string", "integer", "boolean"):
                spec = {"type": kind}
            else:
                spec = quantity_schema(kind, default_unit="" if kind == "dimensionless" else None, sweep=False)
                if default is not None and kind == "dimensionless":
                    default = float(default)
                elif default is not None:
                    default = str(default) if isinstance(default, str) else f"{default:g} {SI_UNITS.get(kind, kind)}"
            if default is not None:
                spec["default"] = default
            spec["description"] = text
            out[key] = spec
        return out

    def bind_rock(self, rock) -> None:
        """The dam's rock grading (:class:`~breachflow.materials.seal.Grading`); checks the filter rules from the
        seal through its filters to the rock (:func:`~breachflow.materials.seal.check_filter`)."""
        from ..materials.seal import bridge_filters, check_filter, standard_filter_gradings

        self.rock = rock
        if self.auto_filters:
            self.undesignable = None
            try:
                bridge = bridge_filters(self.named_layers[-1], rock, standard_filter_gradings(),
                                        self.retention_limit, self.permeability_limit)
            except InputError as exc:  # the run ends with this verdict (cycle.driver) instead of a seal
                self.undesignable = f"[criteria] polder_leakage: {exc}"
                self.seal_layers = list(self.named_layers)
                return
            self.seal_layers = [*self.named_layers, *bridge]
        if self.seal_layers:
            try:
                check_filter([*self.seal_layers, rock], self.retention_limit, self.permeability_limit)
            except InputError as exc:
                raise InputError(f"[criteria] polder_leakage {exc}") from None

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
        plan = None
        try:
            plan = scenario["placement"].plan if scenario is not None and "placement" in scenario else None
        except Exception:  # noqa: BLE001 - no placement section: the run's default spheres
            plan = None
        if self.face_slope is None and plan is not None:
            self.face_slope = plan.dam_side_slope
        if self.seal_layers:
            self.bind_rock(_rock_grading(plan))

    def _use_fallback(self):
        if self._fallback is None:
            self._fallback = SeepageFraction(self.fallback_fraction)
            warnings.warn(f"[criteria] polder_leakage: no polder area ([polder] area); the closure is judged by "
                          f"seepage_fraction < {self.fallback_fraction:g} (fallback_fraction) of the open breach's "
                          f"discharge instead",
                          BreachflowWarning, stacklevel=3)

    @property
    def fallback(self) -> bool:
        return self._fallback is not None

    def verdict(self, ctx) -> LeakageVerdict:
        q = section_discharge(ctx.snapshot, ctx.breach_x, ctx.levee_y, ctx.flow_sign)
        return polder_leakage_check(q, self.area, self.pump_capacity or 0.0, self.threshold)

    def value(self, ctx):
        return self.verdict(ctx).net_rise_per_day

    def sealed(self, ctx, v: LeakageVerdict):
        """``(net rise after the seal m/day, plan dict)`` or None when no seal within the limits suffices."""
        from dataclasses import replace

        from ..materials.seal import SealDesign, required_thickness

        target = self.threshold * self.area / SECONDS_PER_DAY + (self.pump_capacity or 0.0)
        qs = min(abs(ctx.seepage_discharge), v.leakage)
        qo = v.leakage - qs
        if qs <= 0.0 or qo >= target:
            return None
        geom = dam_geometry(ctx, self.rock.porosity)
        if geom is None:
            return None
        head, height, length, width = geom
        filters = tuple((g, self.filter_thickness) for g in self.seal_layers[1:])
        design = SealDesign(self.seal_layers[0], self.max_seal_thickness, self.rock, filters, self.law,
                            self.retention_limit, self.permeability_limit)
        if length <= self.max_seal_thickness + self.filter_thickness * len(filters):
            return None
        t = required_thickness(design, qs, target - qo, head, height, length,
                               max_fraction=self.max_seal_thickness / length)
        if not math.isfinite(t):
            return None
        design = replace(design, thickness=max(t, 1e-3))
        q_after = qo + qs * design.reduction(head, height, length)
        face = width * height * math.hypot(1.0, self._face_slope())
        plan = {"seal_thickness": t, "filter_thickness": self.filter_thickness, "face_area": face,
                "tonnage": design.tonnage(face), "leakage_before": v.leakage, "leakage_after": q_after,
                "head": head, "height": height, "flow_path": length}
        return SECONDS_PER_DAY * max(q_after - (self.pump_capacity or 0.0), 0.0) / self.area, plan

    def _face_slope(self) -> float:
        from ..scenario.stone import DEFAULT_SIDE_SLOPE

        return DEFAULT_SIDE_SLOPE if self.face_slope is None else self.face_slope

    def evaluate(self, ctx) -> CriterionResult:
        if self.area is None:
            self._use_fallback()
        if self._fallback is not None:
            r = self._fallback.evaluate(ctx)
            return CriterionResult(r.name, r.value, r.threshold, r.units, r.satisfied,
                                   f"{r.description} (no polder area: fallback of polder_leakage)")
        v = self.verdict(ctx)
        self.seal_plan = None
        if self.undesignable and not v.acceptable:
            return CriterionResult(self.name, v.net_rise_per_day, self.threshold, self.units, False,
                                   f"leakage {v.leakage:.4g} m3/s, net {v.net_rise_per_day:.3g} m/day; {self.undesignable}")
        if self.seal_layers and not v.acceptable and self.rock is not None:
            res = self.sealed(ctx, v)
            if res is not None:
                net, plan = res
                self.seal_plan = plan
                tons = ", ".join(f"{k} {t:.0f} t" for k, t in plan["tonnage"].items())
                return CriterionResult(
                    self.name, net, self.threshold, self.units, bool(net <= self.threshold * (1 + 1e-9)),
                    f"leakage {v.leakage:.4g} m3/s ({v.rise_per_day:.3g} m/day over {self.area:.4g} m2) sealed by "
                    f"{plan['seal_thickness']:.3g} m of {self.seal_layers[0].name} on the upstream face "
                    f"({plan['face_area']:.4g} m2; {tons}): {plan['leakage_after']:.4g} m3/s, net "
                    f"{net:.3g} m/day")
        pump = (f"{v.pump_ratio:.3g} x the pump capacity {self.pump_capacity:.3g} m3/s" if self.pump_capacity
                else "no pumps")
        return CriterionResult(self.name, v.net_rise_per_day, self.threshold, self.units, v.acceptable,
                               f"leakage {v.leakage:.4g} m3/s = polder rise {v.rise_per_day:.3g} m/day over "
                               f"{self.area:.4g} m2 ({pump}); net {v.net_rise_per_day:.3g} m/day")


def undesignable_seal(criteria) -> str | None:
    """The "no seal designable" verdict of the first ``polder_leakage`` criterion among *criteria* (an
    :class:`~breachflow.cycle.criteria.EndCriteria` or a list) whose ``seal = [..., "auto"]`` found no filter
    layers between its named layers and the dam's rock, else None. A closure that needs a seal which no
    standard grading can make is not attempted: the run ends before its first cycle with this verdict."""
    for c in getattr(criteria, "items", criteria) or []:
        reason = getattr(c, "undesignable", None)
        if reason and not getattr(c, "fallback", False):
            return reason
    return None


def _grading(spec):
    """A seal layer: a name of :data:`~breachflow.materials.seal.DEFAULT_SEAL_GRADINGS` or a table."""
    from ..materials.seal import DEFAULT_SEAL_GRADINGS, Grading

    if isinstance(spec, str):
        if spec in DEFAULT_SEAL_GRADINGS:
            return DEFAULT_SEAL_GRADINGS[spec]
        from ..materials import MATERIALS, _load_builtins, get_material
        from ..materials.rock import GradedRock

        _load_builtins()
        try:
            mat = get_material(spec)
        except (InputError, KeyError, LookupError):
            mat = None
        if isinstance(mat, GradedRock):  # a rock grading of the materials registry (EN 13383)
            return Grading.from_rock(mat)
        raise InputError(f"criteria.polder_leakage.seal: unknown layer {spec!r}; use one of "
                         f"{sorted(DEFAULT_SEAL_GRADINGS)}, a rock grading of the materials registry "
                         f"({', '.join(n for n in MATERIALS.available() if n[:3].lower() in ('hma', 'lma'))}) "
                         f"or a table {{name, d15, d50, d85, porosity}}")
    if isinstance(spec, dict):
        spec = dict(spec)
        kw = {k: to_si(spec.pop(k), name=f"criteria.polder_leakage.seal.{k}", kind="length", positive=True)
              for k in ("d15", "d50", "d85") if k in spec}
        try:
            return Grading(name=str(spec.pop("name")), **kw, **{k: float(v) for k, v in spec.items()})
        except (KeyError, TypeError) as exc:
            raise InputError(f"criteria.polder_leakage.seal: a layer table needs name, d15, d50, d85 ({exc})") from None
    raise InputError(f"criteria.polder_leakage.seal: a layer is a name or a table, got {spec!r}")


def _rock_grading(plan):
    """The dam's grading from the placement: a graded-rock material's D_n15/D_n50/D_n85, else the spheres'
    nominal diameters over ``diameter`` (D_n = D (pi/6)^(1/3))."""
    from ..materials.rock import GradedRock
    from ..materials.seal import Grading

    from dataclasses import replace

    from ..scenario.stone import DUMPED_POROSITY

    mix = getattr(plan, "mix", None)
    if mix is not None and isinstance(mix.materials[0], GradedRock):
        g = Grading.from_rock(mix.materials[0])
        return g if plan.porosity is None else replace(g, porosity=float(plan.porosity))
    d = (0.75, 0.75) if plan is None else plan.diameter
    k = (math.pi / 6.0) ** (1.0 / 3.0)
    lo, hi = k * d[0], k * d[1]
    return Grading("rock dam", lo, 0.5 * (lo + hi), hi,
                   porosity=DUMPED_POROSITY if plan is None else plan.pile_porosity)


def dam_geometry(ctx, porosity):
    """``(head m, wetted height m, mean flow path m, gap width m)`` of the dam in *ctx*, or None without one:
    the flow path is the bulk volume of the resting masses in the gap over (gap width x wetted height); the
    head the flood level minus the median water level of the row just behind the dam."""
    import numpy as np

    x0, x1 = ctx.breach_x
    width = x1 - x0
    height = ctx.flood_level - ctx.bottom
    sel = ctx.resting & (ctx.pos[:, 0] >= x0) & (ctx.pos[:, 0] <= x1) if len(ctx.radius) else np.zeros(0, bool)
    if width <= 0 or height <= 0 or not sel.any():
        return None
    solid = float(np.sum(4.0 / 3.0 * np.pi * ctx.radius[sel] ** 3))
    length = solid / (1.0 - porosity) / (width * height)
    ds = ctx.snapshot
    y = np.asarray(ds["y"].values, float)
    x = np.asarray(ds["x"].values, float)
    y_back = float(np.max(ctx.pos[sel, 1] + ctx.radius[sel])) + (abs(y[1] - y[0]) if y.size > 1 else 0.0)
    j = int(np.argmin(np.abs(y - y_back)))
    ws = np.asarray(ds["water_surface"].values, float)[j]
    wet = (np.asarray(ds["depth"].values, float)[j] > 0) & (x >= x0) & (x <= x1)
    behind = float(np.median(ws[wet])) if wet.any() else ctx.bottom
    head = ctx.flood_level - behind
    return (head, height, length, width) if head > 0 and length > 0 else None
