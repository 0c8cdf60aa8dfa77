"""The ``[placement]``, ``[criteria]`` and ``[closure]`` sections: where and when masses are dropped, when
the closure ends, and how the pile enters the flow model (docs/theory.md, *The closure cycle*)."""
from __future__ import annotations

from dataclasses import dataclass, field

from ...errors import BreachflowError
from ...scenario.config import register_section
from ...swe.porous_laws import POROUS_LAWS
from ..criteria import EndCriteria
from ..losses import LOSS_LIMIT
from ..placement import POSITION_MODES, PlacementPlan
from .timeline import TIMELINE_KEYS, TimelineKeys


def _where(ctx, key: str) -> str:
    """File and line of *key* in the section (for a warning)."""
    line = ctx.line_of(key)
    return f"{ctx.path or '<scenario>'}" + (f", line {line}" if line else "")


@register_section("placement")
@dataclass
class PlacementSection:
    """``[placement]``: see :class:`~.placement.PlacementPlan` (``diameter``, ``density``, ``batch``,
    ``positions`` (``line`` | ``zone`` | ``list`` | ``vertical`` | ``horizontal``, :mod:`~.strategies`),
    ``start``/``stop``/``zone``/``points``, ``release_height``, ``rate``, ``material`` (a closure material of
    :mod:`breachflow.materials`, e.g. ``"HMA_1000_3000"``, or a list with ``fractions``))."""

    plan: PlacementPlan

    @classmethod
    def schema_keys(cls) -> dict:
        """The keys :meth:`~breachflow.cycle.placement.PlacementPlan.from_config` reads, their kinds and the plan's defaults."""
        from dataclasses import MISSING, fields

        from ...scenario.reference import quantity_schema
        from ...units import SI_UNITS

        out = {}
        for f in fields(PlacementPlan):
            default = f.default if f.default is not MISSING else None
            kind = PlacementPlan.KEY_KINDS.get(f.name)
            if f.name == "material":
                out[f.name] = {"description": "closure material (breachflow.materials): a name such as "
                                              "\"HMA_1000_3000\", a table {name = ..., parameters}, or a list of them "
                                              "(a mix: each mass carries its own material's drag coefficient, "
                                              "friction and rolling resistance); "
                                              "default: spheres of diameter and density",
                               "anyOf": [{"type": "string"}, {"type": "object"},
                                         {"type": "array", "items": {"anyOf": [{"type": "string"}, {"type": "object"}]}}]}
                continue
            if f.name == "fractions":
                out[f.name] = {"description": "mass fractions of the delivered tonnage, one per material of the list "
                                              "(non-negative, not all zero; default: equal)",
                               "type": "array", "items": {"type": "number", "minimum": 0}}
                continue
            if kind is None:
                out[f.name] = {"type": "integer" if f.name == "batch" else "string"}
                if default is not None:
                    out[f.name]["default"] = default
                if f.name == "positions":
                    out[f.name]["enum"] = list(POSITION_MODES)
                continue
            unit = SI_UNITS.get(kind, kind)
            if f.name in ("porosity", "side_slope"):
                from ...scenario.stone import DEFAULT_SIDE_SLOPE, DUMPED_POROSITY

                out[f.name] = quantity_schema(kind, default_unit="", positive=f.name == "porosity",
                                              nonnegative=f.name == "side_slope", sweep=False)
                out[f.name]["description"] = (
                    "porosity of the dumped pile (the seal's flow path through the dam, the pre-run estimate's "
                    f"tonnage); default: the material's, spheres {DUMPED_POROSITY:g}" if f.name == "porosity" else
                    "side slopes of the dumped dam, H per V (the pre-run estimate's dam, the seal's upstream "
                    f"face); default {DEFAULT_SIDE_SLOPE:g}")
                continue
            if f.name == "rate":
                default = f"{default * 3600:g} 1/hr"
            elif isinstance(default, tuple):
                default = [f"{v:g} {unit}" for v in default]
            elif default is not None:
                default = f"{default:g} {unit}"
            out[f.name] = quantity_schema(kind, default=default, positive=f.name in ("diameter", "density", "rate"),
                                          nonnegative=f.name == "release_height",
                                          default_unit="m" if f.name in ("start", "stop", "zone", "points") else None)
        return out

    @classmethod
    def from_table(cls, table, ctx):
        # a misspelt key is named at its own line; ``material`` may be a table ({name = ..., parameters})
        ctx.check_keys(table, PlacementPlan.__dataclass_fields__, subtables=("material",))
        if "rate" in table:
            import warnings

            warnings.warn(f"{_where(ctx, 'rate')}: [placement] rate: deprecated; the operation time follows from "
                          "the tonnes delivered with [closure] method (a delivery method with its capacity in t/h, "
                          "e.g. method = \"split_barge\"; with flood = \"frozen\" the flood level stays fixed); "
                          "without a method, rate still sets masses per hour",
                          DeprecationWarning, stacklevel=2)
        try:
            return cls(PlacementPlan.from_config(table))
        except (BreachflowError, TypeError, ValueError) as exc:
            msg = str(exc)  # the key the message is about: the one named first (not one in a list of allowed keys)
            found = sorted((msg.find(f"placement.{k}") if f"placement.{k}" in msg else msg.find(k), k)
                           for k in table if k in msg)
            key = found[0][1] if found else None
            raise ctx.error(str(exc), key) from None


