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
from ...fluid.bed import BED_KINDS, Z_STAR, BedRoughness, ProtectionRegion
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
    #: a bottom protection over part of the bed (:class:`~breachflow.fluid.bed.ProtectionRegion`; None: none)
    protection: ProtectionRegion | None = None
    #: an erodible bed: lower the terrain by the Meyer-Peter–Müller / Exner bed change of each cycle's flow
    #: before the next re-solve (:func:`breachflow.cycle.scour.cycle_bed_change`)
    bed_change: bool = True
    #: explicit Exner steps per cycle at most (the flow time reached is reported)
    bed_change_steps: int = 2000

    def describe(self) -> str:
        """The bed model in words, for the verdict and the run's summary."""
        r = self.roughness
        if r.kind == "smooth" and self.protection is None:
            words = "smooth bed (no grain roughness)"
        elif r.kind == "protection":
            words = f"bottom protection of {_mm(r.grain_size)} stones, {r.thickness:g} m thick, over the whole bed"
        else:
            words = f"natural bed of {_mm(r.grain_size)} grains"
        if self.protection is not None:
            p = self.protection
            where = (f"box x {p.box[0]:g}..{p.box[1]:g} m, y {p.box[2]:g}..{p.box[3]:g} m" if p.box is not None
                     else f"a polygon of {len(p.polygon)} vertices")
            words += f", bottom protection of {_mm(p.grain_size)} stones ({p.thickness:g} m) over {where}"
        if self.erodible:
            words += ", erodible" + (" (the terrain follows the Exner bed change between cycles)" if self.bed_change
                                     else " (scour estimated, terrain fixed)")
        else:
            words += ", not erodible"
        return words


def _mm(d: float) -> str:
    return f"{d * 1000:g} mm" if d < 0.01 else (f"{d * 100:g} cm" if d < 1.0 else f"{d:g} m")


@register_section("bed")
@dataclass
class BedSection:
    """``[bed]``: ``kind`` (``natural`` | ``protection`` | ``smooth``; default ``natural`` when ``grain_size`` is
    given), ``grain_size`` (d of the bed or the protection's stones), ``thickness`` (protection layer),
    ``z_star`` (pivot-angle offset, Wiberg & Smith 1987), ``roughness`` (k_s, default 2 grain_size);
    near-bed forces: ``near_bed`` (true), ``lift_coefficient`` (0.2), ``peak_factor`` (calibrated,
    :data:`~breachflow.fluid.nearbed.PEAK_FACTOR`), ``turbulence_intensity`` (2.30), ``turbulence_decay`` (1);
    erosion: ``erodible`` (false: no scour estimate), ``bed_change`` (true: an erodible terrain follows the
    Meyer-Peter–Müller / Exner bed change of each cycle's flow), ``bed_change_steps`` (2000, explicit Exner steps
    per cycle at most); ``protection`` a bottom protection over a region, ``{ grain_size, thickness, box =
    [x0, x1, y0, y1] | polygon = [[x, y], ...] }`` in the grid's coordinates (breach centre x = 0, levee line
    y = 0), on a natural bed of ``grain_size``."""

    settings: BedSettings = field(default_factory=BedSettings)

    KEYS = {"kind", "grain_size", "thickness", "z_star", "roughness", "near_bed", "lift_coefficient", "peak_factor",
            "turbulence_intensity", "turbulence_decay", "erodible", "protection", "bed_change", "bed_change_steps"}
    PROTECTION_KEYS = {"grain_size", "thickness", "box", "polygon"}

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, cls.KEYS - {"protection"}, subtables=("protection",))
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
        prot = cls._protection(table, ctx)
        if prot is not None and kind == "protection":
            raise ctx.error("kind = \"protection\" covers the whole bed; a protection over a region goes with "
                            "kind = \"natural\" (the bed around it)", "protection")
        if prot is not None and d is None:
            raise ctx.error("a protection over a region needs the natural bed's grain_size around it", "protection")
        change = ctx.raw(table, "bed_change", types=(bool,), default=True)
        steps = ctx.raw(table, "bed_change_steps", types=(int,), default=2000)
        if isinstance(steps, bool) or steps < 1:
            raise ctx.error(f"bed_change_steps = {steps!r}: needs at least 1", "bed_change_steps")
        return cls(BedSettings(rough, bedp, bool(erodible), prot, bool(change), int(steps)))

    @classmethod
    def _protection(cls, table, ctx):
        """``protection = { grain_size, thickness, box = [x0, x1, y0, y1] | polygon = [[x, y], ...] }`` (m)."""
        sub = table.get("protection")
        if sub is None:
            return None
        if not isinstance(sub, dict):
            raise ctx.error(f"protection must be a table {{ grain_size, thickness, box | polygon }}, got {sub!r}",
                            "protection")
        unknown = set(sub) - cls.PROTECTION_KEYS
        if unknown:
            raise ctx.error(f"protection: unknown key(s) {sorted(unknown)}; allowed {sorted(cls.PROTECTION_KEYS)}",
                            "protection")
        from ...units import to_si

        def length(v, what):
            try:
                return float(to_si(v, name=f"bed.protection.{what}", kind="length", default_unit="m"))
            except InputError as exc:
                raise ctx.error(str(exc), "protection") from None

        if "grain_size" not in sub:
            raise ctx.error("protection needs its stones' grain_size", "protection")
        dp = length(sub["grain_size"], "grain_size")
        th = length(sub.get("thickness", sub["grain_size"]), "thickness")

        def coords(v, what, n=None):
            if not isinstance(v, (list, tuple)) or (n is not None and len(v) != n):
                raise ctx.error(f"protection.{what} = {v!r}: needs {n or 'a list of'} lengths", "protection")
            return tuple(length(c, what) for c in v)

        box = coords(sub["box"], "box", 4) if "box" in sub else None
        poly = tuple(coords(p, "polygon", 2) for p in sub["polygon"]) if "polygon" in sub else None
        try:
            return ProtectionRegion(dp, th, box, poly)
        except InputError as exc:
            raise ctx.error(str(exc), "protection") from None
