"""The ``[bed]`` section: the breach floor as a rough bed (natural bed or bottom protection) under the masses,
the near-bed flow forces on them (exposed height, lift, turbulent velocity peaks), and the erodible bed's
scour estimate. Physics, sources and calibration: ``docs/bed-and-forces.md``.

Without a ``[bed]`` section a run keeps the smooth terrain and the centre-height flow of earlier versions.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError
from ...fluid import nearbed as NB
from ...fluid.bed import BED_KINDS, Z_STAR, BedRoughness
from ...scenario.config import register_section


@dataclass
class BedSettings:
    """What the closure run takes from ``[bed]``: the terrain's :class:`~breachflow.fluid.bed.BedRoughness`,
    the near-bed parameter vector (:func:`breachflow.fluid.nearbed.parameters`; None: off) and the erosion
    setting (``erodible``: the per-cycle scour estimate of :mod:`breachflow.cycle.scour` with the bed's grain
    size)."""

    roughness: BedRoughness = field(default_factory=BedRoughness)
    near_bed: np.ndarray | None = None
    erodible: bool = False


@register_section("bed")
@dataclass
class BedSection:
    """``[bed]``: ``kind`` (``natural`` | ``protection`` | ``smooth``; default ``natural`` when ``grain_size`` is
    given), ``grain_size`` (d of the bed or the protection's stones), ``thickness`` (protection layer),
    ``z_star`` (pivot-angle offset, Wiberg & Smith 1987), ``roughness`` (k_s, default 2 grain_size);
    near-bed forces: ``near_bed`` (true), ``lift_coefficient`` (0.2), ``peak_factor`` (calibrated,
    :data:`~breachflow.fluid.nearbed.PEAK_FACTOR`), ``turbulence_intensity`` (2.30), ``turbulence_decay`` (1);
    erosion: ``erodible`` (false: no scour estimate)."""

    settings: BedSettings = field(default_factory=BedSettings)

    KEYS = {"kind", "grain_size", "thickness", "z_star", "roughness", "near_bed", "lift_coefficient", "peak_factor",
            "turbulence_intensity", "turbulence_decay", "erodible"}

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, cls.KEYS)
        d = ctx.quantity(table, "grain_size", "length", default=None, default_unit="m", positive=True)
        kind = ctx.raw(table, "kind", default="natural" if d is not None else "smooth")
        if kind not in BED_KINDS:
            raise ctx.error(f"kind must be one of {list(BED_KINDS)}, got {kind!r}", "kind")
        thick = ctx.quantity(table, "thickness", "length", default=None, default_unit="m", positive=True)
        z_star = ctx.quantity(table, "z_star", "dimensionless", default=Z_STAR, default_unit="")
        ks = ctx.quantity(table, "roughness", "length", default=None, default_unit="m", positive=True)
        try:
            rough = BedRoughness(kind, float(d or 0.0), float(thick if thick is not None else (d or 0.0)),
                                 float(z_star), ks)
        except InputError as exc:
            raise ctx.error(str(exc), "kind" if d is not None else "grain_size") from None
        on = ctx.raw(table, "near_bed", types=(bool,), default=True)
        cl = ctx.quantity(table, "lift_coefficient", "dimensionless", default=NB.LIFT_COEFFICIENT, default_unit="",
                          nonnegative=True)
        kp = ctx.quantity(table, "peak_factor", "dimensionless", default=NB.PEAK_FACTOR, default_unit="",
                          nonnegative=True)
        du = ctx.quantity(table, "turbulence_intensity", "dimensionless", default=NB.NEZU_DU, default_unit="",
                          nonnegative=True)
        ck = ctx.quantity(table, "turbulence_decay", "dimensionless", default=NB.NEZU_CK, default_unit="",
                          nonnegative=True)
        bedp = NB.parameters(lift={"coefficient": cl},
                             turbulence={"peak_factor": kp, "intensity": du, "decay": ck}) if on else None
        erodible = ctx.raw(table, "erodible", types=(bool,), default=False)
        if erodible and d is None:
            raise ctx.error("an erodible bed needs its grain_size", "erodible")
        return cls(BedSettings(rough, bedp, bool(erodible)))