@register_section("criteria")
@dataclass
class CriteriaSection:
    """``[criteria]``: ``mode`` (``any``|``all``), ``max_cycles`` and thresholds by criterion name."""

    criteria: EndCriteria

    @classmethod
    def schema_keys(cls) -> dict:
        """``mode``, ``max_cycles`` and one threshold per registered criterion (its kind and unit)."""
        from ...scenario.reference import quantity_schema
        from ..criteria import criteria as registry

        out = {"mode": {"type": "string", "enum": ["any", "all"], "default": "any"},
               "max_cycles": {"type": "integer", "default": 50}}
        for name in registry.available():
            c = registry.get(name)
            spec = quantity_schema(c.kind, default_unit="" if c.kind == "dimensionless" else None, nonnegative=True,
                                   sweep=False)
            opts = {"type": "object", "description": "keyword arguments of the criterion"}
            if hasattr(c, "option_schema"):  # a criterion that describes its keyword table
                opts["properties"] = c.option_schema()
                opts["additionalProperties"] = False
            spec["anyOf"].append(opts)
            spec["description"] = f"threshold ({c.compare} it counts as met; unit {c.units}) {c.description}".strip()
            out[name] = spec
        return out

    @classmethod
    def from_table(cls, table, ctx):
        if "seepage_fraction" in table:
            import warnings

            warnings.warn(f"{_where(ctx, 'seepage_fraction')}: [criteria] seepage_fraction: deprecated; write "
                          "polder_leakage = \"1 cm/day\" (what still flows through the dam as the rise of the [polder] "
                          "area per day, net of its pumps; with seal = [...] for a leaky rock dam)",
                          DeprecationWarning, stacklevel=2)
        try:
            return cls(EndCriteria.from_config(table))
        except (BreachflowError, TypeError, ValueError) as exc:
            key = next((k for k in table if k in str(exc)), None)
            raise ctx.error(str(exc), key) from None


@register_section("closure")
@dataclass
class ClosureSection:
    """``[closure]``: ``remap`` (``porous``, the default: a leaky rock-fill pile | ``raised_bed`` |
    ``no_flow``), ``seed``, ``porous_law`` (the flow law of a porous pile, :mod:`~breachflow.swe.porous_laws`:
    ``ergun``, the default | ``van_gent`` | ``ergun_dilute``), ``area`` (the breach area ``[x0, x1, y0, y1]``
    outside which masses count as carried away and where ``max_speed`` judges the flow; default from the scene, see
    :mod:`~breachflow.cycle.losses`), ``loss_limit`` (fraction of a cycle's placement whose loss — whenever its masses
    leave — in a flow faster than the masses withstand ends the run with a "not closable" verdict; also
    the fraction of all placed tonnage above which the losses are flagged; default 0.5), ``pile_sampling`` (how the pile enters ``raised_bed`` / ``no_flow``:
    ``centre``, the default: the sphere top above each cell centre | ``cell_average``: the cell average of
    the pile top, blocked where it stands above the water over half the cell, :mod:`~breachflow.cycle.remap`).
    The closure in time: ``method`` (a delivery method, :mod:`~breachflow.cycle.delivery`), ``start`` (after
    the breach), ``breach_date`` and the method's overrides ``capacity``, ``working_hours``, ``wind_limit``,
    ``unit_mass``, and ``flood`` (``"follow"`` | ``"frozen"``: the levels held, :mod:`~breachflow.cycle.frozen_timeline`)
    (:mod:`~breachflow.cycle.config.timeline`, :mod:`~breachflow.cycle.timeline`)."""

    remap: str = "porous"
    seed: int = 0
    area: tuple | None = None
    loss_limit: float = LOSS_LIMIT
    porous_law: str = POROUS_LAWS.default
    pile_sampling: str = "centre"
    timeline: TimelineKeys = field(default_factory=TimelineKeys)

    @classmethod
    def extra_schema_keys(cls) -> dict:
        """The time-coupling keys (:meth:`~breachflow.cycle.config.timeline.TimelineKeys.schema_keys`)."""
        return TimelineKeys.schema_keys()

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"remap", "seed", "area", "loss_limit", "porous_law", "pile_sampling", *TIMELINE_KEYS})
        area = None
        if "area" in table:
            val = ctx.raw(table, "area", types=(list,))
            if len(val) != 4:
                raise ctx.error(f"area must be [x0, x1, y0, y1], got {val!r}", "area")
            area = tuple(float(v) for v in ctx.quantity({"area": val}, "area", "length", dim="area").values)
            if not (area[0] < area[1] and area[2] < area[3]):
                raise ctx.error(f"area must be [x0, x1, y0, y1] with x0 < x1 and y0 < y1, got {val!r}", "area")
        loss = ctx.quantity(table, "loss_limit", "dimensionless", default=LOSS_LIMIT, default_unit="",
                            positive=True)
        out = cls(ctx.raw(table, "remap", default="porous"), ctx.raw(table, "seed", types=(int,), default=0),
                  area, float(loss), ctx.raw(table, "porous_law", default=POROUS_LAWS.default),
                  ctx.raw(table, "pile_sampling", default="centre"))
        from ..remap import PILE_SAMPLINGS, REMAP_MODES

        if out.pile_sampling not in PILE_SAMPLINGS:
            raise ctx.error(f"{out.pile_sampling!r} unknown; pile_sampling must be one of {PILE_SAMPLINGS}",
                            "pile_sampling")

        if out.remap not in REMAP_MODES:
            raise ctx.error(f"{out.remap!r} unknown; remap must be one of {REMAP_MODES}", "remap")
        if out.porous_law not in POROUS_LAWS:
            raise ctx.error(f"{out.porous_law!r} unknown; porous_law must be one of {POROUS_LAWS.available()}",
                            "porous_law")
        out.timeline = TimelineKeys.from_table(table, ctx)
        return out
