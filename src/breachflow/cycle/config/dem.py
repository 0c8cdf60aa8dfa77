"""The ``[dem]`` and ``[fluid]`` sections: the DEM of the dropped masses (material, integrator, rest
and cap) and the fluid forces on them (drag law, field sampling, velocity profile; docs/theory.md, *DEM contact*, *Fluid forces on a mass*)."""
from __future__ import annotations

from dataclasses import dataclass, field

from ...errors import BreachflowError, InputError
from ...scenario.config import register_section


@register_section("dem")
@dataclass
class DemSection:
    """``[dem]``: material (``kn``, ``ks``, ``friction``, ``rolling_friction``, ``adhesion``, ``restitution``, ``global_damping``)
    and run control (``integrator``, ``e_tol``, ``max_time`` per cycle (safety cap), ``rest_speed``, ``rest_time``,
    ``rest_rule`` (``window`` | ``speed``: which masses are the pile at the cap, :mod:`~breachflow.cycle.rest`),
    ``record_interval``, ``sleeping``, ``stability_time``)."""

    values: dict = field(default_factory=dict)

    #: material defaults of a closure run (SI); the rest of the defaults are :class:`~.driver.DemSettings`'
    MATERIAL_DEFAULTS = {"kn": 2.0e7, "friction": 0.6, "rolling_friction": 0.3, "adhesion": 0.0}

    @classmethod
    def schema_defaults(cls) -> dict:
        """Default of every key (SI values with their unit), for the scenario reference."""
        from ...units import SI_UNITS
        from ..driver import DemSettings

        d = DemSettings()
        vals = {**{k: getattr(d, k) for k in cls.KINDS if hasattr(d, k)}, **cls.MATERIAL_DEFAULTS,
                "integrator": d.integrator, "sleeping": d.sleeping, "rest_rule": d.rest_rule}
        out = {}
        for k, v in vals.items():
            unit = SI_UNITS.get(cls.KINDS.get(k, ""), "")
            out[k] = v if isinstance(v, (bool, str)) or not unit else f"{v:g} {unit}"
        out["ks"] = "kn (Material default: equal stiffnesses, as the report)"
        return out

    KINDS = {"kn": "stiffness", "ks": "stiffness", "friction": "dimensionless", "rolling_friction": "dimensionless",
             "adhesion": "force",
             "restitution": "dimensionless", "global_damping": "damping", "e_tol": "length", "max_time": "time",
             "rest_speed": "speed", "record_interval": "time", "stability_time": "time", "rest_time": "time"}

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, set(cls.KINDS) | {"integrator", "sleeping", "rest_rule"})
        vals = {k: ctx.quantity(table, k, kind, default_unit="" if kind == "dimensionless" else None, nonnegative=True)
                for k, kind in cls.KINDS.items() if k in table}
        if "integrator" in table:
            vals["integrator"] = ctx.raw(table, "integrator")
        if "sleeping" in table:
            vals["sleeping"] = ctx.raw(table, "sleeping", types=(bool,))
        if "rest_rule" in table:
            from ..rest import REST_RULES

            vals["rest_rule"] = ctx.raw(table, "rest_rule")
            try:
                REST_RULES.get(vals["rest_rule"])
            except InputError as exc:
                raise ctx.error(str(exc), "rest_rule") from None
        return cls(vals)


@register_section("fluid")
@dataclass
class FluidSection:
    """``[fluid]``: ``drag_law`` (registry name), ``sampling`` (``bilinear`` | ``neighbourhood``), ``xi``,
    ``velocity_profile`` (``log`` (default) | ``power`` | ``uniform``, :mod:`breachflow.fluid.profile`;
    the log law follows Shields' depth dependence in the stone-stability validation, docs/validation.md) and
    ``roughness`` (k_s of the log law; default from the site's Manning n)."""

    drag_law: str = "report"
    sampling: str = "bilinear"
    xi: float = 0.5
    velocity_profile: str = "log"
    roughness: float | None = None

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"drag_law", "sampling", "xi", "velocity_profile", "roughness"})
        out = cls(ctx.raw(table, "drag_law", default="report"), ctx.raw(table, "sampling", default="bilinear"),
                  ctx.quantity(table, "xi", "dimensionless", default=0.5, default_unit="", nonnegative=True),
                  ctx.raw(table, "velocity_profile", default="log"),
                  ctx.quantity(table, "roughness", "length", default=None, default_unit="m", positive=True))
        from ...fluid.drag import get_drag_law
        from ...fluid.profile import PROFILES

        if out.velocity_profile not in PROFILES:
            raise ctx.error(f"velocity_profile must be one of {sorted(PROFILES)}", "velocity_profile")

        try:
            get_drag_law(out.drag_law)
        except BreachflowError as exc:
            raise ctx.error(str(exc), "drag_law") from None
        return out
