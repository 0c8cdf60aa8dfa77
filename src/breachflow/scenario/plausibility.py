"""Plausible ranges of scenario inputs: impossible or absurd values are refused before anything runs.

A value can be a valid quantity of the right dimension and still be nonsense: ``length = "5 parsecs"`` is a
length, ``batch = 10000000`` is a whole number. Such values used to reach the solvers and end in a
50-line ``Unable to allocate 1.07 EiB`` traceback, an hour-long hang, or a confident but meaningless answer.
:data:`RANGES` lists, for each quantity of a scenario file that sizes an allocation or a computation or that
a physical argument bounds, the plausible range in SI units and why; :func:`check_scenario` (called once,
by :func:`breachflow.scenario.config.parse_scenario`, for every scenario: ``run``, ``window --scenario``,
every ensemble member) refuses a value outside it with a :class:`~breachflow.errors.ParseError` naming
the file, line, key and value. :func:`check_value` does the same for a command-line option, and
:func:`~breachflow.limits.check_grid_size` refuses a hydrodynamic grid too large to allocate before it is allocated.

The bounds are wide on purpose (an order of magnitude or more beyond the cases the model was built and
tested for): they catch unit mix-ups and typos, not unusual sites. docs/run-safety.md lists them with
their reasons.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import BreachflowError, InputError, ParseError
from ..limits import MAX_CELLS, MAX_PARTICLES, check_grid_size  # noqa: F401  (re-exported)
from .quantities import si_input


@dataclass(frozen=True)
class Bound:
    """The plausible range ``lo <= value <= hi`` (SI) of one key, the unit to show it in, and why."""

    kind: str
    lo: float
    hi: float
    unit: str
    why: str
    default_unit: str | None = None

    def show(self, v: float) -> str:
        from ..units import ureg

        if self.unit in ("", "1"):
            return f"{v:.6g}"
        si = {"length": "m", "area": "m**2", "speed": "m/s", "discharge": "m**3/s", "time": "s", "density": "kg/m**3",
              "rate": "m/s", "1/s": "1/s"}.get(self.kind, "")
        try:
            q = ureg.Quantity(v, si).to(self.unit).magnitude if si else v
        except Exception:  # noqa: BLE001
            q = v
        return f"{q:.6g} {self.unit}"


_BREACH = "a levee breach is metres to a few kilometres long (Upper Jones Tract, 2004: about 90 m, Harder 2012)"
_HEIGHT = "levees and their breaches are metres to a few tens of metres high"
_EXTENT = "the simulated site reaches metres to kilometres from the breach"
_MASS = ("dumped closure masses are stones, blocks or bags of centimetres to metres (EN 13383 gradings: "
         "5 kg to 15 t); a smaller mass is carried off by any closure flow and needs a DEM time step too short "
         "to run; the largest units placed in a gap are caissons of tens of metres")

#: (section, key) → plausible range. Keys of a list value (a sweep, a diameter range) are checked item by item.
RANGES: dict[tuple[str, str], Bound] = {
    ("breach", "length"): Bound("length", 0.5, 10_000.0, "m", _BREACH),
    ("breach", "depth"): Bound("length", 0.05, 50.0, "m", _HEIGHT),
    ("breach", "scour_depth"): Bound("length", 0.0, 50.0, "m", _HEIGHT),
    ("breach", "discharge"): Bound("discharge", 0.0, 1.0e5, "m^3/s",
                                   "a breach carries part of a river's or an estuary's flow; the bound lies above "
                                   "the peak discharge of the largest rivers"),
    ("breach", "mean_velocity"): Bound("speed", 0.0, 20.0, "m/s",
                                       "flow through a breach is driven by metres of head: sqrt(2 g h) for 20 m of head "
                                       "is about 20 m/s"),
    ("breach", "development_time"): Bound("time", 0.0, 365 * 86400.0, "h", "a breach develops in hours to days"),
    ("levee", "height"): Bound("length", 0.1, 50.0, "m", _HEIGHT),
    ("levee", "crown_width"): Bound("length", 0.0, 200.0, "m", "a levee crown is metres to tens of metres wide"),
    ("levee", "flood_slope"): Bound("dimensionless", 0.0, 50.0, "", "levee slopes are 1V:0H (a wall) to about 1V:10H"),
    ("levee", "protected_slope"): Bound("dimensionless", 0.0, 50.0, "", "levee slopes are 1V:0H (a wall) to about 1V:10H"),
    ("polder", "area"): Bound("area", 1.0e3, 1.0e11, "ha",
                              "a polder is hectares to thousands of km²"),
    ("polder", "inundation_depth"): Bound("length", 0.001, 30.0, "m", "a permissible inundation depth is centimetres to metres"),
    ("polder", "pump_capacity"): Bound("discharge", 0.0, 1.0e5, "m^3/s", "pumping stations move up to thousands of m³/s"),
    ("flood", "surge_height"): Bound("length", 0.0, 30.0, "m", "the highest storm surges and river floods are metres to about ten metres"),
    ("flood", "rise_rate"): Bound("rate", 0.0, 10.0 / 3600.0, "m/hr", "flood stages change by centimetres to a metre or two per hour"),
    ("flood", "fall_rate"): Bound("rate", 0.0, 10.0 / 3600.0, "m/hr", "flood stages change by centimetres to a metre or two per hour"),
    ("flood", "duration"): Bound("time", 0.0, 365 * 86400.0, "day", "a flood lasts hours to months"),
    ("site", "breach_length"): Bound("length", 0.5, 10_000.0, "m", _BREACH),
    ("site", "levee_length_each_side"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "flood_side_extent"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "protected_side_extent"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "flood_channel_length"): Bound("length", 0.0, 100_000.0, "m", _EXTENT),
    ("site", "extent_along"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "extent_flood"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "extent_protected"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("site", "ground_elevation"): Bound("length", -500.0, 9_000.0, "m",
                                        "the lowest and the highest land on Earth lie within this range"),
    ("site", "flood_water_elevation"): Bound("length", -500.0, 9_000.0, "m",
                                             "the lowest and the highest land on Earth lie within this range"),
    ("site", "manning_n"): Bound("manning", 0.005, 0.3, "s/m^(1/3)",
                                 "Manning's n of natural and lined channels lies between about 0.01 and 0.2"),
    ("hydro", "resolution"): Bound("length", 0.02, 1_000.0, "m",
                                   "the breach must span cells, and a cell much smaller than the masses resolves nothing more"),
    ("hydro", "refine"): Bound("length", 0.02, 1_000.0, "m", "as [hydro] resolution"),
    ("hydro", "monitor_radius"): Bound("length", 0.0, 20_000.0, "m", _EXTENT),
    ("hydro", "t_max_initial"): Bound("time", 0.0, 30 * 86400.0, "s", "a steady state is reached in minutes to hours of model time"),
    ("hydro", "t_max"): Bound("time", 0.0, 30 * 86400.0, "s", "a steady state is reached in minutes to hours of model time"),
    ("dem", "max_time"): Bound("time", 0.0, 86400.0, "s", "dumped masses come to rest in seconds to minutes"),
    ("placement", "diameter"): Bound("length", 0.05, 25.0, "m", _MASS),
    ("placement", "density"): Bound("density", 0.0, 8_000.0, "kg/m^3",
                                    "closure masses are sand bags, rock or concrete, at most steel (7,850 kg/m³); "
                                    "masses not heavier than water are refused by the closure's own check"),
    ("placement", "release_height"): Bound("length", 0.0, 100.0, "m", "masses are dropped from a crane, a barge or a helicopter"),
    ("placement", "batch"): Bound("count", 1, 2_000, "",
                                  "a cycle dumps what one truck, skip, barge or helicopter load holds; every mass of "
                                  "a batch is a DEM particle of every later cycle"),
    ("criteria", "max_cycles"): Bound("count", 1, 100_000, "", "each cycle is a flow solve and a DEM run"),
}


#: command-line option name → (section, key) of :data:`RANGES` (``breachflow window``)
OPTION_KEYS = {"breach_length": ("breach", "length"), "discharge": ("breach", "discharge"),
               "mean_velocity": ("breach", "mean_velocity"), "polder_area": ("polder", "area"),
               "inundation_depth": ("polder", "inundation_depth"), "pump_capacity": ("polder", "pump_capacity"),
               "surge_height": ("flood", "surge_height"), "rise_rate": ("flood", "rise_rate"),
               "fall_rate": ("flood", "fall_rate"), "flood_duration": ("flood", "duration")}


def _values(bound: Bound, raw, name: str) -> list[float]:
    """The SI values of a raw TOML value (a scalar or a list of them)."""
    if bound.kind == "count":
        items = raw if isinstance(raw, list) else [raw]
        return [float(v) for v in items if isinstance(v, (int, float)) and not isinstance(v, bool)]
    unit = {"dimensionless": "", "manning": "s/m**(1/3)"}.get(bound.kind)  # as the sections read them
    v = si_input(raw, name=name, kind=bound.kind, default_unit=unit)
    return [float(x) for x in np.atleast_1d(np.asarray(getattr(v, "values", v), float)).ravel()]


def violation(section: str, key: str, raw, *, label: str | None = None) -> str | None:
    """Why the raw value of ``[section] key`` is implausible (None when plausible or not ranged)."""
    bound = RANGES.get((section, key))
    if bound is None:
        return None
    label = label or f"[{section}] {key}"
    try:
        vals = _values(bound, raw, label)
    except BreachflowError:
        return None  # not a quantity: the section's own parser reports it
    for v in vals:
        if not math.isfinite(v):
            return f"{label} = {_shown(raw)} is not a finite number"
        if not bound.lo <= v <= bound.hi:
            shown = "" if bound.kind == "count" else f" ({bound.show(v)})"
            return (f"{label} = {_shown(raw)}{shown} is outside the plausible range "
                    f"{bound.show(bound.lo)} to {bound.show(bound.hi)}: {bound.why}")
    return None


def _shown(raw) -> str:
    return repr(raw) if isinstance(raw, str) else str(raw)


def check_value(option: str, raw) -> None:
    """Refuse (:class:`~breachflow.errors.InputError`) an implausible value of command-line *option*."""
    if raw is None or option not in OPTION_KEYS:
        return
    why = violation(*OPTION_KEYS[option], raw, label=f"--{option.replace('_', '-')}")
    if why:
        raise InputError(why)


def check_scenario(data: dict, text: str, path=None) -> None:
    """Refuse the first implausible value of the parsed TOML *data* (a :class:`~breachflow.errors.ParseError`
    naming the file, line, key and value), and a run whose particle count (``batch × max_cycles``) or grid
    could not be held in memory."""
    from .toml import line_of as _line_of

    for (section, key), _ in RANGES.items():
        table = data.get(section)
        if not isinstance(table, dict) or key not in table:
            continue
        why = violation(section, key, table[key])
        if why:
            raise ParseError(why, path=path, line=_line_of(text, section, key))
    pl, cr = data.get("placement"), data.get("criteria")
    batch = pl.get("batch") if isinstance(pl, dict) else None
    cycles = cr.get("max_cycles") if isinstance(cr, dict) else None
    if isinstance(batch, int) and isinstance(cycles, int) and batch * cycles > MAX_PARTICLES:
        raise ParseError(f"[placement] batch = {batch} with [criteria] max_cycles = {cycles} makes up to "
                         f"{batch * cycles:,} masses; a run holds at most {MAX_PARTICLES:,} (every cycle file stores "
                         f"every mass)", path=path, line=_line_of(text, "placement", "batch"))


