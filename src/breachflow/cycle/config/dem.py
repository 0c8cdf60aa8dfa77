"""The ``[dem]`` and ``[fluid]`` sections: the DEM of the dropped masses (material, integrator, rest
and cap) and the fluid forces on them (drag law, field sampling, velocity profile; docs/theory.md, *DEM contact*, *Fluid forces on a mass*)."""
from __future__ import annotations

from dataclasses import dataclass, field

from ...errors import BreachflowError, InputError
from ...scenario.config import register_section
from ..driver import DemSettings


@register_section("dem")
@dataclass
class DemSection:
    """``[dem]``: material (``kn``, ``ks``, ``friction``, ``rolling_friction``, ``adhesion``, ``restitution``, ``global_damping``)
    and run control (``integrator``, ``e_tol``, ``max_time`` per cycle (safety cap), ``rest_speed``, ``rest_time``,
    ``rest_rule`` (``mean_speed`` | ``speed``: which masses are the pile at the cap, :mod:`~breachflow.cycle.rest`),
    ``record_interval``, ``sleeping``, ``stability_time``)."""

    values: dict = field(default_factory=dict)

    #: material defaults of a closure run (SI); the rest of the defaults are :class:`~.driver.DemSettings`'
    MATERIAL_DEFAULTS = {"kn": 2.0e7, "friction": 0.6, "rolling_friction": 0.3, "adhesion": 0.0}

    @classmethod
    def schema_defaults(cls) -> dict:
        """Default of every key (SI values with their unit), for the scenario reference."""
        from ...units import SI_UNITS

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
            from ..rest import REST_RULES, RENAMED_RULES

            table = ctx.renamed(table, "rest_rule", values=RENAMED_RULES)
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

    # the defaults of a closure run, defined once (DemSettings)
    drag_law: str = DemSettings.drag_law
    sampling: str = DemSettings.sampling
    xi: float = DemSettings.xi
    velocity_profile: str = DemSettings.velocity_profile
    roughness: float | None = DemSettings.roughness

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"drag_law", "sampling", "xi", "velocity_profile", "roughness"})
        out = cls(ctx.raw(table, "drag_law", default=cls.drag_law), ctx.raw(table, "sampling", default=cls.sampling),
                  ctx.quantity(table, "xi", "dimensionless", default=cls.xi, default_unit="", nonnegative=True),
                  ctx.raw(table, "velocity_profile", default=cls.velocity_profile),
                  ctx.quantity(table, "roughness", "length", default=cls.roughness, default_unit="m", positive=True))
        from ...fluid.drag import DRAG_LAWS
        from ...fluid.profile import velocity_profiles

        if not isinstance(out.velocity_profile, str) or out.velocity_profile not in velocity_profiles:
            raise ctx.error(f"velocity_profile must be one of {velocity_profiles.available()}", "velocity_profile")

        try:
            DRAG_LAWS.create(out.drag_law)
        except BreachflowError as exc:
            raise ctx.error(str(exc), "drag_law") from None
        return out
