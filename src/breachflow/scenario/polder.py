"""The polder (the protected area behind the breach): the ``[polder]`` section and its water balance.

The polder fills with the breach discharge and is drained by its pumps. Its water level ``z_P``
(m, the datum of the bed) follows the volume balance

    dV/dt = Q_breach(t) - Q_pump,        V = V(z_P)

with ``V(z) = A (z - z_0)`` for a flat polder of area ``A`` (``area``, the report's ``A_P``, §2.4)
starting at ``z_0`` (``initial_level``), or a stage–storage curve ``V(z)`` read from a CSV file
(``storage_curve``: ``level [m], volume [m^3]``; e.g. integrated from a terrain model of the polder
outside this package). Equivalently ``dz_P/dt = (Q_breach - Q_pump) / A(z_P)`` with ``A(z) = dV/dz``.

:meth:`Polder.step` advances the level over an interval in which the inflow is constant (the
discharge of the last steady solve of a closure cycle): the balance is then exact in the volume,
``V(t + Δt) = V(t) + (Q - Q_pump) Δt``, and the level is read back from the curve. A level cannot
rise above the flood-side level that drives the inflow: the interval's step stops at the crossing
(the breach balance, report's ``t_Q``) and reports when it happened.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .config import register_section

#: level step of a stage–storage curve from the terrain (m)
DEFAULT_LEVEL_STEP = 0.1


def _region(ctx, value):
    """``[polder] region``: None, a box [x0, x1, y0, y1] or a polygon [[x, y], ...] (numbers, m)."""
    if value is None:
        return None

    def num(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)

    if isinstance(value, list) and len(value) == 4 and all(num(v) for v in value):
        if value[0] == value[1] or value[2] == value[3]:
            raise ctx.error(f"region box [x0, x1, y0, y1] has no area: {value!r}", "region")
        return [float(v) for v in value]
    if isinstance(value, list) and len(value) >= 3 and all(
            isinstance(p, list) and len(p) == 2 and all(num(v) for v in p) for p in value):
        return [[float(a), float(b)] for a, b in value]
    raise ctx.error(f"region must be a box [x0, x1, y0, y1] or a polygon [[x, y], ...] of at least three "
                    f"points (m, the terrain's coordinates), got {value!r}", "region")


@register_section("polder")
@dataclass
class PolderSection:
    """``[polder]``: ``area`` (the report's ``A_P``, e.g. ``"4900 ha"``), ``inundation_depth`` (``d_I``, the
    permissible mean depth; needed by the closure window), ``pump_capacity`` (``Q_P``, m³/s, default 0),
    ``initial_level`` (water level of the polder at the breach, m in the datum of the bed; default the
    protected-side ground of the site) and ``storage_curve`` (CSV ``level [m], volume [m^3]``: the
    polder's stage–storage curve, used instead of ``area`` for the water balance).

    ``storage = "terrain"``: the stage–storage curve from the terrain (:mod:`~breachflow.scenario.storage`):
    the flow model's terrain, or the GeoTIFF ``terrain``; only the cells inside ``region`` (a box
    ``[x0, x1, y0, y1]`` or a polygon ``[[x, y], ...]``, m in the terrain's coordinates; default the
    protected side of the levee in the flow model) that the water from the breach's landside cell reaches
    (``seed = [x, y]``: that cell in the GeoTIFF's coordinates, required with a GeoTIFF); levels every
    ``level_step`` (default 0.1 m). ``area`` is then optional (the region's plan area)."""

    area: Any
    inundation_depth: Any = None
    pump_capacity: Any = 0.0
    initial_level: Any = None
    storage_curve: Path | None = None
    storage: str | None = None  #: "terrain": the curve from the terrain
    terrain: Path | None = None  #: GeoTIFF of the polder (default: the flow model's terrain)
    region: Any = None  #: box [x0, x1, y0, y1] or polygon [[x, y], ...] (m, the terrain's coordinates)
    seed: tuple | None = None  #: the breach's landside cell [x, y] in the GeoTIFF's coordinates
    level_step: float = DEFAULT_LEVEL_STEP

    @classmethod
    def from_table(cls, table, ctx):
        ctx.check_keys(table, {"area", "inundation_depth", "pump_capacity", "initial_level", "storage_curve",
                               "storage", "terrain", "region", "seed", "level_step"})
        # every key is read first (the scenario reference records them), then checked
        storage = ctx.raw(table, "storage")
        out = cls(ctx.quantity(table, "area", "area", required=storage is None, positive=True, dim="polder_area"),
                  ctx.quantity(table, "inundation_depth", "length", positive=True),
                  ctx.quantity(table, "pump_capacity", "discharge", default="0 m^3/s", nonnegative=True),
                  ctx.quantity(table, "initial_level", "length"),
                  ctx.file(table, "storage_curve"), storage, ctx.file(table, "terrain"))
        step = ctx.quantity(table, "level_step", "length", default=f"{DEFAULT_LEVEL_STEP} m", positive=True)
        region = ctx.raw(table, "region", types=(list,))
        seed = ctx.raw(table, "seed", types=(list,))
        if storage is not None and storage != "terrain":
            raise ctx.error(f"unknown storage {storage!r}: \"terrain\" (the curve from the terrain), or leave it out "
                            f"(area, or storage_curve)", "storage")
        if storage is None:
            for key in ("terrain", "region", "seed", "level_step"):
                if key in table:
                    raise ctx.error(f"{key} = {table[key]!r} needs storage = \"terrain\"", key)
        elif "storage_curve" in table:
            raise ctx.error("give either storage = \"terrain\" or storage_curve, not both", "storage_curve")
        if storage is not None:
            out.region = _region(ctx, region)
            if seed is not None and not (len(seed) == 2 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in seed)):
                raise ctx.error(f"seed must be [x, y] (m, the terrain's coordinates), got {seed!r}", "seed")
            out.seed = None if seed is None else (float(seed[0]), float(seed[1]))
            if out.terrain is not None and out.seed is None:
                raise ctx.error(f"terrain = {table['terrain']!r} needs seed = [x, y]: the breach's landside cell in "
                                f"the GeoTIFF's coordinates", "terrain")
            if np.ndim(np.asarray(getattr(step, "values", step))) != 0:
                raise ctx.error("one level_step, not a list", "level_step")
            out.level_step = float(getattr(step, "values", step))
        if out.storage_curve is not None:
            try:
                read_storage_curve(out.storage_curve)
            except InputError as exc:
                raise ctx.error(str(exc), "storage_curve") from None
        return out

    def polder(self, ground_level: float, terrain=None) -> "Polder":
        """The :class:`Polder` of this section (scalar values; a swept ``area`` is refused), starting at
        ``initial_level`` or at *ground_level* (m) when none is given. *terrain* ``(bed, x, y, seed_xy,
        protected_mask)`` of the flow model: used by ``storage = "terrain"`` without a GeoTIFF."""
        vals = {}
        for key in ("area", "pump_capacity", "initial_level"):
            v = getattr(self, key)
            if v is not None and np.ndim(np.asarray(getattr(v, "values", v))) != 0:
                raise InputError(f"[polder] {key}: a closure run takes one value, not a list (sweep it with an ensemble)")
            vals[key] = None if v is None else float(getattr(v, "values", v))
        z0 = vals["initial_level"] if vals["initial_level"] is not None else float(ground_level)
        curve = read_storage_curve(self.storage_curve) if self.storage_curve is not None else None
        area = vals["area"]
        if self.storage == "terrain":
            curve = self.terrain_curve(terrain)
            if area is None:  # the plan area of the curve's top: the whole region reached
                area = float((curve[1][-1] - curve[1][-2]) / (curve[0][-1] - curve[0][-2]))
        return Polder(area=area, pump_capacity=vals["pump_capacity"], initial_level=z0, curve=curve)

    def terrain_curve(self, terrain=None) -> tuple[np.ndarray, np.ndarray]:
        """``(levels, volumes)`` of ``storage = "terrain"`` from *terrain* ``(bed, x, y, seed_xy, protected_mask)``:
        the GeoTIFF ``terrain`` as read by the caller (``seed_xy`` and ``protected_mask`` None), or the flow
        model's terrain. ``seed`` and ``region`` of the section, when given, replace the seed and the mask."""
        from .storage import terrain_storage_curve

        if terrain is None:
            raise InputError("[polder] storage = \"terrain\": no terrain to integrate (give terrain = a GeoTIFF "
                             "and seed = [x, y], or use the embedded flow model, [hydro] solver = \"swe\")")
        bed, x, y, seed_xy, protected = terrain
        seed = seed_xy if self.seed is None else self.seed
        if seed is None:
            raise InputError("[polder] storage = \"terrain\": seed = [x, y] (the breach's landside cell) is required "
                             "with a GeoTIFF terrain")
        return terrain_storage_curve(bed, x, y, seed, region=self.region, level_step=self.level_step,
                                     mask=protected if self.region is None else None)


def read_storage_curve(path) -> tuple[np.ndarray, np.ndarray]:
    """``(levels m, volumes m³)`` of a stage–storage CSV (``level [m], volume [m^3]``; units converted);
    volumes must not decrease with the level and the levels must increase."""
    from .hydrograph import _unit_scale
    import csv

    path = Path(path)
    rows = [r for r in csv.reader(path.read_text().splitlines()) if r and not r[0].lstrip().startswith("#")]
    if len(rows) < 3:
        raise InputError(f"{path}: a storage curve needs a header 'level [m], volume [m^3]' and at least two rows")
    from .hydrograph import _HEADER

    heads = [_HEADER.match(h) for h in rows[0]]
    if len(heads) != 2 or not all(heads):
        raise InputError(f"{path}: header must be 'level [unit], volume [unit]', got {rows[0]}")
    sl = _unit_scale(heads[0].group(2), "length", "level", path, 1)
    sv = _unit_scale(heads[1].group(2), "volume", "volume", path, 1)
    try:
        data = np.array([[float(a), float(b)] for a, b in rows[1:]], float)
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from None
    z, v = data[:, 0] * sl[0] + sl[1], data[:, 1] * sv[0]
    if not (np.all(np.diff(z) > 0) and np.all(np.diff(v) >= 0)):
        raise InputError(f"{path}: levels must increase and volumes must not decrease")
    return z, v


@dataclass
class Polder:
    """The water balance of a polder (SI): flat (``area``) or a stage–storage ``curve`` (levels, volumes).

    ``volume(z)`` is the stored volume above ``initial_level`` (0 there); beyond the curve's last point
    the curve continues with its last plan area."""

    area: float
    pump_capacity: float = 0.0
    initial_level: float = 0.0
    curve: tuple | None = None

    def __post_init__(self):
        if not (self.area is not None and self.area > 0):
            raise InputError(f"polder area must be > 0 m², got {self.area!r}")
        if not self.pump_capacity >= 0:
            raise InputError(f"polder pump_capacity must be >= 0 m³/s, got {self.pump_capacity!r}")
        self._v0 = 0.0
        if self.curve is not None:
            self._v0 = float(self._curve_volume(self.initial_level))

    def _curve_volume(self, z):
        zc, vc = self.curve
        z = np.asarray(z, float)
        a_top = (vc[-1] - vc[-2]) / (zc[-1] - zc[-2])
        a_bot = (vc[1] - vc[0]) / (zc[1] - zc[0])
        return np.where(z > zc[-1], vc[-1] + a_top * (z - zc[-1]),
                        np.where(z < zc[0], vc[0] + a_bot * (z - zc[0]), np.interp(z, zc, vc)))

    def volume(self, level) -> float:
        """Stored volume (m³) at *level* relative to the initial level."""
        if self.curve is None:
            return float(self.area * (level - self.initial_level))
        return float(self._curve_volume(level)) - self._v0

    def level(self, volume) -> float:
        """Water level (m) holding *volume* (m³, relative to the initial level)."""
        if self.curve is None:
            return float(self.initial_level + volume / self.area)
        zc, vc = self.curve
        target = float(volume) + self._v0
        if target > vc[-1]:
            a_top = (vc[-1] - vc[-2]) / (zc[-1] - zc[-2])
            return float(zc[-1] + (target - vc[-1]) / a_top)
        if target < vc[0]:
            a_bot = (vc[1] - vc[0]) / (zc[1] - zc[0])
            return float(zc[0] + (target - vc[0]) / a_bot)
        return float(np.interp(target, vc, zc))

    def plan_area(self, level) -> float:
        """Plan area A(z) = dV/dz (m²) at *level*."""
        if self.curve is None:
            return float(self.area)
        dz = 1e-3
        return (float(self._curve_volume(level + dz)) - float(self._curve_volume(level - dz))) / (2 * dz)

    def rise_per_day(self, discharge) -> float:
        """Rise of the level per day (m/day) with an inflow *discharge* (m³/s) less the pumps at the initial level."""
        return 86400.0 * (float(discharge) - self.pump_capacity) / self.plan_area(self.initial_level)

    def step(self, level: float, dt: float, discharge: float, flood=None):
        """Advance *level* over *dt* (s) with a constant inflow *discharge* (m³/s) less the pumps.

        *flood* ``(z_F(t), z_F(t + dt))``: the flood-side level at both ends of the interval (linear in
        between); the polder cannot rise above it: the step stops where the two meet. Returns
        ``(new_level, crossing)`` with *crossing* the time within the interval where the polder met the
        flood level (None when it did not)."""
        net = float(discharge) - self.pump_capacity
        v0 = self.volume(level)
        new = self.level(max(v0 + net * dt, self.volume(min(level, self.initial_level))))
        if flood is None or dt <= 0:
            return new, None
        f0, f1 = float(flood[0]), float(flood[1])
        if level >= f0:  # already at balance
            return min(new, f1) if net > 0 else new, 0.0
        if new < f1:
            return new, None
        # the crossing of z_P(t) (by the volume balance) with the linear flood level: bisection
        lo, hi = 0.0, dt
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            zp = self.level(v0 + net * mid)
            if zp >= f0 + (f1 - f0) * mid / dt:
                hi = mid
            else:
                lo = mid
        return f1, 0.5 * (lo + hi)
